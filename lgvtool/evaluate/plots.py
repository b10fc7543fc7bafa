"""Plotly figures of an evaluation (the paper's Fig. 6 and more). Pure: figures in, no files.

- :func:`trajectory_figure`: trajectories over the reference circle and the reflector map
  (Fig. 6a), as a hall overview beside a close-up of the drive;
- :func:`radial_error_figure`: signed radial error against time per estimator (Fig. 6b);
- :func:`rotation_bars_figure`: RMSE per rotation and estimator;
- :func:`truth_error_figure`: position error against the ground truth over time.

Axes are in m and s; errors are shown in mm.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import plotly.graph_objects as go
from plotly.colors import qualitative
from plotly.subplots import make_subplots

from lgvtool.errors import InputError
from lgvtool.evaluate.circle import Circle
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.table import MM, Table1, estimator_order

MAX_POINTS = 5000
"""Traces longer than this are decimated (every k-th sample) to keep the report small."""

TRUTH_COLOUR = "#222222"
CIRCLE_COLOUR = "#888888"


def colours(names: Sequence[str]) -> dict[str, str]:
    """A fixed colour per estimator name, in ``estimator_order``."""
    palette = qualitative.Plotly
    return {n: palette[i % len(palette)] for i, n in enumerate(estimator_order(names))}


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
        if res.truth is not None:
            s = _decimate(len(res.truth))
            fig.add_trace(go.Scatter(
                x=res.truth["x"].to_numpy()[s], y=res.truth["y"].to_numpy()[s], mode="lines",
                name="truth", legendgroup="truth", showlegend=show,
                line={"color": TRUTH_COLOUR, "width": 1}), row=1, col=c)
        for n in estimator_order(list(res.estimators)):
            df = res.estimators[n].trajectory
            s = _decimate(len(df))
            fig.add_trace(go.Scatter(
                x=df["x"].to_numpy()[s], y=df["y"].to_numpy()[s], mode="lines", name=n,
                legendgroup=n, showlegend=show, line={"color": col[n], "width": 1.5}),
                row=1, col=c)
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
    for b in res.laps.boundaries:
        fig.add_vline(x=b - res.t0, line={"color": "#bbbbbb", "dash": "dot", "width": 1})


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
    fig.add_hline(y=0.0, line={"color": "#666666", "width": 1})
    fig.update_layout(title=title or f"{res.name}: radial error about the reference circle",
                      xaxis_title="time since start (s)", yaxis_title="radial error (mm)",
                      height=420)
    return fig


def rotation_bars_figure(table: Table1, *, title: str = "RMSE per rotation") -> go.Figure:
    """Grouped bars: RMSE (mm) of every rotation (Table 1 row) per estimator."""
    fig = go.Figure()
    col = colours(list(table.estimators))
    labels = [f"{r.log} #{r.rotation}" if table.multi_log else str(r.number) for r in table.rows]
    for n in table.estimators:
        y = [r.stats[n].rmse * MM if n in r.stats else None for r in table.rows]
        fig.add_trace(go.Bar(x=labels, y=y, name=n, marker_color=col[n]))
    fig.update_layout(title=title, barmode="group", xaxis_title="rotation",
                      yaxis_title="RMSE (mm)", height=420)
    fig.update_xaxes(type="category")
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
    fig.update_layout(title=title or f"{res.name}: position error against ground truth",
                      xaxis_title="time since start (s)", yaxis_title="position error (mm)",
                      height=420)
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
    if importlib.util.find_spec("kaleido") is None:
        raise InputError("PNG export needs the optional package 'kaleido' "
                         "(install it with: pip install 'lgvtool[png]')")


def write_png(fig: go.Figure, path: str | Path, *, width: int = 1200) -> None:
    """Write ``fig`` as a PNG image ``width`` pixels wide (needs kaleido)."""
    require_kaleido()
    try:
        fig.write_image(str(path), format="png", width=width)
    except Exception as exc:  # kaleido's own failures (e.g. no browser engine): one line
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise InputError(f"PNG export of {Path(path).name} failed: {first}") from None
