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
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import plotly.graph_objects as go
from plotly.colors import qualitative
from plotly.subplots import make_subplots

from lgvtool.circle import Circle
from lgvtool.errors import InputError
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.quality import DataQuality
from lgvtool.evaluate.table import MM, Table1, estimator_order
from lgvtool.extras import require

MAX_POINTS = 5000
"""Traces longer than this are decimated (every k-th sample) to keep the report small."""

MAX_BAR_ROTATIONS = 30
"""Up to this many rotations the per-rotation figure shows grouped bars."""
MAX_BOUNDARY_LINES = 60
"""Rotation boundaries are drawn as lines up to this many rotations."""

TRUTH_COLOUR = "#000000"
CIRCLE_COLOUR = "#888888"

ESTIMATOR_COLOURS = {
    "laser": "#0072B2",          # blue
    "deadreckoning": "#E7298A",  # magenta
    "ekf": "#2CA02C",            # green
    "pf-paper": "#E69F00",       # orange
    "pf": "#D62728",             # red
}
"""The colours of the built-in estimators: apart in hue (laser and pf-paper, the pair compared
most, at opposite ends: blue and orange), none near the truth's black or the circle's
grey."""


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


def trajectory_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Trajectories of every estimator (and the truth) over the reference circle, with the
    reflector map: the whole hall on the left, the drive on the right."""
    fig = make_subplots(rows=1, cols=2, column_widths=[0.45, 0.55],
                        subplot_titles=("Hall and reflectors", "Drive and reference circle"))
    col = colours(list(res.estimators))
    circle = _reference_circle(res)
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
                line={"color": CIRCLE_COLOUR, "dash": "dash", "width": 2}), row=1, col=c)
        for n in estimator_order(list(res.estimators)):
            df = res.estimators[n].trajectory
            s = _decimate(len(df))
            fig.add_trace(go.Scatter(
                x=df["x"].to_numpy()[s], y=df["y"].to_numpy()[s], mode="lines", name=n,
                legendgroup=n, showlegend=show, line={"color": col[n], "width": 1.5}),
                row=1, col=c)
        if res.truth is not None:
            # drawn last, so on top of the estimates, dotted so they show through
            s = _decimate(len(res.truth))
            fig.add_trace(go.Scatter(
                x=res.truth["x"].to_numpy()[s], y=res.truth["y"].to_numpy()[s], mode="lines",
                name="truth", legendgroup="truth", showlegend=show,
                line={"color": TRUTH_COLOUR, "width": 1.5, "dash": "dot"}), row=1, col=c)
    if circle is not None:
        span = circle.r * 1.6
        fig.update_xaxes(range=[circle.cx - span, circle.cx + span], row=1, col=2)
        fig.update_yaxes(range=[circle.cy - span, circle.cy + span], row=1, col=2)
    fig.update_xaxes(title_text="x (m)")
    fig.update_yaxes(title_text="y (m)")
    fig.update_yaxes(scaleanchor="x", scaleratio=1, row=1, col=1)
    fig.update_yaxes(scaleanchor="x2", scaleratio=1, row=1, col=2)
    fig.update_layout(title=title or f"{res.name}: positioning result", height=520,
                      legend={"orientation": "h", "y": -0.15})
    return fig


def _rotation_lines(fig: go.Figure, res: EvaluationResult) -> None:
    """Dotted full-height lines at the rotation boundaries, all set at once (linear time);
    none past :data:`MAX_BOUNDARY_LINES` rotations, where they would only grey the plot."""
    bounds = list(res.laps.boundaries)
    if not bounds or len(bounds) > MAX_BOUNDARY_LINES + 1:
        return
    line = {"color": "#bbbbbb", "dash": "dot", "width": 1}
    fig.update_layout(shapes=[{"type": "line", "xref": "x", "yref": "paper", "x0": b - res.t0,
                               "x1": b - res.t0, "y0": 0, "y1": 1, "line": line}
                              for b in bounds])


def _time_slider(fig: go.Figure, span_s: float) -> None:
    """A range slider under the time axis of a long log (over ten minutes)."""
    if span_s > 600.0:
        fig.update_xaxes(rangeslider={"visible": True, "thickness": 0.07})


def radial_error_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Signed radial error (mm) against time since the start (s) for every estimator; dotted
    lines mark the rotation boundaries."""
    fig = go.Figure()
    col = colours(list(res.estimators))
    for n in estimator_order(list(res.estimators)):
        rad = res.estimators[n].radial
        if rad is None:
            continue
        s = _decimate(len(rad))
        fig.add_trace(go.Scatter(
            x=rad["t"].to_numpy()[s] - res.t0, y=rad["error"].to_numpy()[s] * MM, mode="lines",
            name=n, line={"color": col[n], "width": 1.2}))
    _rotation_lines(fig, res)
    _time_slider(fig, _span(res))
    fig.add_hline(y=0.0, line={"color": "#666666", "width": 1})
    fig.update_layout(title=title or f"{res.name}: radial error about the reference circle",
                      xaxis_title="time since start (s)", yaxis_title="radial error (mm)",
                      height=420)
    return fig


