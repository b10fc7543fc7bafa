"""Coverage along a drive: at each pose of the NAV head, the layout reflectors it could see and
the dilution of precision (GDOP) of that geometry for the position, beside the number the device
reported using; a heat map of the site and the stretches where coverage is poor (SI units:
m, rad, s).

Pure: values in, values out (:func:`coverage_section` gives the ``coverage`` key of
``audit.json``).

The GDOP is that of a range-bearing fit with the heading unknown, the fit both NAV families
make: each visible reflector gives its range (standard deviation ``sigma_r``) and its bearing
relative to the head (``sigma_b``); the state is the head's ``(x, y, heading)``. With ``u`` the
unit vector from the head to a reflector at range ``r`` and ``g = (u_y, -u_x) / r``, the
information is::

    A = sum(u u^T / sigma_r^2 + g g^T / sigma_b^2)     (x, y block)
    b = -sum(g) / sigma_b^2                             (x, y against heading)
    c = n / sigma_b^2                                   (heading)

and the position covariance is ``M^-1`` with ``M = A - b b^T / c`` (the heading eliminated).
``GDOP = sqrt(trace(M^-1)) / sigma_r``: the position's standard deviation (m, radial) in units
of one range's. It is infinite below two reflectors (no position at all) or on a degenerate
geometry. docs/audit.md derives it.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.audit.visibility import (
    DeviceView,
    expected_visibility,
    pose_blocks,
    reflector_arrays,
)
from lgvtool.config import Reflector
from lgvtool.declared import as_dict, setting
from lgvtool.json_types import JSON, JSONObject
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAX_CELLS = 40_000
"""Most cells of the heat map: on a larger site (or a drive that strays far) the cell side
doubles until the grid fits (200 m x 200 m at 1 m)."""

GDOP_MODEL = "range-bearing, heading unknown"
"""The fit whose dilution of precision :func:`gdop` gives (named in ``audit.json``)."""


@dataclass(frozen=True)
class CoverageSettings:
    """How coverage along a drive is summarised: the heat map's cells and what counts as poor."""

    cell_m: float = setting(
        1.0, "Side of a heat map cell, m.", unit="m", minimum=0.05, maximum=100.0)
    gdop_max: float = setting(
        2.0,
        "GDOP above this is poor: the geometry alone makes the position's standard deviation "
        "more than this many times one range's (2: about 24 mm at 12 mm per range), "
        "dimensionless.",
        unit="", minimum=0.0, min_open=True)
    gap_s: float = setting(
        2.0, "A pause between poses longer than this ends a poor segment, s.", unit="s",
        minimum=0.0, min_open=True)
    match_s: float = setting(
        0.5,
        "A device pose within this of a drive pose gives its reported reflector count, s.",
        unit="s", minimum=0.0)
    segments_listed: int = setting(
        20, "Most poor segments listed (the longest first).", unit="", minimum=0,
        maximum=10_000)


