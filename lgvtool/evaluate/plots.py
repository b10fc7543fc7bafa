"""Plotly figures of an evaluation (the paper's Fig. 6 and more). Pure: figures in, no files.

- :func:`trajectory_figure`: trajectories over the reference circle and the reflector map
  (Fig. 6a), as a hall overview beside a close-up of the drive;
- :func:`radial_error_figure`: signed radial error against time per estimator (Fig. 6b);
- :func:`rotation_bars_figure`: RMSE per rotation and estimator: grouped bars up to
  :data:`MAX_BAR_ROTATIONS` rotations, beyond that a line per estimator over the rotations
  (with a range slider) beside the distribution of the per-rotation RMSE (box plots), which
  stay readable at hundreds of rotations;
- :func:`truth_error_figure`: position error against the ground truth over time;
- :func:`quality_timeline_figure`: the log's diagnostics and gaps over time.

Axes are in m and s; errors are shown in mm. Every figure is built in time linear in the data:
rotation boundaries are one list of shapes set at once (never one ``add_vline`` per rotation,
which re-validates every shape so far), and drawn only up to :data:`MAX_BOUNDARY_LINES`.

The error figures over time are scaled to the steady state (:func:`steady_scale`): a filter's
start-up (pf-paper's uniform start, hundreds of mm for a few seconds) is shaded and labelled,
its off-scale peak named in a note, and does not set the y-axis, so the laser's band of a few
tens of mm stays readable. Every line is labelled: estimators, truth and circle in the legend,
rotation boundaries by a legend entry and their numbers (Table 1's) above the plot, the zero
line by name. Colours come from lgvtool's one table (:mod:`lgvtool.colours`), shared with the
Foxglove layout. Legends sit below the plots and the trajectory figure stacks its two panels
on a narrow page (its ``layout.meta["narrow"]``, applied by the report's script), so that the
figures read at 420 px as at 1400 px.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import plotly.graph_objects as go
from plotly.colors import qualitative
from plotly.subplots import make_subplots

from lgvtool import colours as shared_colours
from lgvtool.circle import Circle
from lgvtool.errors import InputError
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.quality import DataQuality
from lgvtool.evaluate.table import MM, Table1, estimator_order
from lgvtool.extras import require
from lgvtool.json_types import JSONObject

MAX_POINTS = 5000
"""Traces longer than this are decimated (every k-th sample) to keep the report small."""

MAX_BAR_ROTATIONS = 30
"""Up to this many rotations the per-rotation figure shows grouped bars."""
MAX_BOUNDARY_LINES = 60
"""Rotation boundaries are drawn as lines up to this many rotations."""

TRUTH_COLOUR = shared_colours.TRUTH_ON_LIGHT
CIRCLE_COLOUR = "#c8c8c8"
"""The reference circle: a light grey, dashed, apart from deadreckoning's mid grey."""

ESTIMATOR_COLOURS = {n: c for n, c in shared_colours.SOURCE_COLOURS.items() if n != "nav"}
"""The colours of the built-in estimators, those of the Foxglove layout and the live view
(:mod:`lgvtool.colours`): laser blue, deadreckoning grey, ekf green, pf-paper red, pf purple;
the pair compared most (laser and pf-paper) far apart, none near the truth's black or the
circle's light grey."""

BOUNDARY_COLOUR = "#aaaaaa"
NOTE_COLOUR = "#555555"

STARTUP_SHARE = 0.25
"""A start-up is looked for in the first quarter of a drive at most (:func:`steady_scale`)."""

NARROW_PX = 640
"""Below this width (px) the report lays the trajectory figure out for a phone
(``layout.meta["narrow"]``)."""


def colours(names: Sequence[str]) -> dict[str, str]:
    """A fixed colour per estimator name: the built-in ones their own, others from plotly's
    palette (skipping colours already taken)."""
    taken = {ESTIMATOR_COLOURS[n] for n in names if n in ESTIMATOR_COLOURS}
    spare = [c for c in qualitative.Dark24 if c not in taken]
    out: dict[str, str] = {}
    k = 0
    for n in estimator_order(names):
        if n in ESTIMATOR_COLOURS:
            out[n] = ESTIMATOR_COLOURS[n]
        else:
            out[n] = spare[k % len(spare)]
            k += 1
    return out


