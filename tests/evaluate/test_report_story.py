"""The report reads as a story and its figures as the paper's, without a browser (the browser
check is test_report_browser.py): the verdict opens the page, then per log what was run, the
paper's claim beside lgvtool's own figures, what lgvtool measured and where the error comes
from; error figures are scaled to the steady state with the start-up shown; every line is
labelled; rotations are numbered in their own log; one colour table is shared with the
Foxglove layout; the page is one offline file laid out for phones too."""

from __future__ import annotations

import json
import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import plotly.graph_objects as go
import pytest
from evaluate_synth import DELTA, PERIOD, H, circle_drive

from lgvtool import colours as shared
from lgvtool.evaluate import plots
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.html_report import render_report
from lgvtool.evaluate.table import MM, build_table
from lgvtool.evaluate.verdict import PAPER, EstimatorVerdict, Verdict
from lgvtool.log import foxglove

LAYOUT = Path(__file__).resolve().parents[2] / "docs" / "foxglove-layout.json"
STARTUP_S = 6.0
STARTUP_M = 0.7


def _with_startup(df: pd.DataFrame, offset: float = STARTUP_M, span: float = STARTUP_S
                  ) -> pd.DataFrame:
    """``df`` pushed ``offset`` m away from the circle for its first ``span`` s: a filter
    finding the vehicle from a uniform start."""
    out = df.copy()
    t = out["t"].to_numpy() - out["t"].iloc[0]
    early = t < span
    out.loc[early, "x"] += offset
    return out


def _result(name: str = "drive", rotations: float = 4.3, truth: bool = True):
    d = {"laser": circle_drive(rotations=rotations, dt=0.45, bias=-0.06, sd=0.02, seed=1),
         "pf-paper": _with_startup(circle_drive(rotations=rotations, dt=0.45, sd=0.012, seed=3)),
         "pf": circle_drive(rotations=rotations, dt=0.125, sd=0.003, seed=2)}
    return evaluate_trajectories(d, truth=circle_drive(rotations=rotations, dt=0.1) if truth
                                 else None, steering_angle=DELTA, h=H, name=name)


class Page(HTMLParser):
    """The order of the parts that matter: verdict, headings, figures, tables."""

    def __init__(self) -> None:
        super().__init__()
        self.order: list[str] = []
        self.headings: list[str] = []
        self.external: list[str] = []
        self.viewport = False
        self.tables_in_box = 0
        self.tables = 0
        self._stack: list[str] = []
        self._heading = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        cls = a.get("class") or ""
        if a.get("data-part") == "verdict":
            self.order.append("verdict")
        if "data-figure" in a:
            self.order.append("figure:" + (a["data-figure"] or ""))
        if tag == "table":
            self.tables += 1
            self.tables_in_box += any("box" in c for c in self._stack[-2:])
        if tag in ("h2", "h3"):
            self._heading = True
            self.headings.append("")
        for key in ("src", "href"):
            v = a.get(key) or ""
            if re.match(r"(https?:)?//", v):
                self.external.append(v)
        if tag == "meta" and a.get("name") == "viewport":
            self.viewport = True
        if tag == "div":
            self._stack.append(cls)

    def handle_endtag(self, tag: str) -> None:
        if tag in ("h2", "h3"):
            self._heading = False
        if tag == "div" and self._stack:
            self._stack.pop()

    def handle_data(self, data: str) -> None:
        if self._heading:
            self.headings[-1] += data


def _page(results) -> tuple[str, Page]:
    text = render_report(results)
    p = Page()
    p.feed(text)
    return text, p


def test_the_verdict_opens_the_page_and_the_story_follows() -> None:
    text, p = _page([_result()])
    assert p.order[0] == "verdict"
    assert p.order[1] == "figure:trajectories"          # the first screen: verdict and a plot
    story = ["What was run", "The paper's claim", "What lgvtool measured",
             "Where the error comes from"]
    where = [p.headings.index(h) for h in story]
    assert where == sorted(where)
    verdict = text[text.index('data-part="verdict"'):text.index("</div></div>", text.index(
        'data-part="verdict"'))]
    for name in ("laser", "pf-paper", "pf"):
        assert f'data-estimator="{name}"' in verdict
    assert "× the laser" in verdict