@dataclass(frozen=True)
class HeadTrack:
    """The head's poses along one drive (valid poses only), in time order, and the device's
    own reflector counts.

    ``t`` s (any origin: the log's first message in ``audit.json``), ``x``, ``y`` m and
    ``heading`` rad of the NAV head in the map frame (not the vehicle's O:
    :func:`lgvtool.localize.geometry.o_to_nav` moves an estimate there); ``source``: what they
    come from (``"nav"``: the device's own poses, else an estimator's name); ``name``: the log's
    (segments name it). ``reported_t`` (s, same origin) and ``reported_used``: the device's
    poses and the number of reflectors each reports using (the NAV350 pose's
    ``reflectors_used`` field, the NAV200 reply's count), in time order, None when unknown.
    :meth:`of` sorts both and leaves out non-finite poses.
    """

    path: Trajectory
    """The poses: ``t`` s, ``x``, ``y`` m, ``heading`` rad (the one trajectory type)."""
    source: str = "nav"
    name: str = ""
    reported_t: FloatArray | None = None
    reported_used: IntArray | None = None

    def __post_init__(self) -> None:
        if (self.reported_t is None) != (self.reported_used is None) or (
                self.reported_t is not None and self.reported_used is not None
                and len(self.reported_t) != len(self.reported_used)):
            raise ValueError("reported_t and reported_used must be given together, of one "
                             "length")

    @property
    def t(self) -> FloatArray:
        """Time of each pose, s."""
        return self.path.t

    @property
    def x(self) -> FloatArray:
        """x of the head in the map frame, m."""
        return self.path.x

    @property
    def y(self) -> FloatArray:
        """y of the head in the map frame, m."""
        return self.path.y

    @property
    def heading(self) -> FloatArray:
        """Heading of the head in the map frame, rad."""
        return self.path.heading

    def __len__(self) -> int:
        return len(self.path)

    @classmethod
    def of(cls, t: ArrayLike, x: ArrayLike, y: ArrayLike, heading: ArrayLike,
           source: str = "nav", name: str = "", reported_t: ArrayLike | None = None,
           reported_used: ArrayLike | None = None) -> HeadTrack:
        """A track from array-likes (s, m, m, rad; the counts' s and counts), sorted by
        time; poses with a non-finite time, position or heading are left out."""
        ta = np.asarray(t, dtype=np.float64).ravel()
        xa = np.asarray(x, dtype=np.float64).ravel()
        ya = np.asarray(y, dtype=np.float64).ravel()
        ha = np.asarray(heading, dtype=np.float64).ravel()
        if not len(ta) == len(xa) == len(ya) == len(ha):
            raise ValueError("t, x, y and heading must be of one length")
        keep = np.isfinite(ta) & np.isfinite(xa) & np.isfinite(ya) & np.isfinite(ha)
        ta, xa, ya, ha = ta[keep], xa[keep], ya[keep], ha[keep]
        order = np.argsort(ta, kind="stable")
        rt = ru = None
        if reported_t is not None and reported_used is not None:
            rt = np.asarray(reported_t, dtype=np.float64).ravel()
            ru = np.asarray(reported_used, dtype=np.int64).ravel()
            if len(rt) == len(ru):
                ro = np.argsort(rt, kind="stable")
                rt, ru = rt[ro], ru[ro]
        return cls(Trajectory(ta[order], xa[order], ya[order], ha[order]), source, name, rt,
                   ru)


@dataclass(frozen=True)
class PoseCoverage:
    """Coverage at each pose of a :class:`HeadTrack`: ``visible`` the number of layout
    reflectors the head could see, ``gdop`` their geometry's GDOP (dimensionless, inf where no
    position is possible), ``reported`` the number the device reported using (-1 where no
    device pose lies within ``match_s``)."""

    visible: IntArray
    gdop: FloatArray
    reported: IntArray


def gdop(head_x: FloatArray, head_y: FloatArray, visible: NDArray[np.bool_],
         reflectors: Sequence[Reflector], view: DeviceView) -> FloatArray:
    """GDOP of the range-bearing fit (heading unknown) at each pose, from the reflectors each
    sees (``visible`` ``(n_poses, n_reflectors)``); dimensionless, inf where fewer than two are
    visible or the geometry is degenerate. ``head_x``, ``head_y`` in m; the noise ratio from
    ``view`` (``sigma_range_m``, ``sigma_bearing_deg``)."""
    rx, ry, _ = reflector_arrays(reflectors)
    n = len(head_x)
    if n == 0:
        return np.zeros(0, dtype=np.float64)
    w = visible.astype(np.float64)
    dx = rx[None, :] - head_x[:, None]
    dy = ry[None, :] - head_y[:, None]
    r = np.maximum(np.hypot(dx, dy), 1e-9)
    ux, uy = dx / r, dy / r
    # everything in units of sigma_r: range weight 1, bearing weight (sigma_r / sigma_b)^2
    kb = (view.sigma_range_m / view.sigma_bearing_rad) ** 2
    gx, gy = uy / r, -ux / r
    a_xx = (w * (ux * ux + kb * gx * gx)).sum(axis=1)
    a_yy = (w * (uy * uy + kb * gy * gy)).sum(axis=1)
    a_xy = (w * (ux * uy + kb * gx * gy)).sum(axis=1)
    b_x = -kb * (w * gx).sum(axis=1)
    b_y = -kb * (w * gy).sum(axis=1)
    count = w.sum(axis=1)
    c = kb * count
    with np.errstate(divide="ignore", invalid="ignore"):
        m_xx = a_xx - b_x * b_x / c
        m_yy = a_yy - b_y * b_y / c
        m_xy = a_xy - b_x * b_y / c
        det = m_xx * m_yy - m_xy * m_xy
        tr = m_xx + m_yy
        out = np.sqrt(tr / det)
    bad = (count < 2) | ~(det > 1e-12 * tr * tr) | ~np.isfinite(out)
    out[bad] = np.inf
    return np.asarray(out, dtype=np.float64)