def _decimate(n: int) -> slice:
    return slice(None, None, max(1, int(np.ceil(n / MAX_POINTS))))


def _reference_circle(res: EvaluationResult) -> Circle | None:
    if res.reference_circle is not None:
        return res.reference_circle
    return next((ev.circle for ev in res.estimators.values() if ev.circle is not None), None)


LEGEND_BELOW: dict[str, Any] = {"orientation": "h", "x": 0.0, "xanchor": "left",
                                "yref": "container", "y": 0.0, "yanchor": "bottom"}
"""Legends at the foot of the figure, in rows that wrap (a side legend takes a third of a
phone); plotly makes room for them below the axis, its tick labels and its title."""
MARGIN: dict[str, int] = {"l": 60, "r": 16, "t": 56, "b": 8}


def _layout(fig: go.Figure, *, title: str, height: int, **more: object) -> None:
    """The layout every report figure shares: title, legend below, narrow margins."""
    fig.update_layout(title={"text": title, "x": 0.0, "xanchor": "left"}, height=height,
                      legend=LEGEND_BELOW, margin=MARGIN, **more)


def _narrow(fig: go.Figure, narrow: JSONObject, wide: JSONObject) -> None:
    """Store in ``layout.meta`` the relayout the report's script applies below
    :data:`NARROW_PX` of width (``narrow``) and gives back above it (``wide``)."""
    fig.update_layout(meta={"narrow": narrow, "wide": wide, "narrow_px": NARROW_PX})


def _taller_when_narrow(fig: go.Figure, extra: int = 140) -> None:
    """On a phone the legend below wraps into several rows: the figure grows by ``extra`` px
    there, so that the plot keeps its height."""
    h = int(fig.layout.height)
    _narrow(fig, {"height": h + extra}, {"height": h})


