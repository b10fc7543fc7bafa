"""The self-contained HTML report: tables and plotly figures in one file that opens offline.

plotly.js is embedded once, in the first figure; the others reuse it. Every table carries a
``data-table`` attribute and every figure a ``data-figure`` attribute so that tools (and tests)
can find them.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence

import plotly.graph_objects as go

from lgvtool import __version__
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.plots import log_figures, rotation_bars_figure
from lgvtool.evaluate.table import (
    Table1,
    build_table,
    no_rows_note,
    summary_cells,
    table1_cells,
)

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222; }
h1 { font-size: 1.6em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
tr:last-child td { font-weight: 600; }
table.facts tr:last-child td { font-weight: normal; }
.warnings { color: #8a4b00; }
.figure { margin: 1.2em 0; }
"""


def _table_html(kind: str, head: list[str], body: list[list[str]], caption: str) -> str:
    e = html.escape
    rows = ["<tr>" + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    rows += ["<tr>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>" for row in body]
    return (f'<table data-table="{e(kind)}"><caption>{e(caption)}</caption>'
            + "".join(rows) + "</table>")


def _facts(res: EvaluationResult) -> str:
    ref = res.reference
    facts: list[tuple[str, str]] = []
    if ref.steering_angle is not None:
        facts.append(("steering angle delta", f"{math.degrees(ref.steering_angle):.2f} deg "
                      f"({'median of the logged angle' if ref.steering_source == 'log' else 'configured'})"))
    facts.append(("h (O to drive wheel)", f"{ref.h:.3f} m"))
    if ref.kinematic_radius is not None:
        facts.append(("kinematic radius R = h / tan(delta)", f"{ref.kinematic_radius:.4f} m"))
    facts.append(("radius used", "free (geometric fit)" if ref.free_radius else "kinematic"))
    facts.append(("centre", "shared by all estimators" if ref.shared_centre
                  else "fitted per estimator"))
    for n, ev in res.estimators.items():
        if ev.circle is not None:
            fitted = f"{ev.fitted.r:.4f} m" if ev.fitted is not None else "-"
            facts.append((f"{n}: centre / radius / fitted radius",
                          f"({ev.circle.cx:.3f}, {ev.circle.cy:.3f}) m / {ev.circle.r:.4f} m / "
                          f"{fitted}"))
    facts.append(("complete rotations", str(res.laps.complete)))
    facts.append(("partial rotations left out", str(res.laps.partial)))
    if res.laps.source:
        facts.append(("rotations found on", res.laps.source))
    if res.truth_path is not None:
        facts.append(("true path about the circle (radial RMSE / bias)",
                      f"{res.truth_path.rmse * 1e3:.2f} mm / {res.truth_path.mean * 1e3:.2f} mm"))
    e = html.escape
    rows = "".join(f"<tr><td>{e(k)}</td><td>{e(v)}</td></tr>" for k, v in facts)
    return f'<table class="facts" data-table="reference">{rows}</table>'


def _tables(table: Table1, label: str) -> list[str]:
    parts: list[str] = []
    if table.rows:
        parts.append(_table_html("table1", *table1_cells(table),
                                 f"{label}: RMSE (mm) and variance (mm²) of the radial error "
                                 "per rotation"))
    else:
        parts.append(f"<p>{html.escape(no_rows_note(table))}</p>")
    parts.append(_table_html("summary", *summary_cells(table),
                             f"{label}: summary per estimator"))
    return parts


class _Figures:
    """Renders figures to HTML divs, embedding plotly.js in the first one only."""

    def __init__(self) -> None:
        self.count = 0
        self.slugs: list[str] = []

    def __call__(self, slug: str, fig: go.Figure) -> str:
        div = fig.to_html(full_html=False, include_plotlyjs=self.count == 0,
                          config={"displaylogo": False, "responsive": True})
        self.count += 1
        self.slugs.append(slug)
        return f'<div class="figure" data-figure="{html.escape(slug)}">{div}</div>'


def render_report(
    results: Sequence[EvaluationResult], *, figures: list[tuple[str, go.Figure]] | None = None
) -> str:
    """The report of one or more logs as one HTML page. If ``figures`` is a list, every figure
    is also appended to it as (file stem, figure), for PNG export."""
    e = html.escape
    fig_html = _Figures()
    title = ("lgvtool evaluation: " + ", ".join(r.name for r in results))
    body: list[str] = [f"<h1>{e(title)}</h1>",
                       f"<p>lgvtool {e(__version__)}; {len(results)} log(s).</p>"]
    if len(results) > 1:
        table = build_table(results)
        body.append('<section data-section="aggregate"><h2>All logs</h2>')
        body += _tables(table, "All logs")
        if table.rows:
            fig = rotation_bars_figure(table, title="All logs: RMSE per rotation")
            body.append(fig_html("all-rotations", fig))
            if figures is not None:
                figures.append(("all-rotations", fig))
        body.append("</section>")
    for i, res in enumerate(results):
        table = build_table([res])
        prefix = f"{res.name}-" if len(results) > 1 else ""
        body.append(f'<section data-section="log" data-log="{e(res.name)}" id="log-{i + 1}">')
        body.append(f"<h2>{e(res.name)}</h2>")
        if res.path:
            body.append(f"<p>Log: <code>{e(res.path)}</code>; estimates "
                        f"{'read from the log' if res.source == 'log' else 'computed by replay'}"
                        ".</p>")
        if res.warnings:
            body.append('<ul class="warnings">' + "".join(f"<li>{e(w)}</li>" for w in res.warnings)
                        + "</ul>")
        body.append(_facts(res))
        body += _tables(table, res.name)
        for slug, fig in log_figures(res, table):
            body.append(fig_html(prefix + slug, fig))
            if figures is not None:
                figures.append((prefix + slug, fig))
        body.append("</section>")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")