def _span(res: EvaluationResult) -> float:
    """Time covered by the estimates, s."""
    ends = [float(ev.trajectory["t"].iloc[-1]) for ev in res.estimators.values()
            if len(ev.trajectory)]
    return max(ends, default=res.t0) - res.t0


def rotation_bars_figure(table: Table1, *, title: str = "RMSE per rotation") -> go.Figure:
    """RMSE (mm) of every rotation (Table 1 row) per estimator: grouped bars up to
    :data:`MAX_BAR_ROTATIONS` rotations; beyond, one line per estimator over the rotation
    number (range slider below) beside box plots of the per-rotation RMSE."""
    col = colours(list(table.estimators))
    labels = [f"{r.log} #{r.rotation}" if table.multi_log else str(r.number) for r in table.rows]
    if len(table.rows) <= MAX_BAR_ROTATIONS:
        fig = go.Figure()
        for n in table.estimators:
            y = [r.stats[n].rmse * MM if n in r.stats else None for r in table.rows]
            fig.add_trace(go.Bar(x=labels, y=y, name=n, marker_color=col[n]))
        fig.update_layout(title=title, barmode="group", xaxis_title="rotation",
                          yaxis_title="RMSE (mm)", height=420)
        fig.update_xaxes(type="category")
        return fig
    fig = make_subplots(rows=1, cols=2, column_widths=[0.74, 0.26], shared_yaxes=True,
                        horizontal_spacing=0.02,
                        subplot_titles=(f"per rotation ({len(table.rows)} rotations)",
                                        "distribution over the rotations"))
    x = list(range(1, len(table.rows) + 1))
    for n in table.estimators:
        y = [r.stats[n].rmse * MM if n in r.stats else None for r in table.rows]
        fig.add_trace(go.Scatter(x=x, y=y, name=n, legendgroup=n, mode="lines+markers",
                                 line={"color": col[n], "width": 1}, marker={"size": 3},
                                 text=labels, hovertemplate="rotation %{text}: %{y:.2f} mm"),
                      row=1, col=1)
        fig.add_trace(go.Box(y=[v for v in y if v is not None], name=n, legendgroup=n,
                             showlegend=False, marker_color=col[n], boxpoints="outliers"),
                      row=1, col=2)
    fig.update_xaxes(title_text="rotation", rangeslider={"visible": True, "thickness": 0.07},
                     row=1, col=1)
    fig.update_yaxes(title_text="RMSE (mm)", row=1, col=1)
    fig.update_layout(title=title, height=480)
    return fig


def truth_error_figure(res: EvaluationResult, *, title: str | None = None) -> go.Figure:
    """Position error against the ground truth (mm) over time (s) for every estimator."""
    fig = go.Figure()
    col = colours(list(res.estimators))
    for n in estimator_order(list(res.estimators)):
        te = res.estimators[n].truth_error
        if te is None:
            continue
        s = _decimate(len(te))
        fig.add_trace(go.Scatter(
            x=te["t"].to_numpy()[s] - res.t0, y=te["position_error"].to_numpy()[s] * MM,
            mode="lines", name=n, line={"color": col[n], "width": 1.2}))
    _rotation_lines(fig, res)
    _time_slider(fig, _span(res))
    fig.update_layout(title=title or f"{res.name}: position error against ground truth",
                      xaxis_title="time since start (s)", yaxis_title="position error (mm)",
                      height=420)
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
    fig.update_layout(title=title, height=max(260, 120 + 26 * rows), showlegend=False,
                      xaxis_title="time since start (s)", barmode="overlay",
                      margin={"l": 260})
    fig.update_xaxes(range=[0.0, max(q.duration, 1e-3)])
    fig.update_yaxes(type="category", categoryorder="array",
                     categoryarray=[f"gap: {t}" for t in reversed(gap_topics)]
                     + [f"{k[0]}: {k[1]}" for k in reversed(kinds)])
    _time_slider(fig, q.duration)
    return fig


def log_figures(res: EvaluationResult, table: Table1) -> list[tuple[str, go.Figure]]:
    """The figures of one log as (slug, figure): trajectories, then whichever of radial error,
    rotation bars and ground-truth error the log supports."""
    out: list[tuple[str, go.Figure]] = [("trajectories", trajectory_figure(res))]
    if any(ev.radial is not None for ev in res.estimators.values()):
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
