"""The self-contained HTML report: tables and plotly figures in one file that opens offline.

plotly.js is embedded once, in the first figure; the others reuse it. Every table carries a
``data-table`` attribute and every figure a ``data-figure`` attribute so that tools (and tests)
can find them. Long tables (Table 1 of a long log) scroll inside a box with their header kept
in view; only Table 1's Average row is set in bold. A log with diagnostics, NAV replies without
a position or gaps gets a data-quality section (:mod:`lgvtool.evaluate.quality`).
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Sequence

import plotly.graph_objects as go

from lgvtool import __version__
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.plots import log_figures, quality_timeline_figure, rotation_bars_figure
from lgvtool.evaluate.quality import log_quality
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
tr.aggregate td { font-weight: 600; border-top: 2px solid #888; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: 0.3em 0; }
caption .sub { font-weight: normal; color: #555; }
.scroll { max-height: 34em; overflow: auto; display: inline-block; max-width: 100%; }
.scroll table { margin: 0; }
.scroll th { position: sticky; top: 0; background: #f4f4f4; }
.scroll tr.aggregate td { position: sticky; bottom: 0; background: #fff; }
th { background: #f4f4f4; }
table[data-table="diagnostics"] td:nth-child(2), table[data-table="diagnostics"] th:nth-child(2)
  { text-align: left; }
.warnings { color: #8a4b00; }
.note { color: #555; }
.figure { margin: 1.2em 0; }
"""

TABLE1_TITLE = "Table 1 Comparison of variance and RMSE"
"""The title the paper gives its Table 1."""
SCROLL_ROWS = 25
"""Tables with more rows than this scroll inside a box."""


def _table_html(kind: str, head: list[str], body: list[list[str]], caption: str, *,
                title: str | None = None, aggregate_last: bool = False) -> str:
    """A table; ``title`` leads the caption in bold, ``aggregate_last`` marks the last row
    (an average) as the one bold row; tables longer than :data:`SCROLL_ROWS` scroll."""
    e = html.escape
    rows = ["<tr>" + "".join(f"<th>{e(h)}</th>" for h in head) + "</tr>"]
    for i, row in enumerate(body):
        cls = ' class="aggregate"' if aggregate_last and i == len(body) - 1 else ""
        rows.append(f"<tr{cls}>" + "".join(f"<td>{e(c)}</td>" for c in row) + "</tr>")
    cap = (f"{e(title)} <span class=\"sub\">({e(caption)})</span>" if title
           else f'<span class="sub">{e(caption)}</span>')
    table = (f'<table data-table="{e(kind)}"><caption>{cap}</caption>'
             + "".join(rows) + "</table>")
    if len(body) > SCROLL_ROWS:
        return f'<div class="scroll" data-scroll="{e(kind)}">{table}</div>'
    return table


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
                                 f"per rotation, {len(table.rows)} rotations",
                                 title=TABLE1_TITLE, aggregate_last=True))
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


def _quality_html(res: EvaluationResult, fig_html: _Figures, prefix: str,
                  figures: list[tuple[str, go.Figure]] | None) -> str:
    """The data-quality section of one log (empty when the log cannot be read again)."""
    if not res.path:
        return ""
    q = log_quality(res)
    if q is None:
        return ""
    e = html.escape
    if not q.any:
        return ('<section data-section="data-quality"><h2>Data quality</h2><p class="note">'
                f"No diagnostics, no NAV reply without a position ({q.nav_replies} replies) "
                "and no gap in the motion or observation topics.</p></section>")
    facts = [("diagnostics", f"{q.diagnostics} (" + ", ".join(
        f"{_LEVELS.get(k, k)} {v}" for k, v in sorted(q.by_level.items())) + ")")]
    facts.append(("MCU frames dropped (sequence gaps)", str(q.dropped_frames)))
    corrupt = ", ".join(f"{s} {n}" for s, n in sorted(q.corrupt_frames.items())) or "none"
    facts.append(("corrupt frames (checksum or length)", corrupt))
    facts.append(("bytes skipped while resynchronising", str(q.skipped_bytes)))
    share = f" ({100.0 * q.nav_no_position / q.nav_replies:.1f} %)" if q.nav_replies else ""
    facts.append(("NAV replies without a position", f"{q.nav_no_position} of {q.nav_replies}"
                  + share))
    facts.append(("NAV requests unanswered", str(q.nav_unanswered)))
    if q.gaps:
        worst = max(q.gaps, key=lambda g: g.length)
        facts.append(("gaps", f"{len(q.gaps)}, longest {worst.length:.2f} s on {worst.topic} "
                      f"at {worst.start:.1f} s"))
    else:
        facts.append(("gaps", "none"))
    parts = ['<section data-section="data-quality"><h2>Data quality</h2>',
             '<table class="facts" data-table="quality">'
             + "".join(f"<tr><td>{e(k)}</td><td>{e(v)}</td></tr>" for k, v in facts)
             + "</table>"]
    first: dict[tuple[str, str], float] = {}
    last: dict[tuple[str, str], float] = {}
    for t, source, kind, _level, _n in q.events:
        first.setdefault((source, kind), t)
        last[(source, kind)] = t
    rows = [[s, k, str(n), f"{first.get((s, k), 0.0):.1f}", f"{last.get((s, k), 0.0):.1f}"]
            for (s, k), n in sorted(q.by_kind.items(), key=lambda kv: (-kv[1], kv[0]))]
    if rows:
        parts.append(_table_html("diagnostics", ["source", "kind", "count", "first (s)",
                                                 "last (s)"], rows,
                                 "diagnostics by source and kind; 'simulator' events are the "
                                 "faults a simulation injected, the others what the decoders "
                                 "and the NAV200 session saw"))
    if q.gaps:
        per: dict[str, list[float]] = {}
        for g in q.gaps:
            per.setdefault(g.topic, []).append(g.length)
        parts.append(_table_html("gaps", ["topic", "gaps", "total (s)", "longest (s)"],
                                 [[t, str(len(v)), f"{sum(v):.2f}", f"{max(v):.2f}"]
                                  for t, v in sorted(per.items())],
                                 "silences longer than three median intervals of the topic "
                                 "(and 0.25 s)"))
    fig = quality_timeline_figure(q, title=f"{res.name}: diagnostics and gaps over time")
    parts.append(fig_html(prefix + "data-quality", fig))
    if figures is not None:
        figures.append((prefix + "data-quality", fig))
    parts.append("</section>")
    return "".join(parts)


_LEVELS = {1: "debug", 2: "info", 3: "warning", 4: "error", 5: "fatal"}


def render_report(
    results: Sequence[EvaluationResult], *, figures: list[tuple[str, go.Figure]] | None = None,
    progress: Callable[[int], None] | None = None,
) -> str:
    """The report of one or more logs as one HTML page. If ``figures`` is a list, every figure
    is also appended to it as (file stem, figure), for PNG export. ``progress`` is called with
    1 as each log's part is done."""
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
        body.append(_quality_html(res, fig_html, prefix, figures))
        body.append("</section>")
        if progress is not None:
            progress(1)
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>\n"
            + "\n".join(body) + "\n</body></html>\n")