def test_a_verdict_set_by_the_job_is_the_one_shown() -> None:
    res = _result()
    res.verdict = Verdict(
        log=res.name, reference="circle", reference_text="radial RMSE of a made-up kind",
        estimators=(EstimatorVerdict("laser", 0.0625, 1.0, "NAV poses"),
                    EstimatorVerdict("pf", 0.00312, 0.05, "reflector scans", "a note")),
        paper=None, warnings=("a warning of the verdict",),
        paths=("out/report.html", "out/table1.md"), no_reference_text=None)
    text, _ = _page([res])
    assert "radial RMSE of a made-up kind" in text and "a warning of the verdict" in text
    assert "62.5 mm" in text and "3.1 mm" in text and "a note" in text
    assert "out/report.html" in text


def test_the_papers_claim_stands_beside_computed_figures() -> None:
    res = _result()
    text, _ = _page([res])
    start = text.index("The paper's claim</h3>")
    claim = text[start:text.index("What lgvtool measured</h3>", start)]
    table = build_table([res])
    laser, filt = table.average["laser"], table.average["pf-paper"]
    cells = re.findall(r'<div class="paperfig">([^<]*)</div><div>([^<]*)</div>', claim)
    assert cells[0] == (f"{PAPER['laser_rmse_mm']:.1f}", f"{laser.rmse * MM:.1f}")
    assert cells[1] == (f"{PAPER['filter_rmse_mm']:.1f}", f"{filt.rmse * MM:.1f}")
    assert cells[2][1] == f"{filt.rmse / laser.rmse:.2f} ×"
    assert cells[4] == (f"{PAPER['filter_variance_mm2']:.0f}",
                        f"{filt.variance * MM * MM:.0f}")
    assert "56.9 to 20.4 mm RMSE" in claim               # the paper's headline, as the paper's


def test_where_the_error_comes_from_is_computed_from_the_log() -> None:
    res = _result()
    text, _ = _page([res])
    why = text[text.index("Where the error comes from</h3>"):]
    pooled = res.estimators["laser"].pooled
    assert f"a bias of {abs(pooled.mean) * MM:.1f} mm inside the circle" in why
    assert "pf-paper</b>: " in why and "its start-up (the first" in why
    assert "along the path" in why and "across it" in why


def _startup_figure(res, fig: go.Figure, unit_peak: float) -> None:
    lo, hi = fig.layout.yaxis.range
    assert hi < 0.25 * unit_peak                         # the start-up does not set the scale
    assert lo <= -60.0 * 0.9                             # the laser's band is in view
    notes = [a.text for a in fig.layout.annotations if a.text and "start-up" in a.text]
    assert len(notes) == 1 and "pf-paper" in notes[0]
    shaded = [s for s in fig.layout.shapes if s.type == "rect"]
    assert len(shaded) == 1 and 0.0 < shaded[0].x1 < STARTUP_S + 2.0


def test_error_figures_are_scaled_to_the_steady_state_and_show_the_startup() -> None:
    res = _result()
    _startup_figure(res, plots.radial_error_figure(res), STARTUP_M * MM)
    truth_fig = plots.truth_error_figure(res)
    _, hi = truth_fig.layout.yaxis.range
    assert hi < 0.25 * STARTUP_M * MM
    calm = _result("calm")
    calm.estimators.pop("pf-paper")
    assert plots.steady_scale({n: (ev.radial["t"].to_numpy(), ev.radial["error"].to_numpy())
                               for n, ev in calm.estimators.items()}) is None


def test_steady_scale_keeps_late_spikes_in_range() -> None:
    t = np.linspace(0.0, 200.0, 2001)
    y = np.sin(t)                                        # +-1 in the steady state
    y[:30] = 50.0                                        # a start-up of 3 s
    y[1500] = 8.0                                        # a spike late in the drive
    s = plots.steady_scale({"a": (t, y)})
    assert s is not None and s.startup_end == pytest.approx(3.0, abs=0.11)
    assert s.low < -1.0 and 8.0 < s.high < 12.0 and s.off_scale == {"a": 50.0}
    assert s.ends == {"a": s.startup_end}


