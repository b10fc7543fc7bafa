"""The audit report: its parts from a small audit document, a NAV200 document without reflector
verdicts, and the page in headless Chromium (the evaluation report's browser check)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

from lgvtool.audit.audit_report import render_audit_report, write_audit_report
from lgvtool.audit.coverage import CoverageSettings, HeadTrack, coverage_section
from lgvtool.audit.visibility import DeviceView
from lgvtool.config import Reflector
from lgvtool.json_types import JSONObject

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evaluate"))
from test_report_browser import _check_page, browser, render

__all__ = ["browser"]  # the fixture, used by name

STATUSES = ["ok", "missing", "moved", "weak", "ambiguous", "ok"]


def _site() -> tuple[list[Reflector], HeadTrack, JSONObject]:
    # six reflectors round a 20 m x 10 m hall and a drive along its middle, out of reach of
    # all but two at its east end (range 9 m): a poor segment there
    layout = [Reflector(id=10 + i, x=x, y=y) for i, (x, y) in enumerate(
        [(0.0, 0.0), (0.0, 10.0), (8.0, 0.0), (8.0, 10.0), (20.0, 0.0), (20.0, 10.0)])]
    t = np.arange(0.0, 24.0, 0.125)
    track = HeadTrack.of(t, t * 0.8, np.full(len(t), 5.0), np.zeros(len(t)), name="hall-1",
                         reported_t=t, reported_used=np.full(len(t), 3))
    view = DeviceView.for_family("nav350", {"range_max_m": 9.0})
    cov = coverage_section(track, layout, view, CoverageSettings(cell_m=2.0))
    doc: JSONObject = {
        "logs": ["hall-1"],
        "reflectors": [
            {"id": r.id, "status": s, "expected_sightings": 180, "sightings": 0 if
             s == "missing" else 150, "residual_m": 0.004,
             "shift_m": [0.06, -0.03] if s == "moved" else [0.001, 0.0],
             "shift_sigma_m": [0.002, 0.002]}
            for r, s in zip(layout, STATUSES, strict=True)],
        "unmapped": [{"x": 14.0, "y": 9.9, "sightings": 40, "sigma_m": 0.02}],
        "coverage": cov,
    }
    return layout, track, doc


def _table(page: str, kind: str) -> str:
    found = re.search(rf'<table data-table="{kind}">(.*?)</table>', page, re.S)
    assert found is not None, f"no table {kind}"
    return found.group(1)


def test_report_parts() -> None:
    layout, track, doc = _site()
    cov = doc["coverage"]
    assert isinstance(cov, dict) and isinstance(cov["segments_total"], int)
    assert cov["segments_total"] >= 1  # the east end is poor
    page = render_audit_report(doc, layout, [track])
    for slug in ("audit-map", "coverage-gdop", "coverage-visible"):
        assert f'data-figure="{slug}"' in page
    assert page.count("Plotly.newPlot") == 3
    assert page.count("plotly.js v") == 1  # embedded once: the page opens offline
    rows = _table(page, "reflectors")
    # non-ok first: missing, moved, weak, ambiguous, then the two ok
    order = re.findall(r"<tr><td>(\d+)</td><td>(\w+)</td>", rows)
    assert order == [("11", "missing"), ("12", "moved"), ("13", "weak"),
                     ("14", "ambiguous"), ("10", "ok"), ("15", "ok")]
    assert "60.0, -30.0" in rows  # the moved reflector's shift in mm
    assert "14.000" in _table(page, "unmapped")
    segs = _table(page, "segments")
    assert segs.count("<tr>") == 1 + min(int(cov["segments_total"]), 20)
    assert "fewer than 3 visible" in segs
    # the shift arrow, enlarged by a round factor named in the legend (10 % of the 20 m
    # extent over 67 mm: 30, down to x20)
    assert '"name":"shift, drawn x20"' in page
    assert '"arrowcolor":"#ff7f0e"' in page
    assert 'data-part="summary"' in page and "<b>2</b> ok" in page


def test_nav200_document_has_coverage_only(tmp_path: Path) -> None:
    layout, track, doc = _site()
    doc = {"logs": ["nav200"], "coverage": doc["coverage"],
           "notes": ["NAV200 log: poses only; reflectors cannot be audited."]}
    out = tmp_path / "report.html"
    write_audit_report(doc, layout, out, [track])
    page = out.read_text(encoding="utf-8")
    assert "No reflector was audited" in page
    assert "reflectors cannot be audited" in page
    assert "<b>6</b> not audited" in page
    assert 'data-table="reflectors"' not in page
    assert 'data-figure="coverage-gdop"' in page


@pytest.mark.parametrize("width", (1400, 420))
def test_report_renders_in_chromium(browser: str, tmp_path: Path, width: int) -> None:
    layout, track, doc = _site()
    out = tmp_path / "report.html"
    write_audit_report(doc, layout, out, [track])
    m = render(browser, out, width)
    _check_page(m, width)
    assert [f["slug"] for f in m["figures"]] == ["audit-map", "coverage-gdop",
                                                 "coverage-visible"]


def test_map_draws_the_drives_within_the_point_budget() -> None:
    from lgvtool.audit.audit_report import map_figure
    from lgvtool.evaluate.plots import MAX_POINTS

    layout, _, doc = _site()
    t = np.arange(0.0, 5000.0, 0.1)  # 50 000 poses a drive
    drives = [HeadTrack.of(t, np.cos(t / 100) * 8 + 10, np.sin(t / 100) * 4 + 5,
                           np.zeros(len(t)), name=f"log-{k}") for k in range(4)]
    fig = map_figure(doc, layout, drives)
    lines = [d for d in fig.data if d.mode == "lines" and d.legendgroup == "drive"]
    assert len(lines) == 4 and sum(d.showlegend for d in lines) == 1
    assert sum(len(d.x) for d in lines) <= MAX_POINTS + 4
    assert all(len(d.x) >= MAX_POINTS // 4 - 1 for d in lines)
    # the reflectors by status, one trace each, with their counts in the legend
    names = [d.name for d in fig.data if d.mode == "markers"]
    assert names[:5] == ["missing (1)", "moved (1)", "weak (1)", "ambiguous (1)", "ok (2)"]
