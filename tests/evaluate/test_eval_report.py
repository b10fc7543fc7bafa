"""The HTML report: figures, tables, plotly.js embedded once; parsed with html.parser."""

from __future__ import annotations

from html.parser import HTMLParser

import pytest
from evaluate_synth import DELTA, H, circle_drive

from lgvtool.config import paper_hall_reflectors
from lgvtool.errors import InputError
from lgvtool.evaluate import plots
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.html_report import render_report


class Collector(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.figures: list[str] = []
        self.tables: list[str] = []
        self.sections: list[str] = []
        self.scripts = 0
        self.bundles = 0
        self._in_script = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "div" and "data-figure" in a:
            self.figures.append(a["data-figure"] or "")
        if tag == "table":
            self.tables.append(a.get("data-table") or "")
        if tag == "section":
            self.sections.append(a.get("data-section") or "")
        if tag == "script":
            self.scripts += 1
            self._in_script = True
            if a.get("src"):
                raise AssertionError(f"external script {a['src']}: the report must work offline")

    def handle_endtag(self, tag: str) -> None:
        if tag == "script":
            self._in_script = False

    def handle_data(self, data: str) -> None:
        if self._in_script and "plotly.js v" in data and len(data) > 1_000_000:
            self.bundles += 1


def result(name: str = "drive", truth: bool = True):
    d = {"laser": circle_drive(rotations=2.4, dt=0.45, bias=0.05, sd=0.02, seed=1),
         "pf": circle_drive(rotations=2.4, sd=0.01, seed=2)}
    return evaluate_trajectories(d, truth=circle_drive(rotations=2.4, dt=0.05) if truth else None,
                                 steering_angle=DELTA, h=H, name=name,
                                 reflectors=paper_hall_reflectors())


def test_report_holds_figures_and_tables() -> None:
    figs: list = []
    page = render_report([result()], figures=figs)
    p = Collector()
    p.feed(page)
    assert p.figures == ["trajectories", "radial-error", "rotations", "truth-error"]
    assert p.tables == ["reference", "table1", "summary"]
    assert p.bundles == 1                                  # plotly.js embedded exactly once
    assert [s for s, _ in figs] == p.figures
    traj = figs[0][1]
    names = {t.name for t in traj.data}
    assert {"reflectors", "laser", "pf", "truth"} <= names
    assert any(n.startswith("reference circle") for n in names)


def test_report_without_truth_and_for_several_logs() -> None:
    page = render_report([result("a", truth=False), result("b", truth=False)])
    p = Collector()
    p.feed(page)
    assert p.sections == ["aggregate", "log", "log"]
    assert "truth-error" not in " ".join(p.figures)
    assert p.figures[0] == "all-rotations"
    assert "a-trajectories" in p.figures and "b-rotations" in p.figures
    assert p.tables.count("table1") == 3
    assert p.bundles == 1


def test_png_export_needs_kaleido(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None)
    with pytest.raises(InputError, match="kaleido"):
        plots.require_kaleido()