def coverage_at_poses(track: HeadTrack, reflectors: Sequence[Reflector], view: DeviceView,
                      settings: CoverageSettings | None = None) -> PoseCoverage:
    """:class:`PoseCoverage` of every pose of ``track``, computed in blocks of poses (the
    visibility of one block at a time: memory bounded on a drive of hours). Each pose takes
    the reported count of the track's nearest device pose within ``settings.match_s``."""
    s = settings or CoverageSettings()
    n, m = len(track), len(reflectors)
    visible = np.zeros(n, dtype=np.int64)
    g = np.full(n, np.inf, dtype=np.float64)
    for rows in _blocks(n, m):
        seen = expected_visibility(track.x[rows], track.y[rows], track.heading[rows],
                                   reflectors, view)
        visible[rows] = seen.sum(axis=1)
        g[rows] = gdop(track.x[rows], track.y[rows], seen, reflectors, view)
    reported = _nearest_counts(track.t, track.reported_t, track.reported_used, s.match_s)
    return PoseCoverage(visible, g, reported)


def _blocks(n: int, m: int) -> Iterator[slice]:
    """Blocks of poses for :func:`coverage_at_poses`: at most 8192, and within the
    visibility's own pair budget."""
    for outer in pose_blocks(n, m):
        for start in range(outer.start, outer.stop, 8192):
            yield slice(start, min(outer.stop, start + 8192))


def _nearest_counts(t: FloatArray, rt: FloatArray | None, ru: IntArray | None,
                    match_s: float) -> IntArray:
    """The count ``ru`` of the device pose (times ``rt`` s, sorted) nearest each time of
    ``t`` (within ``match_s`` s), else -1."""
    out = np.full(len(t), -1, dtype=np.int64)
    if rt is None or ru is None or len(rt) == 0 or len(t) == 0:
        return out
    hi = np.clip(np.searchsorted(rt, t), 0, len(rt) - 1)
    lo = np.maximum(hi - 1, 0)
    pick = np.where(np.abs(rt[lo] - t) <= np.abs(rt[hi] - t), lo, hi)
    close = np.abs(rt[pick] - t) <= match_s
    out[close] = ru[pick[close]]
    return out


# --------------------------------------------------------------------------- summaries


def _num(v: float, digits: int = 4) -> float | None:
    """A float for JSON, rounded; None for a non-finite one."""
    return round(float(v), digits) if math.isfinite(v) else None


def _path_length(x: FloatArray, y: FloatArray) -> FloatArray:
    """Cumulative path length along the points (m), starting at 0."""
    if len(x) == 0:
        return np.zeros(0, dtype=np.float64)
    return np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))


@dataclass(frozen=True)
class Segment:
    """A stretch of the drive where coverage is poor: poses ``first`` to ``last`` (indices)
    inclusive, ``start_s`` to ``end_s`` (s: the end is the next pose's time when the drive
    goes on without a pause, else the last poor pose's)."""

    first: int
    last: int
    start_s: float
    end_s: float


def poor_segments(t: FloatArray, poor: NDArray[np.bool_], gap_s: float) -> list[Segment]:
    """Runs of consecutive poor poses (``poor``, times ``t`` s); a pause longer than ``gap_s``
    s between two poses ends a run."""
    n = len(t)
    if n == 0 or not poor.any():
        return []
    dt = np.diff(t)
    brk = np.concatenate(([True], (dt > gap_s) | ~poor[1:] | ~poor[:-1]))
    starts = np.flatnonzero(poor & brk)
    out = []
    for a in starts:
        b = int(a)
        while b + 1 < n and poor[b + 1] and t[b + 1] - t[b] <= gap_s:
            b += 1
        end = float(t[b + 1]) if b + 1 < n and t[b + 1] - t[b] <= gap_s else float(t[b])
        out.append(Segment(int(a), b, float(t[a]), end))
    return out


