"""The self-contained HTML report: tables and plotly figures in one file that opens offline.

The page reads as a story (docs/evaluation.md, "Reading the report"): it opens with the
verdict (:mod:`lgvtool.evaluate.verdict`) beside one figure, so that the first screen answers
"how good is it", then per log: what was run, the paper's claim beside this log's figures,
what lgvtool measured (Table 1, the summary, the error over time and per rotation) and where
the error comes from (bias and spread on the circle, along and across the path against the
truth, the start-up), then the log's data quality.

plotly.js is embedded once, in the first figure; the others reuse it. Every table carries a
``data-table`` attribute and every figure a ``data-figure`` attribute so that tools (and tests)
can find them; the verdict is ``<div data-part="verdict">``. Every table sits in a box that
scrolls sideways on a narrow screen; long tables (Table 1 of a long log) also scroll down
inside their box with their header kept in view; only Table 1's Average row is set in bold.
A log with diagnostics, NAV replies without a position or gaps gets a data-quality section
(:mod:`lgvtool.evaluate.quality`). Over several logs, rotations keep their number in their
own log (the Log column says which).
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
import plotly.graph_objects as go

from lgvtool import __version__
from lgvtool.evaluate.evaluation import BASELINE, EvaluationResult
from lgvtool.evaluate.plots import (
    colours,
    log_figures,
    quality_timeline_figure,
    rotation_bars_figure,
    steady_scale,
)
from lgvtool.evaluate.quality import log_quality
from lgvtool.evaluate.table import (
    MM,
    Table1,
    build_table,
    no_rows_note,
    summary_cells,
    table1_cells,
)

if TYPE_CHECKING:
    from lgvtool.evaluate.verdict import Verdict

_STYLE = """
* { box-sizing: border-box; }
body { font-family: system-ui, sans-serif; margin: 0 auto; padding: 0.8em 1.2em 3em;
  max-width: 1360px; color: #222; line-height: 1.45; }
h1 { font-size: 1.5em; margin: 0.3em 0 0.1em; overflow-wrap: anywhere; }
h2 { margin-top: 2em; border-bottom: 1px solid #ccc; overflow-wrap: anywhere; }
h3 { margin: 1.8em 0 0.4em; font-size: 1.2em; }
h4.figtitle { margin: 0.2em 0 0; font-size: 1em; }
p, li { overflow-wrap: anywhere; }
code { overflow-wrap: anywhere; }
.meta { color: #555; margin: 0 0 0.8em; }
.lead { display: grid; grid-template-columns: minmax(0, 5fr) minmax(0, 7fr); gap: 1.2em;
  align-items: start; }
@media (max-width: 1100px) { .lead { grid-template-columns: minmax(0, 1fr); } }
.verdict { border: 1px solid #c8d3e0; border-left: 6px solid #1f78b5; background: #f6f9fc;
  padding: 0.5em 1em 0.7em; border-radius: 4px; min-width: 0; }
.verdict h2 { margin: 0.2em 0 0.3em; border: 0; font-size: 1.25em; }
.verdict .ref { margin: 0.2em 0 0.5em; color: #333; }
.est { list-style: none; padding: 0; margin: 0.3em 0; }
.est li { display: grid; grid-template-columns: 9.6em 5.6em minmax(0, 1fr); column-gap: 0.6em;
  align-items: baseline; padding: 0.25em 0; border-top: 1px solid #e3e8ef; }
.est .name { font-weight: 600; overflow-wrap: anywhere; }
.est .fig { text-align: right; font-variant-numeric: tabular-nums; font-weight: 600; }
.est .ratio { font-variant-numeric: tabular-nums; }
.est .bar { display: block; height: 0.45em; border-radius: 2px; margin-top: 0.15em;
  max-width: 100%; }
.est .obs { grid-column: 2 / 4; color: #555; font-size: 0.9em; }
@media (max-width: 520px) {
  .est li { grid-template-columns: minmax(0, 1fr) auto; }
  .est .ratio, .est .obs { grid-column: 1 / 3; }
}
.swatch { display: inline-block; width: 0.85em; height: 0.85em; border-radius: 2px;
  vertical-align: -0.08em; margin-right: 0.35em; }
.paper { margin: 0.5em 0 0.2em; }
.vm { display: grid; margin: 0.4em 0; border-top: 1px solid #e3e8ef; }
.vm > div { padding: 0.2em 0.4em; border-bottom: 1px solid #e3e8ef; text-align: right;
  font-variant-numeric: tabular-nums; white-space: nowrap; }
.vm > div.h { white-space: normal; }
@media (max-width: 520px) { .vm { font-size: 0.88em; } }
.vm > div.k, .vm > div.h:first-child { text-align: left; font-weight: 600; }
.vm > div.h { font-weight: 600; }
.vm .sub { display: block; font-weight: normal; color: #555; font-size: 0.88em; }
.paper b, .cmp .paperfig { color: #7a4b00; }
.warnings { color: #8a4b00; padding-left: 1.2em; margin: 0.4em 0; }
.files { color: #555; font-size: 0.9em; margin: 0.4em 0 0; }
.note { color: #555; }
.toc { margin: 1.2em 0 0; color: #555; }
.toc a { white-space: nowrap; }
.box { max-width: 100%; overflow-x: auto; margin: 0.8em 0; }
table { border-collapse: collapse; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }
th:first-child, td:first-child { text-align: left; }
tr.aggregate td { font-weight: 600; border-top: 2px solid #888; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: 0.3em 0;
  position: sticky; left: 0; max-width: calc(100vw - 2.6em); }
caption .sub { font-weight: normal; color: #555; }
.scroll { max-height: 34em; overflow: auto; }
.scroll th { position: sticky; top: 0; background: #f4f4f4; }
.scroll tr.aggregate td { position: sticky; bottom: 0; background: #fff; }
th { background: #f4f4f4; }
td { white-space: nowrap; }
table.facts td { white-space: normal; }
table.facts td + td { text-align: left; }
table[data-table="diagnostics"] td:nth-child(2), table[data-table="diagnostics"] th:nth-child(2)
  { text-align: left; }
details summary { cursor: pointer; color: #333; }
details.columns { margin: 0.2em 0 1em; }
details.columns dl { display: grid; grid-template-columns: minmax(0, 12em) minmax(0, 1fr);
  gap: 0.2em 1em; max-width: 60em; }
details.columns dt { font-weight: 600; overflow-wrap: anywhere; }
details.columns dd { margin: 0; }
@media (max-width: 520px) { details.columns dl { grid-template-columns: minmax(0, 1fr); } }
.cmp { display: grid; grid-template-columns: minmax(0, 2fr) minmax(0, 1fr) minmax(0, 1fr);
  max-width: 44em; border-top: 1px solid #ccc; margin: 0.6em 0; }
.cmp > div { padding: 0.2em 0.5em; border-bottom: 1px solid #ddd; text-align: right;
  font-variant-numeric: tabular-nums; overflow-wrap: anywhere; }
.cmp > div.k { text-align: left; }
.cmp > div.h { font-weight: 600; background: #f4f4f4; }
.why li { margin: 0.35em 0; }
.figure { margin: 0.8em 0 1.4em; min-width: 0; }
.figcap { color: #555; font-size: 0.9em; margin: 0.1em 0 0; }
"""

_SCRIPT = """
(function () {
  // Figures whose layout.meta holds a "narrow" relayout (the trajectories' two panels
  // stacked) take it below meta.narrow_px of width and give it back above.
  function fit() {
    if (!window.Plotly) { return; }
    document.querySelectorAll('.js-plotly-plot').forEach(function (gd) {
      var meta = gd.layout && gd.layout.meta;
      if (!meta || !meta.narrow) { return; }
      var narrow = gd.parentElement.clientWidth < meta.narrow_px;
      var mode = narrow ? 'narrow' : 'wide';
      if (gd.dataset.mode === mode) { return; }
      gd.dataset.mode = mode;
      var update = narrow ? meta.narrow : meta.wide;
      // plotly.py sizes a wrapper div as well as the plot's own: both follow the height
      gd.style.height = update.height + 'px';
      if (gd.parentElement.style.height) { gd.parentElement.style.height = update.height + 'px'; }
      window.Plotly.relayout(gd, update);
    });
  }
  var timer = null;
  window.addEventListener('resize', function () {
    if (timer) { clearTimeout(timer); }
    timer = setTimeout(fit, 150);
  });
  if (document.readyState === 'loading') {
    document.addEventListener('DOMContentLoaded', fit);
  } else { fit(); }
})();
"""

TABLE1_TITLE = "Table 1 Comparison of variance and RMSE"
"""The title the paper gives its Table 1."""
SCROLL_ROWS = 25
"""Tables with more rows than this scroll inside a box."""

DESCRIPTIONS = {
    "laser": "the NAV's own pose converted to the rotation centre O: the paper's baseline",
    "deadreckoning": "wheel encoders and gyro composed from a first fix, never corrected",
    "ekf": "an extended Kalman filter on the odometry and the NAV's observations",
    "pf-paper": "the paper's particle filter (Ali et al.)",
    "pf": "the paper's filter with the improvements of AMCL-class localisers",
}
"""One phrase per built-in estimator (docs/filter.md says more)."""


def _table_html(kind: str, head: list[str], body: list[list[str]], caption: str, *,
                title: str | None = None, aggregate_last: bool = False) -> str:
    """A table in a box that scrolls sideways when the page is narrower than the table;
    ``title`` leads the caption in bold, ``aggregate_last`` marks the last row (an average)
    as the one bold row; tables longer than :data:`SCROLL_ROWS` also scroll down."""
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
        return f'<div class="box scroll" data-scroll="{e(kind)}">{table}</div>'
    return f'<div class="box">{table}</div>'


def _swatch(colour: str) -> str:
    return f'<span class="swatch" style="background:{html.escape(colour)}"></span>'


def _mm(v: float | None, digits: int = 1) -> str:
    return "-" if v is None or not math.isfinite(v) else f"{v * MM:.{digits}f} mm"


# ------------------------------------------------------------------------------ the verdict


def _verdict_of(res: EvaluationResult) -> Verdict | None:
    """The verdict that :func:`lgvtool.app.evaluate_job.evaluate_logs` set on ``res`` (it
    knows the files written), else one made here without them; None if it cannot be made."""
    v: Verdict | None = getattr(res, "verdict", None)
    if v is not None:
        return v
    try:
        from lgvtool.evaluate.verdict import verdict_of
    except ImportError:  # pragma: no cover - the verdict module is part of lgvtool
        return None
    return verdict_of(res)


def _verdict_rows(v: Verdict, col: dict[str, str]) -> str:
    """One row per estimator: its error, its multiple of the laser's (with a bar: the
    laser's length is the quarter mark), what it observed and its note."""
    e = html.escape
    rows = []
    for est in v.estimators:
        colour = col.get(est.name, "#888888")
        figure = _mm(est.error_m) if est.error_m is not None else (
            _mm(est.disagreement_m) + " from laser" if est.disagreement_m is not None else "-")
        if est.ratio_to_laser is not None:
            width = min(est.ratio_to_laser, 4.0) * 25.0
            ratio = (f"{est.ratio_to_laser:.2f} × the laser"
                     f'<span class="bar" style="width:{width:.1f}%;background:{e(colour)}">'
                     "</span>")
        else:
            ratio = ""
        obs = e(est.observations) + (f"; {e(est.note)}" if est.note else "")
        rows.append(f'<li data-estimator="{e(est.name)}"><span class="name">'
                    f"{_swatch(colour)}{e(est.name)}</span>"
                    f'<span class="fig">{e(figure)}</span><span class="ratio">{ratio}</span>'
                    f'<span class="obs">{obs}</span></li>')
    return '<ul class="est">' + "".join(rows) + "</ul>"


def _verdict_html(v: Verdict, col: dict[str, str], *, heading: str = "Verdict",
                  files: bool = True) -> str:
    """The verdict of one log as the report's opening box."""
    e = html.escape
    parts = [f"<h2>{e(heading)}</h2>"]
    if v.reference == "none":
        parts.append(f'<p class="ref">No reference, so no figure of accuracy: '
                     f"{e(v.reference_text)}.</p>")
    else:
        parts.append(f'<p class="ref">Each estimator\'s {e(v.reference_text)}; lower is '
                     "better.</p>")
    parts.append(_verdict_rows(v, col))
    if v.paper:
        parts.append(f'<p class="paper">{e(v.paper)}.</p>')
    if v.no_reference_text:
        parts.append(f'<p class="note">{e(v.no_reference_text)}</p>')
    if v.warnings:
        parts.append('<ul class="warnings">' + "".join(f"<li>{e(w)}</li>" for w in v.warnings)
                     + "</ul>")
    if files and v.paths:
        from lgvtool.evaluate.verdict import paths_line

        parts.append(f'<p class="files">{e(paths_line(v.paths, width=400))}</p>')
    return (f'<div class="verdict" data-part="verdict" data-log="{e(v.log)}" '
            f'data-reference="{e(v.reference)}">' + "".join(parts) + "</div>")


MATRIX_LOGS = 6
"""Up to this many logs the opening verdict sets their estimators side by side."""


def _verdicts_html(results: Sequence[EvaluationResult], col: dict[str, str]) -> str:
    """The opening box over several logs: the one-line summary, then (up to
    :data:`MATRIX_LOGS` logs) each estimator's error and multiple of the laser's per log
    side by side, and the logs' warnings; each log's full verdict opens its section."""
    from lgvtool.evaluate.table import estimator_order
    from lgvtool.evaluate.verdict import paths_line, summary_line

    e = html.escape
    verdicts = [v for v in (_verdict_of(r) for r in results) if v is not None]
    parts = ["<h2>Verdict</h2>"]
    if verdicts:
        parts.append(f'<p class="ref">{e(summary_line(verdicts, width=1000))}.</p>')
    if verdicts and len(verdicts) <= MATRIX_LOGS:
        names = estimator_order([est.name for v in verdicts for est in v.estimators])
        cells = ['<div class="h"></div>'] + [
            f'<div class="h">{e(v.log)}<span class="sub">{e(v.reference)}</span></div>'
            for v in verdicts]
        for n in names:
            cells.append(f'<div class="k">{_swatch(col.get(n, "#888888"))}{e(n)}</div>')
            for v in verdicts:
                est = next((x for x in v.estimators if x.name == n), None)
                if est is None or est.error_m is None:
                    cells.append("<div>-</div>")
                    continue
                ratio = (f'<span class="sub">{est.ratio_to_laser:.2f} × laser</span>'
                         if est.ratio_to_laser is not None else "")
                cells.append(f"<div><b>{e(_mm(est.error_m))}</b>{ratio}</div>")
        style = f"grid-template-columns: auto repeat({len(verdicts)}, minmax(max-content, 1fr))"
        parts.append(f'<div class="box"><div class="vm" style="{style}">' + "".join(cells)
                     + "</div></div>")
        parts.append('<p class="note">Under each log\'s name the reference its figures are '
                     "measured against; each log's verdict in full opens its section.</p>")
        warns = [f"{v.log}: {w}" for v in verdicts for w in v.warnings]
        if warns:
            parts.append('<ul class="warnings">' + "".join(f"<li>{e(w)}</li>" for w in warns)
                         + "</ul>")
    else:
        parts.append('<p class="note">Each log\'s verdict opens its section below.</p>')
    paths = verdicts[-1].paths if verdicts else ()
    if paths:
        parts.append(f'<p class="files">{e(paths_line(paths, width=400))}</p>')
    return '<div class="verdict" data-part="verdict">' + "".join(parts) + "</div>"


# ------------------------------------------------------------------------------ the story


def _facts(res: EvaluationResult) -> str:
    ref = res.reference
    facts: list[tuple[str, str]] = []
    if ref.steering_angle is not None:
        facts.append(("steering angle delta", f"{math.degrees(ref.steering_angle):.2f} deg "
                      f"({'median of the logged angle' if ref.steering_source == 'log' else 'configured'})"))
    facts.append(("h (O to drive wheel)", f"{ref.h:.3f} m"))
    if ref.kinematic_radius is not None:
        facts.append(("kinematic radius R = h / tan(delta)", f"{ref.kinematic_radius:.4f} m"))
    if ref.fixed_circle:
        whom = {"truth": "the ground truth", "estimator": f"estimator '{ref.circle_reference}'",
                "topic": f"the bag topic {ref.circle_reference} (at import)"}
        facts.append(("reference circle", f"fitted to {whom[ref.circle_source]} (centre and "
                      f"radius); every other trajectory is scored against it"))
    else:
        facts.append(("radius used", "free (geometric fit)" if ref.free_radius
                      else "kinematic"))
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
    return ('<details><summary>The reference in figures</summary><div class="box">'
            f'<table class="facts" data-table="reference">{rows}</table></div></details>')


def _duration(res: EvaluationResult) -> float:
    ends = [float(ev.trajectory.t[-1]) for ev in res.estimators.values()
            if len(ev.trajectory)]
    return max(ends, default=res.t0) - res.t0


def _what_was_run(res: EvaluationResult, col: dict[str, str]) -> str:
    """What was run: the drive, the estimators and what each observed, the reference."""
    e = html.escape
    ref = res.reference
    drive = f"{_duration(res):.0f} s of driving"
    speed = getattr(res, "drive_speed", None)
    if speed is not None:
        drive += f" at {speed * 100:.0f} cm/s (drive wheel, median while moving)"
    if ref.steering_angle is not None:
        drive += f", steering {math.degrees(ref.steering_angle):.1f}°"
    drive += ", with ground truth" if res.has_truth else ", without ground truth"
    source = ("computed by replaying the log" if res.source == "replay"
              else "read from the log (as an earlier replay or another tool wrote them)")
    parts = [f"<p>{e(res.name)}: {e(drive)}. The estimates were {e(source)}:</p>"]
    items = []
    observed = getattr(res, "observations", None) or {}
    for n in res.estimators:
        what = DESCRIPTIONS.get(n, "")
        used = observed.get(n)
        tail = "; ".join(x for x in (what, f"it observed {used}" if used else "") if x)
        items.append(f"<li>{_swatch(col[n])}<b>{e(n)}</b>{': ' + e(tail) if tail else ''}</li>")
    parts.append('<ul class="run">' + "".join(items) + "</ul>")
    if ref.circle_drive and res.laps.complete == 0:
        parts.append("<p>The drive makes no complete rotation about the circle the kinematic "
                     "model predicts, so there are no circle figures"
                     + ("; the estimates are scored against the ground truth.</p>"
                        if res.has_truth else ".</p>"))
    elif ref.circle_drive and ref.kinematic_radius is not None:
        radius = ("a radius fitted to each estimate" if ref.free_radius
                  else f"the kinematic radius R = h / tan δ = {ref.kinematic_radius:.3f} m")
        centre = ("one centre shared by all estimators" if ref.shared_centre
                  else "its centre fitted to each estimate")
        laps = (f"{res.laps.complete} complete rotation{'s' if res.laps.complete != 1 else ''}"
                f" found on {res.laps.source or 'the estimates'}"
                + (f", {res.laps.partial} partial one left out" if res.laps.partial else ""))
        parts.append(f"<p>The reference is the circle the kinematic model predicts, with "
                     f"{e(radius)} and {e(centre)}: {e(laps)}.</p>")
        if res.truth_path is not None:
            parts.append(
                "<p>The vehicle's true path departs from that circle by "
                f"{res.truth_path.rmse * 1e3:.1f} mm RMS (bias "
                f"{res.truth_path.mean * 1e3:+.1f} mm): a real vehicle never drives the "
                "kinematic circle exactly, and every circle figure below includes this.</p>")
    elif res.has_truth:
        parts.append("<p>No reference circle: the estimates are scored against the ground "
                     "truth only.</p>")
    else:
        parts.append("<p>Neither a reference circle nor ground truth: no figure of accuracy "
                     "can be computed.</p>")
    return "".join(parts)


def _paper_claim(table: Table1, results: Sequence[EvaluationResult]) -> str:
    """The paper's published Table 1 Average beside this evaluation's computed one."""
    from lgvtool.evaluate.verdict import (
        PAPER,
        PAPER_FILTER,
        PAPER_SPEED_M_S,
        PAPER_STEERING_DEG,
        is_paper_experiment,
    )

    e = html.escape
    p_ratio = PAPER["filter_rmse_mm"] / PAPER["laser_rmse_mm"]
    p_vratio = PAPER["filter_variance_mm2"] / PAPER["laser_variance_mm2"]
    parts = [f"<p>Ali et al. drove their vehicle round a circle at {PAPER_SPEED_M_S * 100:.0f} "
             f"cm/s with the steering at {PAPER_STEERING_DEG:.0f}° and report in their Table 1 "
             f"that their particle filter cuts the laser navigation's per-rotation error from "
             f"<b>{PAPER['laser_rmse_mm']:.1f} to {PAPER['filter_rmse_mm']:.1f} mm RMSE</b> "
             f"({p_ratio:.2f} ×) and its variance from {PAPER['laser_variance_mm2']:.0f} to "
             f"{PAPER['filter_variance_mm2']:.0f} mm² ({p_vratio:.2f} ×). Those are the paper's "
             "figures, on its own vehicle; the column beside them is computed from this "
             "evaluation.</p>"]
    if not table.rows:
        parts.append(f'<p class="note">{e(no_rows_note(table))} Nothing here to set beside '
                     "the paper's figures.</p>")
        return "".join(parts)
    laser = table.average.get(BASELINE)
    filt = table.average.get(PAPER_FILTER)

    def ratio(a: float | None, b: float | None) -> str:
        return f"{a / b:.2f} ×" if a is not None and b is not None and b > 0 else "-"

    l_rmse = laser.rmse * MM if laser else None
    f_rmse = filt.rmse * MM if filt else None
    l_var = laser.variance * MM * MM if laser else None
    f_var = filt.variance * MM * MM if filt else None

    def num(v: float | None, d: int) -> str:
        return "-" if v is None or not math.isfinite(v) else f"{v:.{d}f}"

    rows = [("laser RMSE (mm)", f"{PAPER['laser_rmse_mm']:.1f}", num(l_rmse, 1)),
            ("filter RMSE (mm)", f"{PAPER['filter_rmse_mm']:.1f}", num(f_rmse, 1)),
            ("filter ÷ laser, RMSE", f"{p_ratio:.2f} ×", ratio(f_rmse, l_rmse)),
            ("laser variance (mm²)", f"{PAPER['laser_variance_mm2']:.0f}", num(l_var, 0)),
            ("filter variance (mm²)", f"{PAPER['filter_variance_mm2']:.0f}", num(f_var, 0)),
            ("filter ÷ laser, variance", f"{p_vratio:.2f} ×", ratio(f_var, l_var))]
    here = (f"this evaluation ({PAPER_FILTER})" if len(results) == 1
            else f"these {len(results)} logs ({PAPER_FILTER})")
    cells = ['<div class="k h">Average of the rotations</div>',
             '<div class="h paperfig">the paper</div>', f'<div class="h">{e(here)}</div>']
    for k, a, b in rows:
        cells += [f'<div class="k">{e(k)}</div>', f'<div class="paperfig">{e(a)}</div>',
                  f"<div>{e(b)}</div>"]
    parts.append('<div class="cmp" data-part="paper-comparison">' + "".join(cells) + "</div>")
    same = [r for r in results if is_paper_experiment(r)]
    if len(same) == len(results):
        whose = "this log's" if len(results) == 1 else "these logs'"
        parts.append('<p class="note">The paper\'s experiment (its steering angle and speed), '
                     "so the two columns measure the same thing; the paper's vehicle, NAV and "
                     f"hall are not {whose}.</p>")
    else:
        parts.append('<p class="note">Not (all) the paper\'s experiment: a different steering '
                     "angle or speed changes the laser's error while turning, so the columns "
                     "compare ratios rather than millimetres.</p>")
    if filt is None:
        parts.append(f'<p class="note">{e(PAPER_FILTER)} was not evaluated (-e {PAPER_FILTER}):'
                     " no filter figure to set beside the paper's.</p>")
    return "".join(parts)


def _along_across(res: EvaluationResult, name: str) -> tuple[float, float, float] | None:
    """RMS of the error along and across the true path over the complete rotations (else the
    whole drive), m, and the mean along-path error, m (negative: behind the vehicle)."""
    if res.truth is None:
        return None
    from lgvtool.evaluate.metrics import associate_truth

    a = associate_truth(res.estimators[name].trajectory, res.truth)
    if a.empty:
        return None
    inside = res.laps.index(a["t"]) > 0 if res.laps.complete else np.ones(len(a), dtype=bool)
    if not inside.any():
        return None
    dx = (a["x"] - a["x_true"]).to_numpy(dtype=float)[inside]
    dy = (a["y"] - a["y_true"]).to_numpy(dtype=float)[inside]
    th = a["heading_true"].to_numpy(dtype=float)[inside]
    along = dx * np.cos(th) + dy * np.sin(th)
    across = -dx * np.sin(th) + dy * np.cos(th)
    ok = np.isfinite(along) & np.isfinite(across)
    if not ok.any():
        return None
    return (float(np.sqrt(np.mean(along[ok] ** 2))), float(np.sqrt(np.mean(across[ok] ** 2))),
            float(np.mean(along[ok])))


def _true_speed(res: EvaluationResult) -> float | None:
    """Median speed of O along the true path while moving, m/s."""
    if res.truth is None or len(res.truth) < 3:
        return None
    t = res.truth.t
    d = np.hypot(np.diff(res.truth.x), np.diff(res.truth.y))
    dt = np.diff(t)
    v = d[dt > 0] / dt[dt > 0]
    v = v[np.isfinite(v) & (v > 0.01)]
    return float(np.median(v)) if v.size else None


def _where_from(res: EvaluationResult, col: dict[str, str]) -> str:
    """Where each estimator's error comes from, from this log's own figures."""
    e = html.escape
    truth_series = {n: (ev.truth_error["t"].to_numpy() - res.t0,
                        ev.truth_error["position_error"].to_numpy() * MM)
                    for n, ev in res.estimators.items() if ev.truth_error is not None}
    radial_series = {n: (ev.radial["t"].to_numpy() - res.t0, ev.radial["error"].to_numpy() * MM)
                     for n, ev in res.estimators.items() if ev.radial is not None}
    series = truth_series or radial_series
    scale = steady_scale(series) if series else None
    speed = _true_speed(res)
    items = []
    for n, ev in res.estimators.items():
        said: list[str] = []
        p = ev.pooled
        if p is not None and math.isfinite(p.rmse) and p.rmse > 0:
            sd = math.sqrt(max(p.variance, 0.0))
            share = 100.0 * p.mean * p.mean / (p.rmse * p.rmse)
            side = "outside" if p.mean > 0 else "inside"
            if share >= 5.0:
                text = (f"on the circle {_mm(p.rmse)} RMS over the rotations' samples: a bias "
                        f"of {_mm(abs(p.mean))} {side} the circle and a spread of {_mm(sd)}; "
                        f"the bias carries {share:.0f} % of the mean square")
            else:
                text = (f"on the circle {_mm(p.rmse)} RMS over the rotations' samples, nearly "
                        f"all spread ({_mm(sd)}; bias {p.mean * MM:+.1f} mm)")
            if share > 50.0 and ev.fitted is not None and ev.circle is not None:
                text += (f" (its own circle has a radius of {ev.fitted.r:.4f} m against "
                         f"{ev.circle.r:.4f} m)")
            said.append(text)
            if ev.centre_offset is not None and ev.centre_offset > 0.01:
                said.append(f"its circle's centre lies {_mm(ev.centre_offset)} from the "
                            "reference centre, which the radial error cannot show")
        aa = _along_across(res, n)
        if aa is not None:
            along, across, mean_along = aa
            where = "in the rotations" if res.laps.complete else "over the drive"
            text = (f"against the truth, {where}, {_mm(along)} RMS along the path and "
                    f"{_mm(across)} across it")
            if speed is not None and abs(mean_along) > 0.002:
                lag = abs(mean_along) / speed * 1e3
                text += (f"; on average {_mm(abs(mean_along))} "
                         f"{'behind' if mean_along < 0 else 'ahead of'} the vehicle, the "
                         f"distance it covers in {lag:.0f} ms at {speed:.2f} m/s")
            said.append(text)
        if scale is not None and n in scale.ends:
            t, y = series[n]
            ok = np.isfinite(y)
            t, y = t[ok], y[ok]
            end = scale.ends[n]
            start = t < end
            total = float(np.sum(y * y))
            if start.any() and total > 0:
                share = 100.0 * float(np.sum(y[start] ** 2)) / total
                peak = float(np.max(np.abs(y[start])))
                if share >= 10.0:
                    said.append(f"its start-up (the first {end:.1f} s, up to "
                                f"{peak:.0f} mm) carries {share:.0f} % of its squared error "
                                f"{'against the truth' if truth_series else 'about the circle'}")
        if said:
            items.append(f"<li>{_swatch(col[n])}<b>{e(n)}</b>: " + "; ".join(e(s) for s in said)
                         + ".</li>")
    if not items:
        return '<p class="note">No figure here to take apart.</p>'
    return ('<ul class="why">' + "".join(items) + "</ul>"
            '<p class="note">A bias (a constant offset while turning) and a delay (an error '
            "along the path) point at the sensor's timing and geometry; a spread points at "
            "noise and at which reflectors each fix used. Why the NAV's pose is off while "
            "turning, mechanism by mechanism: docs/simulator.md, \"Where the laser navigation's "
            "error comes from\"; what each filter does: docs/filter.md.</p>")


def _tables(table: Table1, label: str) -> list[str]:
    parts: list[str] = []
    if table.rows:
        head, body = table1_cells(table)
        if table.multi_log:  # rotations keep their number in their own log, as on the terminal
            head[1] = "Rotation"
            for cells, row in zip(body, table.rows, strict=False):
                cells[1] = str(row.rotation)
        parts.append(_table_html("table1", head, body,
                                 f"{label}: RMSE (mm) and variance (mm²) of the radial error "
                                 f"per rotation, {len(table.rows)} rotations"
                                 + (", numbered in each log" if table.multi_log else ""),
                                 title=TABLE1_TITLE, aggregate_last=True))
    else:
        parts.append(f"<p>{html.escape(no_rows_note(table))}</p>")
    parts.append(_table_html("summary", *summary_cells(table),
                             f"{label}: summary per estimator"))
    parts.append(_column_help())
    return parts


def _column_help() -> str:
    """What every column means (the list ``lgvtool evaluate --help`` prints), folded."""
    from lgvtool.evaluate.verdict import COLUMN_HELP

    e = html.escape
    items = "".join(f"<dt>{e(k)}</dt><dd>{e(v)}</dd>" for k, v in COLUMN_HELP)
    return (f'<details class="columns"><summary>What the columns mean</summary><dl>{items}'
            "</dl></details>")


FIGURE_CAPTIONS = {
    "trajectories": "Every estimate and the truth over the reference circle and the "
                    "reflectors: the hall, then the drive close up (the paper's Fig. 6a).",
    "radial-error": "Distance from the reference circle over time (the paper's Fig. 6b), "
                    "positive outside. The y-axis is set by the steady state: a start-up is "
                    "shaded and its off-scale peak named; double-click the plot to see it all.",
    "rotations": "Each rotation's RMSE per estimator: Table 1 as bars.",
    "truth-error": "Distance from the ground truth over time, scaled to the steady state as "
                   "above.",
    "all-rotations": "Each rotation's RMSE per estimator over all logs, named by log and "
                     "rotation number in that log.",
    "data-quality": "The log's diagnostics and gaps over time.",
}


class _Figures:
    """Renders figures to HTML divs, embedding plotly.js in the first one only. The figure's
    title becomes the HTML heading above it (it wraps on a narrow screen; plotly's does not)."""

    def __init__(self) -> None:
        self.count = 0
        self.slugs: list[str] = []

    def __call__(self, slug: str, fig: go.Figure, kind: str | None = None) -> str:
        title = fig.layout.title.text
        top = fig.layout.margin.t
        fig.layout.title.text = None
        # room above the plot for plotly's tool bar and the notes set above the plot area
        # (subplot titles, rotation numbers), which the tool bar would otherwise cover
        above = any(a.yref == "paper" and (a.y or 0) >= 1.0 for a in fig.layout.annotations)
        fig.layout.margin.t = 58 if above else 36
        try:
            div: str = fig.to_html(full_html=False, include_plotlyjs=self.count == 0,
                              config={"displaylogo": False, "responsive": True})
        finally:
            fig.layout.title.text = title
            fig.layout.margin.t = top
        self.count += 1
        self.slugs.append(slug)
        e = html.escape
        caption = FIGURE_CAPTIONS.get(kind or slug, "")
        return (f'<div class="figure" data-figure="{e(slug)}">'
                + (f'<h4 class="figtitle">{e(title)}</h4>' if title else "")
                + div + (f'<p class="figcap">{e(caption)}</p>' if caption else "") + "</div>")


def _quality_html(res: EvaluationResult, fig_html: _Figures, prefix: str,
                  figures: list[tuple[str, go.Figure]] | None, anchor: str) -> str:
    """The data-quality section of one log (empty when the log cannot be read again)."""
    if not res.path:
        return ""
    q = log_quality(res)
    if q is None:
        return ""
    e = html.escape
    if not q.any:
        return (f'<section data-section="data-quality" id="{anchor}-quality"><h3>Data quality'
                '</h3><p class="note">'
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
    parts = [f'<section data-section="data-quality" id="{anchor}-quality"><h3>Data quality</h3>',
             '<div class="box"><table class="facts" data-table="quality">'
             + "".join(f"<tr><td>{e(k)}</td><td>{e(v)}</td></tr>" for k, v in facts)
             + "</table></div>"]
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
    parts.append(fig_html(prefix + "data-quality", fig, "data-quality"))
    if figures is not None:
        figures.append((prefix + "data-quality", fig))
    parts.append("</section>")
    return "".join(parts)


_LEVELS = {1: "debug", 2: "info", 3: "warning", 4: "error", 5: "fatal"}


def _toc(anchor: str, has_paper: bool, has_quality: bool) -> str:
    links = [("run", "What was run")]
    if has_paper:
        links.append(("paper", "The paper's claim"))
    links += [("measured", "What lgvtool measured"), ("why", "Where the error comes from")]
    if has_quality:
        links.append(("quality", "Data quality"))
    return ('<nav class="toc">In this report: ' + " · ".join(
        f'<a href="#{anchor}-{k}">{html.escape(t)}</a>' for k, t in links) + "</nav>")


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
    multi = len(results) > 1
    col = colours([n for r in results for n in r.estimators])

    def keep(slug: str, fig: go.Figure, kind: str | None = None) -> str:
        if figures is not None:
            figures.append((slug, fig))
        return fig_html(slug, fig, kind)

    if multi:
        meta = f"lgvtool {__version__}; {len(results)} logs."
    else:
        res0 = results[0]
        where = f"; log <code>{e(res0.path)}</code>" if res0.path else ""
        meta = f"lgvtool {e(__version__)}{where}."
    body: list[str] = [f'<h1>{e(title)}</h1><p class="meta">{meta}</p>']
    if multi:
        table = build_table(results)
        body.append('<section data-section="aggregate" id="all"><h2>All logs</h2>')
        lead = _verdicts_html(results, col)
        if table.rows:
            fig = rotation_bars_figure(table, title="All logs: RMSE per rotation")
            lead += keep("all-rotations", fig)
        body.append(f'<div class="lead">{lead}</div>')
        if table.rows:
            body.append('<div class="part" id="all-paper"><h3>The paper\'s claim</h3>'
                        + _paper_claim(table, results) + "</div>")
        body.append('<div class="part" id="all-measured"><h3>What lgvtool measured, all '
                    "logs</h3>" + "".join(_tables(table, "All logs")) + "</div>")
        body.append("</section>")
    for i, res in enumerate(results):
        table = build_table([res])
        prefix = f"{res.name}-" if multi else ""
        anchor = f"log-{i + 1}"
        figs = log_figures(res, table)
        rendered = {slug: keep(prefix + slug, fig, slug) for slug, fig in figs[:1]}
        verdict = _verdict_of(res)
        if not multi:
            lead = _verdict_html(verdict, col) if verdict is not None else ""
            body.append(f'<div class="lead">{lead}{rendered.get("trajectories", "")}</div>')
            body.append(_toc(anchor, bool(table.rows), bool(res.path)))
        body.append(f'<section data-section="log" data-log="{e(res.name)}" id="{anchor}">')
        body.append(f"<h2>{e(res.name)}</h2>")
        if multi and verdict is not None:
            body.append(_verdict_html(verdict, col, heading=f"Verdict on {res.name}",
                                      files=False))
        body.append(f'<div class="part" id="{anchor}-run"><h3>What was run</h3>')
        body.append(_what_was_run(res, col))
        if res.warnings:
            body.append('<ul class="warnings">' + "".join(f"<li>{e(w)}</li>" for w in res.warnings)
                        + "</ul>")
        body.append(_facts(res))
        if multi:
            body.append(rendered.get("trajectories", ""))
        body.append("</div>")
        if not multi and table.rows:
            body.append(f'<div class="part" id="{anchor}-paper"><h3>The paper\'s claim</h3>'
                        + _paper_claim(table, [res]) + "</div>")
        body.append(f'<div class="part" id="{anchor}-measured"><h3>What lgvtool measured</h3>')
        body += _tables(table, res.name)
        later = {slug: fig for slug, fig in figs[1:]}
        for slug in ("radial-error", "rotations"):
            if slug in later:
                body.append(keep(prefix + slug, later[slug], slug))
        body.append("</div>")
        body.append(f'<div class="part" id="{anchor}-why"><h3>Where the error comes from</h3>')
        body.append(_where_from(res, col))
        if "truth-error" in later:
            body.append(keep(prefix + "truth-error", later["truth-error"], "truth-error"))
        body.append("</div>")
        body.append(_quality_html(res, fig_html, prefix, figures, anchor))
        body.append("</section>")
        if progress is not None:
            progress(1)
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{e(title)}</title><style>{_STYLE}</style></head><body>\n"
            + "\n".join(body) + f"\n<script>{_SCRIPT}</script>\n</body></html>\n")