def trajectory_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Trajectories of every estimator (and the truth) over the reference circle, with the
    reflector map: the whole hall on the left, the drive on the right (stacked on a narrow
    page: ``layout.meta["narrow"]`` holds the relayout the report applies there)."""
    fig = make_subplots(rows=1, cols=2, column_widths=[0.45, 0.55],
                        subplot_titles=("Hall and reflectors", "Drive and reference circle"))
    col = colours(list(res.estimators))
    # the reference circle only where the drive goes round it (a straight drive's kinematic
    # circle can be kilometres wide and would set both panels' scale)
    circle = _reference_circle(res) if res.laps.complete else None
    for c in (1, 2):
        show = c == 2
        if res.reflectors:
            fig.add_trace(go.Scatter(
                x=[r.x for r in res.reflectors], y=[r.y for r in res.reflectors],
                mode="markers", name="reflectors", legendgroup="reflectors", showlegend=show,
                marker={"symbol": "circle-open", "size": 9, "color": "#444"},
                text=[f"reflector {r.id}" for r in res.reflectors], hoverinfo="text+x+y"),
                row=1, col=c)
        if circle is not None:
            cx, cy = circle.points()
            fig.add_trace(go.Scatter(
                x=cx, y=cy, mode="lines", name=f"reference circle (R = {circle.r:.3f} m)",
                legendgroup="circle", showlegend=show,
                line={"color": CIRCLE_COLOUR, "dash": "dash", "width": 3}), row=1, col=c)
        for n in estimator_order(list(res.estimators)):
            df = res.estimators[n].trajectory
            s = _decimate(len(df))
            fig.add_trace(go.Scatter(
                x=df.x[s], y=df.y[s], mode="lines", name=n,
                legendgroup=n, showlegend=show, line={"color": col[n], "width": 1.5}),
                row=1, col=c)
        if res.truth is not None:
            # drawn last, so on top of the estimates, dotted so they show through
            s = _decimate(len(res.truth))
            fig.add_trace(go.Scatter(
                x=res.truth.x[s], y=res.truth.y[s], mode="lines",
                name="truth", legendgroup="truth", showlegend=show,
                line={"color": TRUTH_COLOUR, "width": 1.5, "dash": "dot"}), row=1, col=c)
    if circle is not None:
        span = circle.r * 1.6
        fig.update_xaxes(range=[circle.cx - span, circle.cx + span], row=1, col=2)
        fig.update_yaxes(range=[circle.cy - span, circle.cy + span], row=1, col=2)
    else:  # the drive close up: where the truth (else the estimates) mostly went
        ref = res.truth if res.truth is not None else next(
            (ev.trajectory for ev in res.estimators.values() if len(ev.trajectory)), None)
        if ref is not None and len(ref):
            (x0, x1), (y0, y1) = (np.nanpercentile(v, [1.0, 99.0]) for v in (ref.x, ref.y))
            pad = 0.15 * max(x1 - x0, y1 - y0, 0.5)
            fig.update_xaxes(range=[x0 - pad, x1 + pad], row=1, col=2)
            fig.update_yaxes(range=[y0 - pad, y1 + pad], row=1, col=2)
    fig.layout.annotations[1].text = ("Drive and reference circle" if circle is not None
                                      else "Drive")
    fig.update_xaxes(title_text="x (m)")
    fig.update_yaxes(title_text="y (m)")
    fig.update_yaxes(scaleanchor="x", scaleratio=1, row=1, col=1)
    fig.update_yaxes(scaleanchor="x2", scaleratio=1, row=1, col=2)
    _layout(fig, title=title or f"{res.name}: positioning result", height=540)
    wide: dict[str, Any] = {"height": 540, "xaxis.domain": list(fig.layout.xaxis.domain),
                            "yaxis.domain": [0.0, 1.0],
                            "xaxis2.domain": list(fig.layout.xaxis2.domain),
                            "yaxis2.domain": [0.0, 1.0]}
    narrow: dict[str, Any] = {"height": 1040, "xaxis.domain": [0.0, 1.0],
                              "yaxis.domain": [0.58, 1.0], "xaxis2.domain": [0.0, 1.0],
                              "yaxis2.domain": [0.0, 0.42]}
    for i, (a, b) in enumerate(((fig.layout.annotations[0], 1.0),
                                (fig.layout.annotations[1], 0.42))):
        wide[f"annotations[{i}].x"] = a.x
        wide[f"annotations[{i}].y"] = a.y
        narrow[f"annotations[{i}].x"] = 0.5
        narrow[f"annotations[{i}].y"] = b
    _narrow(fig, narrow, wide)
    return fig


@dataclass(frozen=True)
class SteadyScale:
    """The y-range of an error figure set by its steady state, not by a start-up."""

    startup_end: float
    """End of the figure's start-up (the latest of its series'), in the series' time (s since
    the start of the drive)."""
    low: float
    high: float
    """The y-range over every sample after the start-up (figure units), padded."""
    off_scale: dict[str, float] = field(default_factory=dict)
    """Per estimator, its start-up's value farthest outside the range (figure units)."""
    ends: dict[str, float] = field(default_factory=dict)
    """Per estimator with a start-up of its own, where that start-up ends (s)."""


def steady_scale(series: Mapping[str, tuple[np.ndarray, np.ndarray]], *,
                 floor: float = 1.0) -> SteadyScale | None:
    """The steady-state scale of ``series`` (name -> times since the start in s, values), or
    None when no start-up stands out (the plot then scales itself).

    A series' steady band is the 1st to 99th percentile of its second half, widened by its own
    width (at least ``floor``) on each side. Its start-up ends after its last sample outside
    that band within the first :data:`STARTUP_SHARE` of the drive; the figure's start-up ends
    with the latest of them. The range covers every sample after the start-up: later spikes
    are steady-state behaviour and set the scale, the start-up only does not.
    """
    clean: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for n, (t, y) in series.items():
        t, y = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
        ok = np.isfinite(t) & np.isfinite(y)
        if ok.sum() >= 2:
            clean[n] = (t[ok], y[ok])
    if not clean:
        return None
    t_first = min(float(t[0]) for t, _ in clean.values())
    t_last = max(float(t[-1]) for t, _ in clean.values())
    early_end = t_first + STARTUP_SHARE * (t_last - t_first)
    ends: dict[str, float] = {}
    for n, (t, y) in clean.items():
        if len(t) < 20:
            continue
        late = y[t >= t[0] + 0.5 * (t[-1] - t[0])]
        lo, hi = np.percentile(late, [1.0, 99.0])
        width = max(float(hi - lo), floor)
        out = np.flatnonzero((t <= early_end) & ((y < lo - width) | (y > hi + width)))
        if out.size:
            ends[n] = float(t[min(int(out[-1]) + 1, len(t) - 1)])
    end = max(ends.values(), default=t_first)
    if end <= t_first:
        return None
    after = [a for a in (y[t >= end] for t, y in clean.values()) if a.size]
    if not after:
        return None
    low = min(0.0, min(float(a.min()) for a in after))
    high = max(0.0, max(float(a.max()) for a in after))
    pad = max(0.06 * (high - low), floor)
    low, high = low - (pad if low < 0 else pad / 3), high + pad
    off: dict[str, float] = {}
    for n, (t, y) in clean.items():
        y0 = y[t < end]
        beyond = y0[(y0 < low) | (y0 > high)]
        if beyond.size:
            off[n] = float(beyond[np.argmax(np.abs(beyond))])
    return SteadyScale(end, low, high, off, ends)