def _segment_json(seg: Segment, track: HeadTrack, cov: PoseCoverage, along: FloatArray,
                  s: CoverageSettings, view: DeviceView) -> JSONObject:
    """One poor segment as ``audit.json`` holds it."""
    rows = slice(seg.first, seg.last + 1)
    few = bool((cov.visible[rows] < view.min_reflectors).any())
    high = bool((cov.gdop[rows] > s.gdop_max).any())
    reasons: list[JSON] = []
    if few:
        reasons.append(f"fewer than {view.min_reflectors} visible")
    if high:
        reasons.append(f"GDOP above {s.gdop_max:g}")
    end = min(seg.last + 1, len(track) - 1) if seg.end_s > float(track.t[seg.last]) \
        else seg.last
    reported = cov.reported[rows]
    known = reported[reported >= 0]
    return {
        "log": track.name,
        "start_s": _num(seg.start_s, 3), "end_s": _num(seg.end_s, 3),
        "duration_s": _num(seg.end_s - seg.start_s, 3),
        "length_m": _num(float(along[end] - along[seg.first]), 3),
        "poses": seg.last - seg.first + 1,
        "start_xy_m": [_num(float(track.x[seg.first]), 3), _num(float(track.y[seg.first]), 3)],
        "end_xy_m": [_num(float(track.x[end]), 3), _num(float(track.y[end]), 3)],
        "centre_xy_m": [_num(float(track.x[rows].mean()), 3),
                        _num(float(track.y[rows].mean()), 3)],
        "visible_min": int(cov.visible[rows].min()),
        "gdop_max": _num(float(cov.gdop[rows].max()), 3),
        "reported_used_min": int(known.min()) if len(known) else None,
        "reasons": reasons,
    }


