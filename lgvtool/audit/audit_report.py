"""The audit's HTML report: one self-contained page (plotly.js embedded once) in the style of the
evaluation report, built from ``audit.json`` itself, the layout and the drives.

The page: a summary (reflectors by status, unmapped objects, coverage) beside the map (the layout
reflectors coloured by status, arrows for the shifts of moved reflectors, scaled and said so,
unmapped objects with their 1-sigma circles, the drive), then the reflector table, the unmapped
objects, and the coverage: heat maps of the worst GDOP and the fewest visible reflectors per
cell, and the table of the worst segments; then the navigation health: a timeline per log of
the dropouts (by cause), pose jumps and device clock jumps, and the table of the dropouts;
then the error by segment: the RMS along-track and cross-track error by speed (a figure) and
the table of every bin, each headed by its reference (the truth, or an estimator); then the
stations: each source's visits about each station's pose (a figure) and the table of sigma,
95 % radius, worst visit and pass/fail per station and source.
Every table carries ``data-table``, every figure ``data-figure``, every section
``data-section`` (as the evaluation report's), so tools and tests find them. Units: m on
the map, mm in the tables' shifts.

:func:`render_audit_report` is pure (a string); :func:`write_audit_report` writes it.
"""

from __future__ import annotations

import html
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import plotly.graph_objects as go

from lgvtool import __version__
from lgvtool.audit.coverage import HeadTrack
from lgvtool.config import Reflector
from lgvtool.evaluate.html_report import _SCRIPT, _STYLE, _Figures, _table_html
from lgvtool.evaluate.plots import LEGEND_BELOW, MARGIN, MAX_POINTS
from lgvtool.json_types import JSON, JSONObject

STATUS_COLOURS = {
    "ok": "#2ca02c",
    "missing": "#d62728",
    "moved": "#ff7f0e",
    "weak": "#b8860b",
    "ambiguous": "#9467bd",
    "not audited": "#7f7f7f",
}
"""One colour per reflector status (and grey for a layout reflector the audit did not judge:
a NAV200 log, which has no landmarks)."""
UNMAPPED_COLOUR = "#111111"
DRIVE_COLOUR = "#6baed6"
SEGMENT_COLOUR = "#d62728"

CAPTIONS = {
    "audit-map": "The layout as surveyed, each reflector coloured by its status; an arrow from "
                 "a moved reflector's surveyed position along its estimated shift (drawn "
                 "enlarged, by the factor in the legend); unmapped objects (x) with their "
                 "1-sigma circle; the drive of the NAV head.",
    "coverage-gdop": "Worst GDOP of the poses in each cell (blank: never driven; capped at the "
                     "top of the scale); the layout reflectors and the worst segments' "
                     "centres on top.",
    "navigation-timeline": "Per log, along its time: each interval without a valid NAV pose "
                           "(a bar, coloured by cause), each pose jump (a NAV step the "
                           "odometry does not explain) and each jump of the device clock.",
    "segments-speed": "RMS along-track (solid) and cross-track (hatched) error of each pose "
                      "source by the reference's speed; empty bins are left out.",
    "stations": "Each visit's pose of O per source, as its offset (mm, map axes) from the "
                "station's pose (a named station's, else the mean of the audit's estimator); "
                "the circle: the station's position tolerance.",
    "coverage-visible": "Fewest layout reflectors visible (in range, not hidden) from any pose "
                        "in each cell; below the device's minimum no position is possible.",
}

DROPOUT_COLOURS = {
    "no_position": "#d62728",
    "few_reflectors": "#ff7f0e",
    "error": "#9467bd",
    "no_reply": "#7f7f7f",
}
"""One colour per dropout cause (:class:`lgvtool.audit.navigation_health.Dropout`)."""

STATUS_ORDER = ("missing", "moved", "weak", "ambiguous", "ok", "not audited")

_MORE_STYLE = """
ul.counts { list-style: none; padding: 0; margin: 0.3em 0; }
ul.counts li { padding: 0.2em 0; border-top: 1px solid #e3e8ef; }
ul.counts b { font-variant-numeric: tabular-nums; }
"""


def _f(v: JSON) -> float | None:
    """A JSON number as a float (None for anything else)."""
    return float(v) if isinstance(v, int | float) and not isinstance(v, bool) else None


def _obj(v: JSON) -> JSONObject:
    return v if isinstance(v, dict) else {}


def _list(v: JSON) -> list[JSON]:
    return v if isinstance(v, list) else []


def _pair(v: JSON) -> tuple[float, float] | None:
    """``[a, b]`` as two floats, or None."""
    items = _list(v)
    if len(items) != 2:
        return None
    a, b = _f(items[0]), _f(items[1])
    return None if a is None or b is None else (a, b)


def _mm(v: float | None, digits: int = 1) -> str:
    return "" if v is None or not math.isfinite(v) else f"{v * 1000:.{digits}f}"