def _apply_steady(fig: go.Figure, scale: SteadyScale | None, unit: str) -> None:
    """Scale ``fig`` to the steady state: the start-up shaded, and a note at its end naming
    it and the values it leaves off the scale."""
    if scale is None:
        return
    fig.update_yaxes(range=[scale.low, scale.high])
    fig.add_shape(type="rect", xref="x", yref="y domain", x0=0.0, x1=scale.startup_end,
                  y0=0.0, y1=1.0, fillcolor="rgba(0,0,0,0.07)", line={"width": 0},
                  layer="below")
    text = f"◂ start-up, first {scale.startup_end:.1f} s (shaded)"
    if scale.off_scale:
        text += ": off scale " + ", ".join(f"{n} {v:.0f} {unit}"
                                           for n, v in scale.off_scale.items())
    fig.add_annotation(xref="x", yref="y domain", x=scale.startup_end, y=1.0, xanchor="left",
                       yanchor="top", showarrow=False, align="left", text=text,
                       font={"size": 11, "color": NOTE_COLOUR},
                       bgcolor="rgba(255,255,255,0.85)")


def _rotation_lines(fig: go.Figure, res: EvaluationResult) -> None:
    """Dotted full-height lines at the rotation boundaries, all set at once (linear time),
    with a legend entry and the rotations' numbers (Table 1's) above the plot; none past
    :data:`MAX_BOUNDARY_LINES` rotations, where they would only grey the plot."""
    bounds = list(res.laps.boundaries)
    if not bounds or len(bounds) > MAX_BOUNDARY_LINES + 1:
        return
    line = {"color": BOUNDARY_COLOUR, "dash": "dot", "width": 1}
    fig.update_layout(shapes=[{"type": "line", "xref": "x", "yref": "paper", "x0": b - res.t0,
                               "x1": b - res.t0, "y0": 0, "y1": 1, "line": line}
                              for b in bounds])
    rotations = len(bounds) - 1
    step = max(1, int(np.ceil(rotations / 12)))   # at most a dozen numbers: readable on a phone
    notes = [{"xref": "x", "yref": "paper", "x": 0.5 * (a + b) - res.t0, "y": 1.0,
              "yanchor": "bottom", "showarrow": False, "text": str(k + 1),
              "font": {"size": 11, "color": NOTE_COLOUR}}
             for k, (a, b) in enumerate(pairwise(bounds))
             if k % step == 0 or k == rotations - 1]
    notes.append({"xref": "paper", "yref": "paper", "x": 0.0, "y": 1.0, "xanchor": "right",
                  "yanchor": "bottom", "showarrow": False, "text": "rotation",
                  "font": {"size": 11, "color": NOTE_COLOUR}})
    fig.update_layout(annotations=[*fig.layout.annotations, *notes])
    fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines", line=line,
                             name="rotation boundary (numbered above, as in Table 1)",
                             hoverinfo="skip"))


def _time_slider(fig: go.Figure, span_s: float) -> None:
    """A range slider under the time axis of a long log (over ten minutes)."""
    if span_s > 600.0:
        fig.update_xaxes(rangeslider={"visible": True, "thickness": 0.07})