def _grid(px: FloatArray, py: FloatArray, cov: PoseCoverage, reflectors: Sequence[Reflector],
          s: CoverageSettings) -> JSONObject:
    """The heat map: the site in square cells of ``s.cell_m`` m (doubled until at most
    :data:`MAX_CELLS` cover it; ``cell_m`` in the result is the side used), over the drive
    (``px``, ``py`` m and ``cov``: every drive's poses joined) and the layout; per cell (rows: y,
    columns: x) the poses in it, the mean and least visible count, and the mean (over the
    poses with a finite GDOP) and worst GDOP (None: no pose in the cell, or no position
    possible there)."""
    rx, ry, _ = reflector_arrays(reflectors)
    xs = np.concatenate((px, rx))
    ys = np.concatenate((py, ry))
    cell = s.cell_m
    if len(xs) == 0:
        return {"cell_m": cell, "x0_m": 0.0, "y0_m": 0.0, "nx": 0, "ny": 0, "poses": [],
                "visible_mean": [], "visible_min": [], "gdop_mean": [], "gdop_max": []}
    while True:  # a cell size that keeps the grid within MAX_CELLS
        x0 = math.floor(float(xs.min()) / cell) * cell
        y0 = math.floor(float(ys.min()) / cell) * cell
        nx = max(1, math.floor((float(xs.max()) - x0) / cell) + 1)
        ny = max(1, math.floor((float(ys.max()) - y0) / cell) + 1)
        if nx * ny <= MAX_CELLS:
            break
        cell *= 2.0
    ix = np.clip(((px - x0) / cell).astype(np.int64), 0, nx - 1)
    iy = np.clip(((py - y0) / cell).astype(np.int64), 0, ny - 1)
    flat = iy * nx + ix
    size = nx * ny
    poses = np.bincount(flat, minlength=size)
    vis_sum = np.bincount(flat, weights=cov.visible.astype(np.float64), minlength=size)
    vis_min = np.full(size, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(vis_min, flat, cov.visible)
    finite = np.isfinite(cov.gdop)
    g_n = np.bincount(flat[finite], minlength=size)
    g_sum = np.bincount(flat[finite], weights=cov.gdop[finite], minlength=size)
    g_max = np.full(size, -np.inf)
    np.maximum.at(g_max, flat, cov.gdop)
    with np.errstate(divide="ignore", invalid="ignore"):
        vis_mean = vis_sum / poses
        g_mean = g_sum / g_n

    def rows(values: NDArray[np.float64] | IntArray, have: NDArray[np.bool_],
             digits: int) -> list[JSON]:
        v = values.reshape(ny, nx)
        h = have.reshape(ny, nx)
        return [[_num(float(v[j, i]), digits) if h[j, i] else None for i in range(nx)]
                for j in range(ny)]

    visited = poses > 0
    return {
        "cell_m": cell, "x0_m": _num(x0, 6), "y0_m": _num(y0, 6), "nx": nx, "ny": ny,
        "poses": [[int(p) for p in row] for row in poses.reshape(ny, nx)],
        "visible_mean": rows(vis_mean, visited, 2),
        "visible_min": [[int(vis_min[j * nx + i]) if visited[j * nx + i] else None
                         for i in range(nx)] for j in range(ny)],
        "gdop_mean": rows(g_mean, g_n > 0, 3),
        "gdop_max": rows(g_max, visited & np.isfinite(g_max), 3),
    }


def _stats(v: FloatArray) -> JSONObject:
    """Least, median, mean, 95th percentile and greatest of ``v`` (None where empty or not
    finite)."""
    if len(v) == 0:
        return {"min": None, "median": None, "mean": None, "p95": None, "max": None}
    return {"min": _num(float(v.min())), "median": _num(float(np.median(v))),
            "mean": _num(float(v.mean())), "p95": _num(float(np.percentile(v, 95))),
            "max": _num(float(v.max()))}


def coverage_section(tracks: HeadTrack | Sequence[HeadTrack], reflectors: Sequence[Reflector],
                     view: DeviceView, settings: CoverageSettings | None = None) -> JSONObject:
    """The ``coverage`` key of ``audit.json`` for one drive or several (``tracks``: the head's
    valid poses of each log, from the device's own poses or a replayed estimate moved to the
    head, with the device's reported counts) over the layout ``reflectors`` as ``view`` sees
    them. Works on any family's log: it needs poses only. Several drives are pooled (the
    figures and the heat map over all their poses; segments name their log).

    Keys: ``source`` (the tracks' sources), ``gdop_model``, ``view`` and ``settings`` (the
    values used), ``logs``, ``excluded_ids`` (layout reflectors left out: found missing,
    :func:`section_from`), ``poses``, ``duration_s``, ``distance_m``, ``visible`` and
    ``gdop`` (min, median, mean, p95, max over the poses; GDOP over those where a position is
    possible), ``position_sigma_m`` (the same for GDOP x ``view.sigma_range_m``, m),
    ``no_position_fraction`` (share of poses where fewer than two are visible),
    ``below_min_fraction`` (fewer than ``view.min_reflectors``), ``gdop_above_fraction`` (GDOP
    above ``settings.gdop_max``, or none possible), ``reported_used`` (None without device
    counts, else the poses matched, the counts' mean and median, the share below
    ``view.min_reflectors`` and the mean of visible minus reported), ``segments_total``,
    ``poor_time_s``, ``segments`` (the longest ``settings.segments_listed`` poor stretches:
    log, start_s, end_s, duration_s, length_m, poses, start_xy_m, end_xy_m, centre_xy_m,
    visible_min, gdop_max, reported_used_min, reasons) and ``grid`` (cell_m, x0_m, y0_m, nx,
    ny, then rows over y of columns over x: poses, visible_mean, visible_min, gdop_mean,
    gdop_max; None where no pose fell in the cell).
    """
    s = settings or CoverageSettings()
    parts = [tracks] if isinstance(tracks, HeadTrack) else list(tracks)
    covs = [coverage_at_poses(tr, reflectors, view, s) for tr in parts]
    return section_from(parts, covs, reflectors, view, s)


def section_from(tracks: Sequence[HeadTrack], covs: Sequence[PoseCoverage],
                 reflectors: Sequence[Reflector], view: DeviceView,
                 settings: CoverageSettings, missing: Collection[int] = ()) -> JSONObject:
    """:func:`coverage_section` from the per-pose coverage ``covs`` of ``tracks`` (one each)
    already computed over ``reflectors``.

    ``missing``: ids of layout reflectors the audit found missing. They cannot be used, so the
    coverage is computed again without them (they neither count nor hide others), and the
    section lists them as ``excluded_ids``; unknown ids are ignored.
    """
    s = settings
    gone = {r.id for r in reflectors} & set(missing)
    if gone:
        reflectors = [r for r in reflectors if r.id not in gone]
        covs = [coverage_at_poses(tr, reflectors, view, s) for tr in tracks]
    segs: list[tuple[Segment, HeadTrack, PoseCoverage, FloatArray]] = []
    distance = duration = 0.0
    for tr, cov in zip(tracks, covs, strict=True):
        along = _path_length(tr.x, tr.y)
        poor = (cov.visible < view.min_reflectors) | ~(cov.gdop <= s.gdop_max)
        segs += [(g, tr, cov, along) for g in poor_segments(tr.t, poor, s.gap_s)]
        if len(tr):
            distance += float(along[-1])
            duration += float(tr.t[-1] - tr.t[0])
    segs.sort(key=lambda g: (-(g[0].end_s - g[0].start_s), g[1].name, g[0].start_s))
    px, py = _joined_xy(tracks)
    cov = PoseCoverage(
        np.concatenate([c.visible for c in covs] or [np.zeros(0, dtype=np.int64)]),
        np.concatenate([c.gdop for c in covs] or [np.zeros(0, dtype=np.float64)]),
        np.concatenate([c.reported for c in covs] or [np.zeros(0, dtype=np.int64)]))
    n = len(px)
    finite = np.isfinite(cov.gdop)
    known = cov.reported >= 0
    reported: JSON = None
    if known.any():
        used = cov.reported[known].astype(np.float64)
        reported = {
            "poses": int(known.sum()), "mean": _num(float(used.mean()), 3),
            "median": _num(float(np.median(used)), 3),
            "below_min_fraction": _num(float((used < view.min_reflectors).mean())),
            "mean_visible_minus_used": _num(
                float((cov.visible[known] - cov.reported[known]).mean()), 3),
        }
    possible = cov.gdop[finite]
    excluded: list[JSON] = [int(i) for i in sorted(gone)]
    return {
        "source": ", ".join(dict.fromkeys(tr.source for tr in tracks)),
        "gdop_model": GDOP_MODEL,
        "view": as_dict(view),
        "settings": as_dict(s),
        "logs": [tr.name for tr in tracks],
        "excluded_ids": excluded,
        "poses": n,
        "duration_s": _num(duration, 3),
        "distance_m": _num(distance, 3),
        "visible": _stats(cov.visible.astype(np.float64)),
        "gdop": _stats(possible),
        "position_sigma_m": _stats(possible * view.sigma_range_m),
        "no_position_fraction": _num(float((~finite).mean())) if n else None,
        "below_min_fraction": _num(float((cov.visible < view.min_reflectors).mean()))
        if n else None,
        "gdop_above_fraction": _num(float((~(cov.gdop <= s.gdop_max)).mean())) if n else None,
        "reported_used": reported,
        "segments_total": len(segs),
        "poor_time_s": _num(sum(g[0].end_s - g[0].start_s for g in segs), 3),
        "segments": [_segment_json(g, tr, c, along, s, view)
                     for g, tr, c, along in segs[:s.segments_listed]],
        "grid": _grid(px, py, cov, reflectors, s),
    }


def _joined_xy(tracks: Sequence[HeadTrack]) -> tuple[FloatArray, FloatArray]:
    """The positions of ``tracks``' poses one after the other, m (for the pooled figures and
    the heat map, which need no times)."""
    if not tracks:
        return np.zeros(0), np.zeros(0)
    return (np.concatenate([tr.x for tr in tracks]), np.concatenate([tr.y for tr in tracks]))