def test_every_line_is_labelled() -> None:
    res = _result()
    for fig in (plots.radial_error_figure(res), plots.truth_error_figure(res)):
        names = [t.name for t in fig.data]
        assert all(names) and len(set(names)) == len(names)
        assert any(n.startswith("rotation boundary") for n in names)
        numbers = [a.text for a in fig.layout.annotations if a.text and a.text.isdigit()]
        assert numbers == [str(k) for k in range(1, res.laps.complete + 1)]
        dotted = [s for s in fig.layout.shapes if s.yref == "paper"]
        assert len(dotted) == len(res.laps.boundaries)
    radial = plots.radial_error_figure(res)
    assert any(a.text and "on the reference circle" in a.text for a in radial.layout.annotations)


def test_rotations_are_numbered_in_their_own_log() -> None:
    a, b = _result("a", rotations=3.2, truth=False), _result("b", rotations=2.3, truth=False)
    text, _ = _page([a, b])
    table1 = text[text.index('data-table="table1"'):]
    table1 = table1[:table1.index("</table>")]
    assert "<th>Log</th><th>Rotation</th>" in table1
    rows = re.findall(r"<tr><td>([ab])</td><td>(\d+)</td>", table1)
    assert rows == [("a", "1"), ("a", "2"), ("a", "3"), ("b", "1"), ("b", "2")]
    fig = plots.rotation_bars_figure(build_table([a, b]))
    assert fig.layout.xaxis.type == "multicategory"
    logs, numbers = fig.data[0].x
    assert list(zip(logs, numbers, strict=True)) == [("a", "1"), ("a", "2"), ("a", "3"),
                                                     ("b", "1"), ("b", "2")]


def test_one_colour_table_for_the_report_foxglove_and_the_layout() -> None:
    builtin = ["laser", "deadreckoning", "ekf", "pf-paper", "pf"]
    col = plots.colours(builtin)
    assert col == {n: shared.SOURCE_COLOURS[n] for n in builtin}
    for n in [*builtin, "nav"]:
        r, g, b = foxglove.PALETTE[n]
        assert f"#{round(255 * r):02x}{round(255 * g):02x}{round(255 * b):02x}" \
            == shared.SOURCE_COLOURS[n]
    layout = json.loads(LAYOUT.read_text(encoding="utf-8"))
    checked = 0
    for key, cfg in layout["configById"].items():
        for topic, t in cfg.get("topics", {}).items():
            m = re.fullmatch(r"/estimate/([^/]+)/(pose|particles)", topic)
            if m and "color" in t:
                assert t["color"][:7] == shared.SOURCE_COLOURS[m.group(1)], (key, topic)
                checked += 1
        for path in cfg.get("paths", []):
            m = re.match(r"/estimate/([^/]+)/", path["value"])
            if m:
                assert path["color"][:7] == shared.SOURCE_COLOURS[m.group(1)], (key, path)
                checked += 1
    assert checked >= 10
    head = layout["configById"]["3D!lgvview"]["topics"]["/nav/head"]["color"]
    assert head[:7] == shared.SOURCE_COLOURS["nav"]


def test_the_page_is_one_offline_file_laid_out_for_phones() -> None:
    text, p = _page([_result()])
    assert p.external == [] and p.viewport
    assert p.tables and p.tables_in_box == p.tables       # every table scrolls in its box
    traj = plots.trajectory_figure(_result())
    narrow = traj.layout.meta["narrow"]
    assert narrow["xaxis.domain"] == [0.0, 1.0] and narrow["height"] > traj.layout.height
    assert "layout.meta" in text or "meta.narrow" in text  # the script that applies it


def test_startup_helper_moves_only_the_start() -> None:
    df = circle_drive(rotations=1.0, dt=0.5)
    moved = _with_startup(df)
    t = df["t"] - df["t"].iloc[0]
    assert (moved["x"] - df["x"])[t < STARTUP_S].min() == pytest.approx(STARTUP_M)
    assert (moved["x"] - df["x"])[t >= STARTUP_S].abs().max() == 0.0
    assert PERIOD > STARTUP_S and math.isfinite(PERIOD)