def _num(v: float | None, digits: int = 2) -> str:
    return "" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _nice(x: float) -> float:
    """The largest of 1, 2, 5 x 10^k not above ``x`` (> 0)."""
    k = 10.0 ** math.floor(math.log10(x))
    return next(m * k for m in (5.0, 2.0, 1.0) if m * k <= x)


def _statuses(doc: JSONObject, layout: Sequence[Reflector]) -> dict[int, JSONObject]:
    """The audit's entry of each layout reflector id (``reflectors`` of ``audit.json``)."""
    out: dict[int, JSONObject] = {}
    for item in _list(doc.get("reflectors")):
        entry = _obj(item)
        rid = entry.get("id")
        if isinstance(rid, int):
            out[rid] = entry
    return out


def _status(entry: JSONObject | None) -> str:
    s = entry.get("status") if entry else None
    return s if isinstance(s, str) and s in STATUS_COLOURS else "not audited"


def _decimated(track: HeadTrack, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Every k-th pose of ``track`` (m), at most about ``points`` of them."""
    step = max(1, math.ceil(len(track) / max(1, points)))
    return track.x[::step], track.y[::step]


def map_figure(doc: JSONObject, layout: Sequence[Reflector], tracks: Sequence[HeadTrack]
               ) -> go.Figure:
    """The site: the drive, the layout reflectors by status (arrows for shifts), the unmapped
    objects (m)."""
    fig = go.Figure()
    # the drives share the evaluation's point budget (a fleet's week stays a small page)
    points = max(200, MAX_POINTS // max(1, len(tracks)))
    for k, tr in enumerate(tracks):
        x, y = _decimated(tr, points)
        fig.add_trace(go.Scatter(  # SVG, as the evaluation's trajectories: no WebGL needed
            x=x, y=y, mode="lines", line={"color": DRIVE_COLOUR, "width": 1.5},
            name="drive (NAV head)", legendgroup="drive", showlegend=k == 0,
            hoverinfo="skip"))
    entries = _statuses(doc, layout)
    by_status: dict[str, list[Reflector]] = {}
    for r in layout:
        by_status.setdefault(_status(entries.get(r.id)), []).append(r)
    for status in STATUS_ORDER:
        refl = by_status.get(status, [])
        if not refl:
            continue
        text = []
        for r in refl:
            e = entries.get(r.id, {})
            seen, chances = e.get("sightings"), e.get("expected_sightings")
            shift = _pair(e.get("shift_m", None))
            text.append(f"reflector {r.id}: {status}<br>sightings {seen if seen is not None else '-'}"
                        f" of {chances if chances is not None else '-'} expected"
                        + (f"<br>shift {shift[0] * 1000:.0f}, {shift[1] * 1000:.0f} mm"
                           if shift else ""))
        fig.add_trace(go.Scatter(
            x=[r.x for r in refl], y=[r.y for r in refl], mode="markers",
            marker={"color": STATUS_COLOURS[status], "size": 11,
                    "line": {"color": "#333", "width": 1},
                    "symbol": "circle" if status != "missing" else "circle-open-dot"},
            name=f"{status} ({len(refl)})", text=text, hoverinfo="text"))
    _shift_arrows(fig, layout, entries)
    unmapped = [_obj(u) for u in _list(doc.get("unmapped"))]
    ux = [_f(u.get("x")) for u in unmapped]
    uy = [_f(u.get("y")) for u in unmapped]
    keep = [i for i in range(len(unmapped)) if ux[i] is not None and uy[i] is not None]
    if keep:
        fig.add_trace(go.Scatter(
            x=[ux[i] for i in keep], y=[uy[i] for i in keep], mode="markers",
            marker={"color": UNMAPPED_COLOUR, "size": 11, "symbol": "x"},
            name=f"unmapped ({len(keep)})",
            text=[f"unmapped object: {unmapped[i].get('sightings')} sightings, sigma "
                  f"{_mm(_f(unmapped[i].get('sigma_m')))} mm" for i in keep],
            hoverinfo="text"))
        shapes = []
        for i in keep:
            s = _f(unmapped[i].get("sigma_m")) or 0.0
            cx, cy = ux[i], uy[i]
            assert cx is not None and cy is not None
            if s > 0:
                shapes.append({"type": "circle", "xref": "x", "yref": "y", "x0": cx - s,
                               "x1": cx + s, "y0": cy - s, "y1": cy + s,
                               "line": {"color": UNMAPPED_COLOUR, "width": 1, "dash": "dot"}})
        fig.update_layout(shapes=shapes)
    fig.update_layout(title={"text": "The site: reflectors by status, the drive", "x": 0.0,
                             "xanchor": "left"},
                      height=560, legend=LEGEND_BELOW, margin=MARGIN,
                      xaxis={"title": "x (m)", "constrain": "domain"},
                      yaxis={"title": "y (m)", "scaleanchor": "x", "scaleratio": 1},
                      hovermode="closest")
    return fig


def _shift_arrows(fig: go.Figure, layout: Sequence[Reflector],
                  entries: dict[int, JSONObject]) -> None:
    """Arrows from each moved reflector along its estimated shift, enlarged by a round factor
    so that the longest is 4-10 % of the site's extent (the factor named in the legend)."""
    shifts = [(r, s) for r in layout
              if _status(entries.get(r.id)) == "moved"
              and (s := _pair(entries[r.id].get("shift_m"))) is not None]
    longest = max((math.hypot(*s) for _, s in shifts), default=0.0)
    if longest <= 0.0 or not layout:
        return
    xs, ys = [r.x for r in layout], [r.y for r in layout]
    extent = max(max(xs) - min(xs), max(ys) - min(ys), 1.0)
    k = _nice(0.1 * extent / longest) if 0.1 * extent / longest >= 1 else 1.0
    for r, (dx, dy) in shifts:
        fig.add_annotation(x=r.x + k * dx, y=r.y + k * dy, ax=r.x, ay=r.y, xref="x", yref="y",
                           axref="x", ayref="y", showarrow=True, arrowhead=2, arrowsize=1.2,
                           arrowwidth=2, arrowcolor=STATUS_COLOURS["moved"], text="")
    # a legend entry that names the factor
    fig.add_trace(go.Scatter(x=[None], y=[None], mode="lines",
                             line={"color": STATUS_COLOURS["moved"], "width": 2},
                             name=f"shift, drawn x{k:g}"))


def _cell_axes(grid: JSONObject) -> tuple[list[float], list[float]] | None:
    cell, x0, y0 = _f(grid.get("cell_m")), _f(grid.get("x0_m")), _f(grid.get("y0_m"))
    nx, ny = grid.get("nx"), grid.get("ny")
    if cell is None or x0 is None or y0 is None or not isinstance(nx, int) or not isinstance(
            ny, int) or nx <= 0 or ny <= 0:
        return None
    return ([x0 + (i + 0.5) * cell for i in range(nx)],
            [y0 + (j + 0.5) * cell for j in range(ny)])


def _matrix(v: JSON) -> list[list[float | None]]:
    return [[_f(c) for c in _list(row)] for row in _list(v)]


def heatmap_figure(coverage: JSONObject, layout: Sequence[Reflector], what: str
                   ) -> go.Figure | None:
    """The heat map of ``coverage``'s grid: ``what`` is ``"gdop"`` (worst GDOP per cell) or
    ``"visible"`` (fewest reflectors visible per cell); None without a grid."""
    grid = _obj(coverage.get("grid"))
    axes = _cell_axes(grid)
    if axes is None:
        return None
    view, settings = _obj(coverage.get("view")), _obj(coverage.get("settings"))
    if what == "gdop":
        z = _matrix(grid.get("gdop_max"))
        top = 2.0 * (_f(settings.get("gdop_max")) or 2.0)
        trace = go.Heatmap(x=axes[0], y=axes[1], z=z, zmin=0.0, zmax=top,
                           colorscale="YlOrRd", colorbar={"title": {"text": "GDOP"}},
                           hovertemplate="x %{x:.1f} m, y %{y:.1f} m<br>worst GDOP %{z:.2f}"
                                         "<extra></extra>",
                           name="worst GDOP")
        title = "Coverage: worst GDOP per cell"
    else:
        z = _matrix(grid.get("visible_min"))
        need = _f(view.get("min_reflectors")) or 3.0
        high = max([need + 3.0] + [c for row in z for c in row if c is not None])
        trace = go.Heatmap(x=axes[0], y=axes[1], z=z, zmin=0.0, zmax=high,
                           colorscale=[[0.0, "#d62728"], [max(0.0, (need - 0.5) / high),
                                                           "#fdae61"],
                                       [min(1.0, (need + 0.5) / high), "#a6d96a"],
                                       [1.0, "#1a9641"]],
                           colorbar={"title": {"text": "visible"}},
                           hovertemplate="x %{x:.1f} m, y %{y:.1f} m<br>fewest visible %{z}"
                                         "<extra></extra>",
                           name="fewest visible")
        title = "Coverage: fewest reflectors visible per cell"
    fig = go.Figure(trace)
    fig.add_trace(go.Scatter(x=[r.x for r in layout], y=[r.y for r in layout], mode="markers",
                             marker={"color": "#222", "size": 6, "symbol": "diamond"},
                             name="layout reflector",
                             text=[f"reflector {r.id}" for r in layout], hoverinfo="text"))
    segs = [_obj(s) for s in _list(coverage.get("segments"))]
    centres = [(c, s) for s in segs if (c := _pair(s.get("centre_xy_m"))) is not None]
    if centres:
        fig.add_trace(go.Scatter(
            x=[c[0] for c, _ in centres], y=[c[1] for c, _ in centres], mode="markers",
            marker={"color": "rgba(0,0,0,0)", "size": 12,
                    "line": {"color": SEGMENT_COLOUR, "width": 2}},
            name="worst segment",
            text=[f"{_num(_f(s.get('start_s')), 1)}-{_num(_f(s.get('end_s')), 1)} s: "
                  + "; ".join(str(r) for r in _list(s.get("reasons"))) for _, s in centres],
            hoverinfo="text"))
    fig.update_layout(title={"text": title, "x": 0.0, "xanchor": "left"}, height=520,
                      legend=LEGEND_BELOW, margin=MARGIN,
                      xaxis={"title": "x (m)", "constrain": "domain"},
                      yaxis={"title": "y (m)", "scaleanchor": "x", "scaleratio": 1})
    return fig


def navigation_figure(nav: JSONObject) -> go.Figure | None:
    """The navigation timeline of ``audit.json``'s ``navigation`` (one row per log, time s):
    dropouts as bars by cause, pose jumps and clock jumps as markers; None without logs."""
    logs = [_obj(g) for g in _list(nav.get("logs"))]
    if not logs:
        return None
    fig = go.Figure()
    names = [Path(str(g.get("path", ""))).name or str(i) for i, g in enumerate(logs)]
    for cause, colour in DROPOUT_COLOURS.items():
        rows = [(n, _obj(d)) for n, g in zip(names, logs, strict=True)
                for d in _list(g.get("dropouts")) if _obj(d).get("cause") == cause]
        if rows:
            fig.add_trace(go.Bar(
                base=[_f(d.get("start_s")) for _, d in rows],
                x=[_f(d.get("duration_s")) for _, d in rows], y=[n for n, _ in rows],
                orientation="h", marker={"color": colour}, name=cause.replace("_", " "),
                hovertemplate="%{base:.2f} s, %{x:.2f} s long<extra>" + cause + "</extra>"))
    for key, label, symbol, colour in (("pose_jumps", "pose jump", "x", "#111111"),
                                       ("clock_jumps", "clock jump", "diamond", "#1f77b4")):
        pts = [(n, _obj(j)) for n, g in zip(names, logs, strict=True)
               for j in _list(g.get(key))]
        if pts:
            fig.add_trace(go.Scatter(
                x=[_f(j.get("t_s")) for _, j in pts], y=[n for n, _ in pts], mode="markers",
                marker={"symbol": symbol, "size": 9, "color": colour}, name=label,
                text=[(f"{_mm(_f(j.get('jump_m')))} mm, {_num(_f(j.get('jump_rad')), 4)} rad"
                       if key == "pose_jumps" else f"{_num(_f(j.get('step_s')), 3)} s")
                      for _, j in pts], hoverinfo="x+text"))
    fig.update_layout(title={"text": "Navigation timeline", "x": 0.0, "xanchor": "left"},
                      height=200 + 40 * len(logs), barmode="overlay", legend=LEGEND_BELOW,
                      margin=MARGIN, xaxis={"title": "time (s)"},
                      yaxis={"type": "category", "categoryorder": "array",
                             "categoryarray": names})
    return fig


def _navigation_rows(nav: JSONObject) -> list[list[str]]:
    rows = []
    for g in (_obj(v) for v in _list(nav.get("logs"))):
        name = Path(str(g.get("path", ""))).name
        for d in (_obj(v) for v in _list(g.get("dropouts"))):
            used = d.get("reflectors_used_min")
            rows.append([name, _num(_f(d.get("start_s")), 2), _num(_f(d.get("duration_s")), 2),
                         f"{_num(_f(d.get('x')), 2)}, {_num(_f(d.get('y')), 2)}",
                         str(d.get("cause", "")).replace("_", " "), str(d.get("replies", "")),
                         "" if not isinstance(used, int) or used < 0 else str(used)])
    return rows


def _navigation_html(nav: JSONObject, fig_html: Callable[[str, go.Figure], str]) -> str:
    """The navigation section: the figures in a few lines, the timeline and the dropouts."""
    e = html.escape
    share = _f(nav.get("share_in_navigation"))
    out = ['<section data-section="navigation" id="navigation"><h2>Navigation health</h2>',
           f'<p class="note">From the device\'s own status of every pose: '
           f"{_num(None if share is None else 100 * share, 1)} % of the time in navigation, "
           f"{e(str(nav.get('dropouts')))} dropouts ({_num(_f(nav.get('dropout_time_s')), 1)}"
           f" s), {e(str(nav.get('pose_jumps')))} pose jumps, "
           f"{e(str(nav.get('clock_jumps')))} clock jumps.</p>"]
    fig = navigation_figure(nav)
    if fig is not None:
        out.append(fig_html("navigation-timeline", fig))
    rows = _navigation_rows(nav)
    if rows:
        out.append(_table_html(
            "dropouts", ["log", "start (s)", "duration (s)", "x, y (m)", "cause", "replies",
                         "fewest used"], rows,
            "every interval of at least one NAV period without a valid pose; where: the "
            "replayed head pose at its start", title="Dropouts"))
    out.append("</section>")
    return "".join(out)


def _against(seg: JSONObject) -> str:
    """How a segments heading names its reference: "the truth" or "<estimator>"."""
    ref = str(seg.get("reference") or "")
    return "the truth" if ref == "truth" else ref


def segments_figure(seg: JSONObject) -> go.Figure | None:
    """RMS along- and cross-track error (mm) per speed bin of each source of ``audit.json``'s
    ``segments``; None without a compared pose."""
    from lgvtool.colours import source_colour

    fig = go.Figure()
    for src in (_obj(v) for v in _list(seg.get("sources"))):
        bins = [_obj(b) for b in _list(src.get("speed")) if _obj(b).get("count")]
        if not bins:
            continue
        name = str(src.get("source", ""))
        for comp, pattern in (("along", ""), ("cross", "/")):
            rms = [_f(_obj(b.get(comp)).get("rms")) for b in bins]
            fig.add_trace(go.Bar(
                x=[str(b.get("bin")) for b in bins],
                y=[None if v is None else v * 1000 for v in rms],
                name=f"{name} {comp}", marker={"color": source_colour(name),
                                               "pattern": {"shape": pattern}},
                text=[f"{b.get('count')} poses" for b in bins],
                hovertemplate="%{x} m/s: %{y:.1f} mm, %{text}<extra>" + name + " " + comp
                              + "</extra>"))
    if not fig.data:
        return None
    fig.update_layout(title={"text": f"Error by speed (against {_against(seg)})", "x": 0.0,
                             "xanchor": "left"},
                      height=380, barmode="group", legend=LEGEND_BELOW, margin=MARGIN,
                      xaxis={"title": "speed (m/s)", "type": "category"},
                      yaxis={"title": "RMS error (mm)"})
    return fig


_SEGMENT_DIMENSIONS = (("speed", "speed (m/s)"), ("curvature", "curvature (1/m)"),
                       ("direction", "direction"), ("shape", "straight/turn"))


def _segment_error_rows(seg: JSONObject) -> list[list[str]]:
    rows = []
    for src in (_obj(v) for v in _list(seg.get("sources"))):
        for dim, label in _SEGMENT_DIMENSIONS:
            for b in (_obj(v) for v in _list(src.get(dim))):
                if not b.get("count"):
                    continue
                cells = [str(src.get("source", "")), str(src.get("reference", "")), label,
                         str(b.get("bin", "")), str(b.get("count"))]
                for comp in ("along", "cross"):
                    c = _obj(b.get(comp))
                    cells += [_mm(_f(c.get("rms"))), _mm(_f(c.get("mean")))]
                h = _obj(b.get("heading"))
                for k in ("rms", "mean"):
                    rad = _f(h.get(k))
                    cells.append(_num(None if rad is None else math.degrees(rad), 3))
                rows.append(cells)
    return rows


def _segments_html(seg: JSONObject, fig_html: Callable[[str, go.Figure], str]) -> str:
    """The error-by-segment section: what is compared with what, the figure, the table."""
    e = html.escape
    against = _against(seg)
    out = [f'<section data-section="segments" id="segments"><h2>Error by segment (against '
           f"{e(against)})</h2>",
           f'<p class="note">Each pose source against {e(against)}: {e(str(seg.get("frame")))}'
           ".</p>"]
    fig = segments_figure(seg)
    if fig is not None:
        out.append(fig_html("segments-speed", fig))
    out.append(_table_html(
        "segment-errors", ["source", "reference", "by", "bin", "poses", "along rms (mm)",
                           "along mean (mm)", "cross rms (mm)", "cross mean (mm)",
                           "heading rms (deg)", "heading mean (deg)"],
        _segment_error_rows(seg),
        "every non-empty bin; each pose is in one bin of each grouping",
        title=f"Error by segment against {against}"))
    out.append("</section>")
    return "".join(out)


STATION_PLOTS = 12
"""Most stations drawn in the stations figure (the table lists them all)."""


def _role_colour(role: str, name: str) -> str:
    from lgvtool.colours import TRUTH_ON_LIGHT, source_colour

    return TRUTH_ON_LIGHT if role == "truth" else source_colour(name)


def stations_figure(st: JSONObject) -> go.Figure | None:
    """The visits of each station of ``audit.json``'s ``stations`` (one panel per station, at
    most :data:`STATION_PLOTS`): each source's visit positions as offsets (mm) from the
    station's pose, and a named station's tolerance circle; None without a visit."""
    from plotly.subplots import make_subplots

    stations = [_obj(v) for v in _list(st.get("per_station"))][:STATION_PLOTS]
    stations = [s for s in stations if _list(s.get("visit_list"))]
    if not stations:
        return None
    names = _obj(st.get("sources"))
    cols = min(3, len(stations))
    rows = (len(stations) + cols - 1) // cols
    fig = make_subplots(rows=rows, cols=cols, subplot_titles=[
        f"{s.get('name')} ({s.get('visits')} visits)" for s in stations],
        horizontal_spacing=0.08, vertical_spacing=0.12)
    shown: set[str] = set()
    for i, s in enumerate(stations):
        r, c = i // cols + 1, i % cols + 1
        cx, cy = _f(s.get("x")) or 0.0, _f(s.get("y")) or 0.0
        for role in ("truth", "laser", "estimator"):
            pts = [(_list(_obj(_obj(v).get("poses")).get(role)), _obj(v))
                   for v in _list(s.get("visit_list"))]
            pts = [(p, v) for p, v in pts if len(p) == 3 and _f(p[0]) is not None]
            if not pts:
                continue
            name = str(names.get(role, role))
            fig.add_trace(go.Scatter(
                x=[((_f(p[0]) or 0.0) - cx) * 1000 for p, _ in pts],
                y=[((_f(p[1]) or 0.0) - cy) * 1000 for p, _ in pts], mode="markers",
                marker={"size": 6, "color": _role_colour(role, name),
                        "symbol": "x" if role == "truth" else "circle"},
                name=name, legendgroup=name, showlegend=name not in shown,
                text=[f"{Path(str(v.get('log', ''))).name} at {_num(_f(v.get('t_s')), 1)} s"
                      for _, v in pts],
                hovertemplate="%{x:.1f}, %{y:.1f} mm; %{text}<extra>" + name + "</extra>"),
                row=r, col=c)
            shown.add(name)
        tol = _f(s.get("tolerance_xy_m"))
        if tol is not None:
            a = np.linspace(0.0, 2 * math.pi, 73)
            fig.add_trace(go.Scatter(
                x=tol * 1000 * np.cos(a), y=tol * 1000 * np.sin(a), mode="lines",
                line={"color": "#d62728", "dash": "dot", "width": 1}, name="tolerance",
                legendgroup="tolerance", showlegend="tolerance" not in shown,
                hoverinfo="skip"), row=r, col=c)
            shown.add("tolerance")
        axis = "" if i == 0 else str(i + 1)
        fig.update_xaxes(title_text="dx (mm)", row=r, col=c)
        fig.update_yaxes(title_text="dy (mm)", scaleanchor=f"x{axis}", scaleratio=1,
                         row=r, col=c)
    fig.update_layout(title={"text": "Visits per station", "x": 0.0, "xanchor": "left"},
                      height=120 + 300 * rows, legend=LEGEND_BELOW, margin=MARGIN)
    return fig


def _station_rows(st: JSONObject) -> list[list[str]]:
    rows = []
    for s in (_obj(v) for v in _list(st.get("per_station"))):
        tol, tol_deg = _f(s.get("tolerance_xy_m")), _f(s.get("tolerance_deg"))
        tol_text = (f"{_mm(tol)} mm, {_num(tol_deg, 2)} deg" if tol is not None
                    and tol_deg is not None else "no tolerance")
        for src in (_obj(v) for v in _list(s.get("sources"))):
            mean, worst = _obj(src.get("mean")), _obj(src.get("worst"))
            alone = _obj(src.get("stops_alone"))
            ok = src.get("pass")
            err = _obj(src.get("error_vs_truth"))
            rows.append([
                str(s.get("name", "")), str(src.get("source", "")), str(src.get("visits", "")),
                f"{_num(_f(mean.get('x')), 3)}, {_num(_f(mean.get('y')), 3)}",
                _num(_f(mean.get("heading_deg")), 2), _mm(_f(src.get("sigma_x_m"))),
                _mm(_f(src.get("sigma_y_m"))), _num(_f(src.get("sigma_heading_deg")), 3),
                f"{_mm(_f(alone.get('sigma_x_m')))}, {_mm(_f(alone.get('sigma_y_m')))}; "
                f"noise {_mm(_f(alone.get('noise_x_m')))}, {_mm(_f(alone.get('noise_y_m')))}",
                _mm(_f(src.get("radius95_m"))),
                f"{Path(str(worst.get('log', ''))).name} at {_num(_f(worst.get('t_s')), 1)} s: "
                f"{_mm(_f(worst.get('distance_m')))} mm, "
                f"{_num(_f(worst.get('heading_deg')), 2)} deg",
                _mm(_f(err.get("rms_m"))) if err else "",
                tol_text, "" if ok is None else ("pass" if ok else
                                                 f"FAIL ({src.get('within_tolerance')} of "
                                                 f"{src.get('visits')} within)")])
    return rows


def _stations_html(st: JSONObject, fig_html: Callable[[str, go.Figure], str]) -> str:
    """The stations section: how they were found, the visits per station, the table."""
    e = html.escape
    per = _list(st.get("per_station"))
    how = (f"the named stations of {st.get('file')}" if st.get("mode") == "named"
           else "found automatically (standstills grouped by position and heading)")
    out = ['<section data-section="stations" id="stations"><h2>Stations</h2>',
           f'<p class="note">{len(per)} station{"s" if len(per) != 1 else ""}, {e(how)}; '
           f"{e(str(st.get('visits')))} standstills, {len(_list(st.get('unmatched')))} at no "
           "station. Each visit's pose per source is the mean pose of O over the standstill "
           "after its settling time.</p>"]
    fig = stations_figure(st)
    if fig is not None:
        out.append(fig_html("stations", fig))
    rows = _station_rows(st)
    if rows:
        out.append(_table_html(
            "stations", ["station", "source", "visits", "mean x, y (m)", "heading (deg)",
                         "sigma x (mm)", "sigma y (mm)", "sigma heading (deg)",
                         "stops alone sigma x, y (mm)", "95 % radius (mm)", "worst visit",
                         "error vs truth rms (mm)", "tolerance", "result"], rows,
            "sigma: standard deviation of the visits about their mean; stops alone: the same "
            "with the source's own noise over each stop taken off (noise: the RMS standard "
            "error of a visit's mean pose), the vehicle's own repeatability as this source "
            "sees it; 95 % radius: the 95th percentile of the visits' distances from their "
            "mean; worst: the visit farthest from the station's pose",
            title="Repeatability per station"))
    out.append("</section>")
    return "".join(out)


def _summary_html(doc: JSONObject, layout: Sequence[Reflector]) -> str:
    """The lead box: reflectors by status, unmapped objects, coverage in a few lines."""
    e = html.escape
    entries = _statuses(doc, layout)
    counts: dict[str, int] = {}
    for r in layout:
        s = _status(entries.get(r.id))
        counts[s] = counts.get(s, 0) + 1
    items = [f'<li><span class="swatch" style="background:{STATUS_COLOURS[s]}"></span>'
             f"<b>{counts[s]}</b> {e(s)}</li>" for s in STATUS_ORDER if counts.get(s)]
    unmapped = len(_list(doc.get("unmapped")))
    items.append(f"<li><b>{unmapped}</b> unmapped object{'s' if unmapped != 1 else ''}</li>")
    notes = [str(n) for n in _list(doc.get("notes"))]
    cov = _obj(doc.get("coverage"))
    lines = []
    if cov:
        vis, g = _obj(cov.get("visible")), _obj(cov.get("gdop"))
        below = _f(cov.get("below_min_fraction"))
        lines.append(f"{cov.get('poses', 0)} poses over {_num(_f(cov.get('distance_m')), 0)} m "
                     f"({_num(_f(cov.get('duration_s')), 0)} s); reflectors visible: median "
                     f"{_num(_f(vis.get('median')), 0)}, least {_num(_f(vis.get('min')), 0)}; "
                     f"GDOP median {_num(_f(g.get('median')))}, "
                     f"95th percentile {_num(_f(g.get('p95')))}.")
        lines.append(f"{cov.get('segments_total', 0)} poor segments "
                     f"({_num(_f(cov.get('poor_time_s')), 1)} s); "
                     + (f"{100 * below:.1f} % of poses see fewer than "
                        f"{_obj(cov.get('view')).get('min_reflectors', 3)}."
                        if below is not None else ""))
    return ('<div class="verdict" data-part="summary"><h2>Audit summary</h2>'
            f'<ul class="counts">{"".join(items)}</ul>'
            + "".join(f'<p class="ref">{e(n)}</p>' for n in notes)
            + "".join(f'<p class="ref">{e(t)}</p>' for t in lines) + "</div>")


def _reflector_rows(doc: JSONObject, layout: Sequence[Reflector]) -> list[list[str]]:
    entries = _statuses(doc, layout)
    rank = {s: i for i, s in enumerate(STATUS_ORDER)}
    rows = []
    for r in sorted(layout, key=lambda r: (rank[_status(entries.get(r.id))], r.id)):
        en = entries.get(r.id, {})
        shift = _pair(en.get("shift_m"))
        sig = _pair(en.get("shift_sigma_m"))
        rows.append([str(r.id), _status(en), f"{r.x:.3f}", f"{r.y:.3f}",
                     str(en.get("expected_sightings", "")), str(en.get("sightings", "")),
                     _mm(_f(en.get("residual_m"))),
                     f"{_mm(shift[0])}, {_mm(shift[1])}" if shift else "",
                     f"{_mm(sig[0])}, {_mm(sig[1])}" if sig else ""])
    return rows


def _segment_rows(coverage: JSONObject) -> list[list[str]]:
    rows = []
    for item in _list(coverage.get("segments")):
        s = _obj(item)
        c = _pair(s.get("centre_xy_m"))
        rows.append([str(s.get("log", "")), _num(_f(s.get("start_s")), 1),
                     _num(_f(s.get("end_s")), 1), _num(_f(s.get("duration_s")), 1),
                     _num(_f(s.get("length_m")), 1),
                     f"{c[0]:.1f}, {c[1]:.1f}" if c else "", str(s.get("visible_min", "")),
                     _num(_f(s.get("gdop_max"))) or "none possible",
                     "" if s.get("reported_used_min") is None else str(s["reported_used_min"]),
                     "; ".join(str(r) for r in _list(s.get("reasons")))])
    return rows


def render_audit_report(doc: JSONObject, layout: Sequence[Reflector],
                        tracks: Sequence[HeadTrack] = (), *, title: str | None = None) -> str:
    """The audit report as one HTML page.

    ``doc``: ``audit.json`` as built (keys read: ``reflectors`` (id, status,
    expected_sightings, sightings, residual_m, shift_m, shift_sigma_m), ``unmapped`` (x, y,
    sightings, sigma_m), ``coverage`` (:func:`lgvtool.audit.coverage.coverage_section`),
    ``notes`` (strings shown in the summary, e.g. what a NAV200 log cannot audit), ``logs``
    (names), ``navigation`` (:func:`lgvtool.audit.navigation_health.navigation_section`),
    ``segments``, ``stations`` (:func:`lgvtool.audit.stations.stations_section`));
    any may be missing. ``layout``: the layout reflectors as surveyed (m);
    ``tracks``: the drives of the NAV head (m) drawn on the map.
    """
    e = html.escape
    logs = [str(n) for n in _list(doc.get("logs"))]
    title = title or ("lgvtool audit" + (": " + ", ".join(logs) if logs else ""))
    figs = _Figures()
    body = [f'<h1>{e(title)}</h1><p class="meta">lgvtool {e(__version__)}; '
            f"{len(layout)} layout reflectors"
            + (f"; {len(logs)} log{'s' if len(logs) != 1 else ''}" if logs else "") + ".</p>"]

    def fig_html(slug: str, fig: go.Figure) -> str:
        div = figs(slug, fig)
        cap = CAPTIONS.get(slug, "")
        return div[:-len("</div>")] + f'<p class="figcap">{e(cap)}</p></div>' if cap else div

    body.append(f'<div class="lead">{_summary_html(doc, layout)}'
                f'{fig_html("audit-map", map_figure(doc, layout, tracks))}</div>')
    body.append('<section data-section="reflectors" id="reflectors"><h2>Reflectors</h2>')
    if doc.get("reflectors"):
        body.append(_table_html(
            "reflectors", ["id", "status", "x (m)", "y (m)", "expected", "sightings",
                           "residual (mm)", "shift dx, dy (mm)", "1-sigma (mm)"],
            _reflector_rows(doc, layout),
            "layout order by status; expected: revolutions with the reflector in range and not "
            "hidden; shift and its 1-sigma for a moved reflector"))
    else:
        body.append('<p class="note">No reflector was audited (the log holds no landmark '
                    "observations): the coverage below is what it allows.</p>")
    unmapped = [_obj(u) for u in _list(doc.get("unmapped"))]
    if unmapped:
        body.append(_table_html(
            "unmapped", ["x (m)", "y (m)", "sightings", "sigma (mm)"],
            [[_num(_f(u.get("x")), 3), _num(_f(u.get("y")), 3), str(u.get("sightings", "")),
              _mm(_f(u.get("sigma_m")))] for u in unmapped],
            "recurring detections that match no layout reflector"))
    body.append("</section>")
    cov = _obj(doc.get("coverage"))
    if cov:
        body.append('<section data-section="coverage" id="coverage"><h2>Coverage</h2>')
        view = _obj(cov.get("view"))
        body.append(f'<p class="note">At each pose of the drive ({e(str(cov.get("source")))}), '
                    "the layout reflectors the head could see (range "
                    f"{_num(_f(view.get('range_min_m')), 1)}-"
                    f"{_num(_f(view.get('range_max_m')), 1)} m, not hidden behind a nearer "
                    f"one) and the GDOP of a {e(str(cov.get('gdop_model')))} fit, "
                    "the position's standard deviation in units of one range's.</p>")
        for what in ("gdop", "visible"):
            fig = heatmap_figure(cov, layout, what)
            if fig is not None:
                body.append(fig_html(f"coverage-{what}", fig))
        rows = _segment_rows(cov)
        if rows:
            body.append(_table_html(
                "segments", ["log", "start (s)", "end (s)", "duration (s)", "length (m)",
                             "centre x, y (m)", "fewest visible", "worst GDOP",
                             "fewest used", "why"], rows,
                f"the longest of {cov.get('segments_total', len(rows))} stretches where "
                "fewer than the device's minimum are visible or the GDOP is above "
                f"{_num(_f(_obj(cov.get('settings')).get('gdop_max')), 1)}",
                title="Worst segments"))
        else:
            body.append('<p class="note">No poor segment: the whole drive sees enough '
                        "reflectors in a good geometry.</p>")
        body.append("</section>")
    nav = _obj(doc.get("navigation"))
    if _list(nav.get("logs")):
        body.append(_navigation_html(nav, fig_html))
    seg = _obj(doc.get("segments"))
    if _list(seg.get("sources")):
        body.append(_segments_html(seg, fig_html))
    st = _obj(doc.get("stations"))
    if "per_station" in st:
        body.append(_stations_html(st, fig_html))
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            '<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{e(title)}</title><style>{_STYLE}{_MORE_STYLE}</style></head><body>\n"
            + "\n".join(body) + f"\n<script>{_SCRIPT}</script>\n</body></html>\n")


def write_audit_report(doc: JSONObject, layout: Sequence[Reflector], path: str | Path,
                       tracks: Sequence[HeadTrack] = (), *, title: str | None = None) -> None:
    """Write :func:`render_audit_report` of ``doc`` (``audit.json`` as built), the surveyed
    ``layout`` and the NAV head's ``tracks`` (m; one per log, the same tracks the coverage was
    computed from) to ``path`` (``report.html``; UTF-8)."""
    Path(path).write_text(render_audit_report(doc, layout, tracks, title=title),
                          encoding="utf-8")
