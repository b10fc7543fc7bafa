"""The report at scale and its styling: long drives stay readable and linear to build, Table 1
is titled as the paper's, one bold row, distinct colours, the truth drawn on top."""

from __future__ import annotations

import re
from html.parser import HTMLParser

import plotly.graph_objects as go
import pytest
from evaluate_synth import DELTA, H, circle_drive

from lgvtool.evaluate import plots
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.html_report import TABLE1_TITLE, render_report
from lgvtool.evaluate.table import build_table


def _result(rotations: float, name: str = "long"):
    d = {"laser": circle_drive(rotations=rotations, dt=0.45, bias=0.05, sd=0.02, seed=1),
         "pf-paper": circle_drive(rotations=rotations, dt=0.45, bias=0.03, sd=0.02, seed=3),
         "pf": circle_drive(rotations=rotations, dt=0.125, sd=0.01, seed=2)}
    return evaluate_trajectories(d, truth=circle_drive(rotations=rotations, dt=0.1),
                                 steering_angle=DELTA, h=H, name=name)


class Rows(HTMLParser):
    """The tables' rows: table kind -> list of (row class, cells); the caption text."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: dict[str, list[tuple[str, list[str]]]] = {}
        self.captions: dict[str, str] = {}
        self.scrolls: list[str] = []
        self._table = ""
        self._in_caption = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag == "div" and a.get("data-scroll"):
            self.scrolls.append(a["data-scroll"] or "")
        if tag == "table":
            self._table = a.get("data-table") or ""
            self.tables[self._table] = []
            self.captions[self._table] = ""
        elif tag == "tr":
            self.tables[self._table].append((a.get("class") or "", []))
        elif tag == "caption":
            self._in_caption = True

    def handle_endtag(self, tag: str) -> None:
        if tag == "caption":
            self._in_caption = False

    def handle_data(self, data: str) -> None:
        if self._in_caption:
            self.captions[self._table] += data
        elif self._table and self.tables[self._table]:
            self.tables[self._table][-1][1].append(data)


def test_only_table1_average_is_bold_and_table1_has_the_papers_title() -> None:
    page = render_report([_result(3.4, "short")])
    style = page[page.index("<style>"):page.index("</style>")]
    assert "last-child" not in style        # no rule that bolds whatever row comes last
    assert re.search(r"tr\.aggregate td \{[^}]*font-weight: 600", style)
    p = Rows()
    p.feed(page)
    t1 = p.tables["table1"]
    assert [c for c, _ in t1].count("aggregate") == 1 and t1[-1][0] == "aggregate"
    assert t1[-1][1][0] == "Average"
    assert all(c == "" for c, _ in p.tables["summary"])   # pf, the last estimator, not bold
    assert p.captions["table1"].startswith(TABLE1_TITLE)
    assert TABLE1_TITLE == "Table 1 Comparison of variance and RMSE"
    assert p.scrolls == []                   # a short Table 1 does not scroll


def _rgb(c: str) -> tuple[int, ...]:
    return tuple(int(c[i:i + 2], 16) for i in (1, 3, 5))


def test_estimator_colours_are_far_apart_and_apart_from_truth_and_circle() -> None:
    names = ["laser", "deadreckoning", "ekf", "pf-paper", "pf", "mine", "theirs"]
    col = plots.colours(names)
    assert len(set(col.values())) == len(names)
    fixed = [*(_rgb(col[n]) for n in names[:5]), _rgb(plots.TRUTH_COLOUR),
             _rgb(plots.CIRCLE_COLOUR)]
    dist = min(sum((a - b) ** 2 for a, b in zip(p, q, strict=True)) ** 0.5
               for i, p in enumerate(fixed) for q in fixed[i + 1:])
    assert dist > 90, dist
    # the pair the old palette nearly merged
    lp = sum((a - b) ** 2 for a, b in zip(_rgb(col["laser"]), _rgb(col["pf-paper"]),
                                          strict=True)) ** 0.5
    assert lp > 200


def test_truth_is_drawn_over_the_estimates() -> None:
    fig = plots.trajectory_figure(_result(2.2))
    for xaxis in ("x", "x2"):
        order = [t.name for t in fig.data if t.xaxis == xaxis]
        assert order.index("truth") > max(order.index(n) for n in ("laser", "pf-paper", "pf"))


def test_a_long_drive_gets_readable_figures_without_per_rotation_vlines(
        monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(*args: object, **kw: object) -> None:
        raise AssertionError("add_vline re-validates every shape: quadratic in rotations")

    monkeypatch.setattr(go.Figure, "add_vline", refuse)
    res = _result(160.4)
    table = build_table([res])
    assert len(table.rows) >= 150
    figs = dict(plots.log_figures(res, table))
    rot = figs["rotations"]
    kinds = {type(t).__name__ for t in rot.data}
    assert "Bar" not in kinds and {"Scatter", "Box"} <= kinds   # lines + distributions
    lines = [t for t in rot.data if isinstance(t, go.Scatter)]
    assert all(len(t.x) == len(table.rows) for t in lines)
    assert rot.layout.xaxis.rangeslider.visible
    # too many boundaries to draw: none, rather than a grey wall
    assert not [s for s in figs["radial-error"].layout.shapes if s.yref == "paper"]
    page = render_report([res])
    p = Rows()
    p.feed(page)
    assert "table1" in p.scrolls            # Table 1 of 150+ rotations scrolls in a box
    assert len(p.tables["table1"]) == len(table.rows) + 2   # header, rows, Average


def test_a_short_drive_keeps_bars_and_one_boundary_line_per_rotation() -> None:
    res = _result(6.3)
    table = build_table([res])
    figs = dict(plots.log_figures(res, table))
    assert {type(t).__name__ for t in figs["rotations"].data} == {"Bar"}
    shapes = [s for s in figs["radial-error"].layout.shapes if s.yref == "paper"]
    assert len(shapes) == len(res.laps.boundaries)
    assert sorted(s.x0 for s in shapes) == pytest.approx(
        sorted(b - res.t0 for b in res.laps.boundaries), abs=1e-9)
    assert all(s.x0 == s.x1 for s in shapes)