def _series(res: EvaluationResult, attr: str, column: str
            ) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per estimator (in report order), time since the start (s) and ``column`` in mm of its
    ``attr`` frame (radial or truth_error), decimated."""
    out: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for n in estimator_order(list(res.estimators)):
        df = getattr(res.estimators[n], attr)
        if df is None:
            continue
        s = _decimate(len(df))
        out[n] = (df["t"].to_numpy()[s] - res.t0, df[column].to_numpy()[s] * MM)
    return out


def radial_error_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Signed radial error (mm) against time since the start (s) for every estimator, scaled to
    the steady state; dotted lines mark the rotation boundaries, numbered above."""
    fig = go.Figure()
    col = colours(list(res.estimators))
    series = _series(res, "radial", "error")
    for n, (t, y) in series.items():
        fig.add_trace(go.Scatter(x=t, y=y, mode="lines", name=n,
                                 line={"color": col[n], "width": 1.2}))
    _rotation_lines(fig, res)
    _time_slider(fig, _span(res))
    fig.add_hline(y=0.0, line={"color": "#666666", "width": 1})
    fig.add_annotation(xref="x domain", yref="y", x=1.0, y=0.0, xanchor="right",
                       yanchor="bottom", showarrow=False, text="0: on the reference circle",
                       font={"size": 11, "color": NOTE_COLOUR},
                       bgcolor="rgba(255,255,255,0.85)")
    _apply_steady(fig, steady_scale(series), "mm")
    _layout(fig, title=title or f"{res.name}: radial error about the reference circle",
            height=440, xaxis_title="time since start (s)",
            yaxis_title="radial error (mm), + outside")
    _taller_when_narrow(fig)
    return fig


def _span(res: EvaluationResult) -> float:
    """Time covered by the estimates, s."""
    ends = [float(ev.trajectory.t[-1]) for ev in res.estimators.values()
            if len(ev.trajectory)]
    return max(ends, default=res.t0) - res.t0


def rotation_bars_figure(table: Table1, *, title: str = "RMSE per rotation") -> go.Figure:
    """RMSE (mm) of every rotation (Table 1 row) per estimator: grouped bars up to
    :data:`MAX_BAR_ROTATIONS` rotations; beyond, one line per estimator over the rotation
    number (range slider below) beside box plots of the per-rotation RMSE. Over several logs
    each rotation is named by its log and its number in that log."""
    col = colours(list(table.estimators))
    labels = [f"{r.log} #{r.rotation}" if table.multi_log else str(r.number) for r in table.rows]
    axis_title = "rotation, numbered in its log" if table.multi_log else "rotation"
    if len(table.rows) <= MAX_BAR_ROTATIONS:
        fig = go.Figure()
        # over several logs, two rows of labels: the rotation's number, under it its log
        x: list[Any] = ([[r.log for r in table.rows], [str(r.rotation) for r in table.rows]]
                        if table.multi_log else labels)
        for n in table.estimators:
            y = [r.stats[n].rmse * MM if n in r.stats else None for r in table.rows]
            fig.add_trace(go.Bar(x=x, y=y, name=n, marker_color=col[n]))
        _layout(fig, title=title, height=420, barmode="group", xaxis_title=axis_title,
                yaxis_title="RMSE (mm)")
        fig.update_xaxes(type="multicategory" if table.multi_log else "category")
        _taller_when_narrow(fig, 100)
        return fig
    fig = make_subplots(rows=1, cols=2, column_widths=[0.74, 0.26], shared_yaxes=True,
                        horizontal_spacing=0.02,
                        subplot_titles=(f"per rotation ({len(table.rows)} rotations)",
                                        "distribution over the rotations"))
    x = labels if table.multi_log else list(range(1, len(table.rows) + 1))
    for n in table.estimators:
        y = [r.stats[n].rmse * MM if n in r.stats else None for r in table.rows]
        fig.add_trace(go.Scatter(x=x, y=y, name=n, legendgroup=n, mode="lines+markers",
                                 line={"color": col[n], "width": 1}, marker={"size": 3},
                                 text=labels, hovertemplate="rotation %{text}: %{y:.2f} mm"),
                      row=1, col=1)
        fig.add_trace(go.Box(y=[v for v in y if v is not None], name=n, legendgroup=n,
                             showlegend=False, marker_color=col[n], boxpoints="outliers"),
                      row=1, col=2)
    fig.update_xaxes(title_text=axis_title, rangeslider={"visible": True, "thickness": 0.07},
                     row=1, col=1)
    if table.multi_log:
        fig.update_xaxes(type="category", row=1, col=1)
    fig.update_yaxes(title_text="RMSE (mm)", row=1, col=1)
    _layout(fig, title=title, height=480)
    _taller_when_narrow(fig, 100)
    return fig


def truth_error_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Position error against the ground truth (mm) over time (s) for every estimator, scaled
    to the steady state."""
    fig = go.Figure()
    col = colours(list(res.estimators))
    series = _series(res, "truth_error", "position_error")
    for n, (t, y) in series.items():
        fig.add_trace(go.Scatter(x=t, y=y, mode="lines", name=n,
                                 line={"color": col[n], "width": 1.2}))
    _rotation_lines(fig, res)
    _time_slider(fig, _span(res))
    _apply_steady(fig, steady_scale(series), "mm")
    _layout(fig, title=title or f"{res.name}: position error against ground truth",
            height=440, xaxis_title="time since start (s)", yaxis_title="position error (mm)")
    _taller_when_narrow(fig)
    return fig


def quality_timeline_figure(q: DataQuality, *, title: str) -> go.Figure:
    """The diagnostics (one row per source and kind, marker size by count) and the gaps of
    the main topics (bars of their length) against time since the start (s)."""
    fig = go.Figure()
    palette = qualitative.Dark24
    kinds = sorted({(e[1], e[2]) for e in q.events})
    by: dict[tuple[str, str], list[tuple[float, int]]] = {k: [] for k in kinds}
    for t, source, kind, _level, n in q.events:
        by[(source, kind)].append((t, n))
    for i, k in enumerate(kinds):
        ts = [p[0] for p in by[k]]
        counts = [p[1] for p in by[k]]
        fig.add_trace(go.Scattergl(
            x=ts, y=[f"{k[0]}: {k[1]}"] * len(ts), mode="markers", name=f"{k[0]}: {k[1]}",
            marker={"color": palette[i % len(palette)], "size": 7, "symbol": "line-ns-open",
                    "line": {"width": 2}},
            customdata=counts, hovertemplate="%{y} at %{x:.2f} s (x%{customdata})<extra></extra>"))
    gap_topics = sorted({g.topic for g in q.gaps})
    for topic in gap_topics:
        gs = [g for g in q.gaps if g.topic == topic]
        fig.add_trace(go.Bar(
            x=[g.length for g in gs], base=[g.start for g in gs],
            y=[f"gap: {topic}"] * len(gs), orientation="h", name=f"gaps on {topic}",
            marker={"color": "#555555"},
            hovertemplate="gap of %{x:.2f} s from %{base:.2f} s<extra></extra>"))
    rows = len(kinds) + len(gap_topics)
    _layout(fig, title=title, height=max(260, 120 + 26 * rows), showlegend=False,
            xaxis_title="time since start (s)", barmode="overlay")
    fig.update_layout(margin={"l": 8})              # the row names push it as far as they need
    fig.update_xaxes(range=[0.0, max(q.duration, 1e-3)])
    fig.update_yaxes(type="category", categoryorder="array", automargin=True,
                     categoryarray=[f"gap: {t}" for t in reversed(gap_topics)]
                     + [f"{k[0]}: {k[1]}" for k in reversed(kinds)])
    _time_slider(fig, q.duration)
    return fig


def log_figures(res: EvaluationResult, table: Table1) -> list[tuple[str, go.Figure]]:
    """The figures of one log as (slug, figure): trajectories, then whichever of radial error
    (a drive with a complete rotation), rotation bars and ground-truth error the log
    supports."""
    out: list[tuple[str, go.Figure]] = [("trajectories", trajectory_figure(res))]
    if res.laps.complete and any(ev.radial is not None for ev in res.estimators.values()):
        out.append(("radial-error", radial_error_figure(res)))
    if table.rows:
        out.append(("rotations", rotation_bars_figure(table, title=f"{res.name}: RMSE per "
                                                                  "rotation")))
    if any(ev.truth_error is not None for ev in res.estimators.values()):
        out.append(("truth-error", truth_error_figure(res)))
    return out


def require_kaleido() -> None:
    """Raise :class:`~lgvtool.errors.InputError` unless plotly's PNG engine (kaleido) is
    installed."""
    require("PNG export", "png", "kaleido")


def write_png(fig: go.Figure, path: str | Path, *, width: int = 1200) -> None:
    """Write ``fig`` as a PNG image ``width`` pixels wide (needs kaleido)."""
    require_kaleido()
    try:
        fig.write_image(str(path), format="png", width=width)
    except Exception as exc:  # kaleido's own failures (e.g. no browser engine): one line
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise InputError(f"PNG export of {Path(path).name} failed: {first}") from None
