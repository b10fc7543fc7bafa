"""Observations the estimators consume, and the reflector map they are matched against.

Two kinds of observation reach an estimator:

- :class:`PoseObservation`: a pose of the laser head reported by the navigation device
  (NAV200 ``/nav/pose``), m and rad in the map frame;
- :class:`ScanObservation`: the reflectors measured in one head revolution (or one camera
  frame), already expressed as geometry in the vehicle body frame at the observation time
  ``t``: for each reflector the sensor origin and heading in the body frame (which include
  the mounting offset and, when de-skewed, the vehicle's own motion between the measurement
  and ``t``), plus the measured range and bearing.

:func:`scan_observations` builds the latter from raw scans; with a motion track it de-skews
each reflector by its time within the revolution.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Reflector
from lgvtool.localize.motion import MotionTrack
from lgvtool.localize.params import param


@dataclass(frozen=True)
class PoseObservation:
    """A pose of the laser head in the map frame: ``x, y`` in m, ``heading`` in rad, at ``t`` s;
    ``v`` (m/s) and ``omega`` (rad/s): the odometry's forward speed and turn rate of O at ``t``
    (0 when unknown), which the rotating-head pose model's covariance grows with
    (:mod:`lgvtool.localize.pose_model`)."""

    t: float
    x: float
    y: float
    heading: float
    v: float = 0.0
    omega: float = 0.0


@dataclass(frozen=True)
class RawScan:
    """One scan as logged: start time ``t`` (s), revolution ``period`` (s, 0 for a snapshot
    sensor), and per reflector its range (m), bearing (rad, sensor frame), time after the start
    (s) and map id (-1 if unknown)."""

    t: float
    period: float
    ranges: NDArray[np.float64]
    bearings: NDArray[np.float64]
    times: NDArray[np.float64]
    ids: NDArray[np.int64]


class ScanBatch:
    """Many scans as flat arrays: per scan its start ``t`` (s), ``period`` (s) and ``counts``
    (reflectors); per reflector its range (m), bearing (rad), time in the scan (s) and id."""

    __slots__ = ("bearings", "counts", "ids", "period", "ranges", "t", "times")

    def __init__(self, t: NDArray[np.float64], period: NDArray[np.float64],
                 counts: NDArray[np.int64], ranges: NDArray[np.float64],
                 bearings: NDArray[np.float64], times: NDArray[np.float64],
                 ids: NDArray[np.int64]) -> None:
        self.t = t
        self.period = period
        self.counts = counts
        self.ranges = ranges
        self.bearings = bearings
        self.times = times
        self.ids = ids

    def __len__(self) -> int:
        return len(self.t)

    @classmethod
    def from_scans(cls, scans: Sequence[RawScan]) -> ScanBatch:
        """Flatten a list of scans."""
        if not scans:
            z = np.zeros(0)
            return cls(z, z, np.zeros(0, dtype=np.int64), z, z, z, np.zeros(0, dtype=np.int64))
        return cls(np.array([s.t for s in scans], dtype=np.float64),
                   np.array([s.period for s in scans], dtype=np.float64),
                   np.array([len(s.ranges) for s in scans], dtype=np.int64),
                   np.concatenate([s.ranges for s in scans]),
                   np.concatenate([s.bearings for s in scans]),
                   np.concatenate([s.times for s in scans]),
                   np.concatenate([s.ids for s in scans]).astype(np.int64))


class _Points:
    """Measured reflectors: per reflector the point ``q`` (complex ``x + iy``, m, body frame),
    the unit ray ``u`` (complex, body frame), the range (m) and the map id (-1 unknown)."""

    __slots__ = ("_map_index", "ids", "q", "ranges", "u")

    def __init__(self, q: NDArray[np.complex128], u: NDArray[np.complex128],
                 ranges: NDArray[np.float64], ids: NDArray[np.int64]) -> None:
        self.q = q
        self.u = u
        self.ranges = ranges
        self.ids = ids
        self._map_index: tuple[ReflectorMap, NDArray[np.int64]] | None = None

    def __len__(self) -> int:
        return len(self.ranges)

    def map_index(self, rmap: ReflectorMap) -> NDArray[np.int64]:
        """Index in ``rmap`` of each reflector's id (-1 unknown or not in the map), cached."""
        cached = self._map_index
        if cached is not None and cached[0] is rmap:
            return cached[1]
        idx = rmap.index_of(self.ids)
        self._map_index = (rmap, idx)
        return idx


class ScanPoints(_Points):
    """The reflectors of consecutive scans one after the other (those of scan ``k`` are
    ``bounds[k]:bounds[k + 1]``), as :func:`scan_observations` builds them; each of its
    :class:`ScanObservation` holds a view of its own part."""

    __slots__ = ("bounds",)

    def __init__(self, q: NDArray[np.complex128], u: NDArray[np.complex128],
                 ranges: NDArray[np.float64], ids: NDArray[np.int64], bounds: list[int]
                 ) -> None:
        super().__init__(q, u, ranges, ids)
        self.bounds = bounds


class ScanObservation(_Points):
    """Reflectors measured by a sensor, in the vehicle body frame at time ``t`` (s).

    Per reflector ``k``: the measured point ``q`` (complex ``x + iy``, m, body frame), the unit
    ray ``u`` from the sensor towards it (complex, body frame), the measured range (m) and the
    map id (-1 unknown). The sensor pose per reflector (mounting offset and, when de-skewed,
    the vehicle's own motion since the reflector was measured) is folded into ``q`` and ``u``.
    ``block``, ``index``: the :class:`ScanPoints` it is part ``index`` of (None when made
    alone).
    """

    __slots__ = ("block", "index", "t")

    def __init__(self, t: float, q: NDArray[np.complex128], u: NDArray[np.complex128],
                 ranges: NDArray[np.float64], ids: NDArray[np.int64],
                 block: ScanPoints | None = None, index: int = -1) -> None:
        # (the fields set here rather than by the base's __init__: one call less per scan)
        self.q = q
        self.u = u
        self.ranges = ranges
        self.ids = ids
        self._map_index = None
        self.t = float(t)
        self.block = block
        self.index = index

    @property
    def qx(self) -> NDArray[np.float64]:
        """Forward coordinate of each measured point in the body frame, m."""
        return self.q.real

    @property
    def qy(self) -> NDArray[np.float64]:
        """Leftward coordinate of each measured point in the body frame, m."""
        return self.q.imag

    @property
    def ux(self) -> NDArray[np.float64]:
        """Forward component of each unit ray."""
        return self.u.real

    @property
    def uy(self) -> NDArray[np.float64]:
        """Leftward component of each unit ray."""
        return self.u.imag

    @classmethod
    def from_sensor(cls, t: float, ox: NDArray[np.float64], oy: NDArray[np.float64],
                    oth: NDArray[np.float64], ranges: NDArray[np.float64],
                    bearings: NDArray[np.float64], ids: NDArray[np.int64]) -> ScanObservation:
        """From per-reflector sensor poses ``(ox, oy, oth)`` in the body frame (m, rad) and the
        measured ranges (m) and bearings (rad, sensor frame)."""
        u = np.exp(1j * (np.asarray(oth, dtype=np.float64) + bearings))
        r = np.asarray(ranges, dtype=np.float64)
        return cls(t, np.asarray(ox) + 1j * np.asarray(oy) + r * u, u, r,
                   np.asarray(ids, dtype=np.int64))

    @classmethod
    def simple(cls, t: float, ranges: NDArray[np.float64] | list[float],
               bearings: NDArray[np.float64] | list[float],
               ids: NDArray[np.int64] | list[int] | None = None, *, nav_x: float = 0.0,
               nav_y: float = 0.0) -> ScanObservation:
        """All reflectors measured at ``t`` by a sensor at ``(nav_x, nav_y)`` (m) in the vehicle
        frame, aligned with the vehicle x axis."""
        r = np.asarray(ranges, dtype=np.float64)
        k = len(r)
        i = np.full(k, -1, dtype=np.int64) if ids is None else np.asarray(ids, dtype=np.int64)
        return cls.from_sensor(t, np.full(k, float(nav_x)), np.full(k, float(nav_y)),
                               np.zeros(k), r, np.asarray(bearings, dtype=np.float64), i)


def scan_observations(scans: ScanBatch, nav_x: float, nav_y: float, *,
                      track: MotionTrack | None = None, deskew: bool = False,
                      min_range: float = 0.0, max_range: float = math.inf
                      ) -> list[ScanObservation]:
    """Raw scans as body-frame geometry, keeping ranges in ``[min_range, max_range]`` m.

    Without de-skew every reflector is taken as measured at the middle of the revolution
    (``t + period / 2``), the least biased single time. With de-skew (needs ``track``) the
    observation time is the end of the revolution and each reflector's sensor pose is the
    vehicle's odometry pose at its own measurement time, expressed in the body frame at the
    end. All scans are processed in one vectorised pass.
    """
    if len(scans) == 0:
        return []
    counts, r, b, tau, ids = scans.counts, scans.ranges, scans.bearings, scans.times, scans.ids
    start, period = scans.t, scans.period
    owner = np.repeat(np.arange(len(start)), counts)
    mount = complex(nav_x, nav_y)
    if deskew and track is not None:
        t_obs = start + period
        x, y, th, _, _ = track.poses_at(np.concatenate([t_obs, start[owner] + tau]))
        n = len(start)
        x0, y0, th0 = x[:n][owner], y[:n][owner], th[:n][owner]
        rot0 = np.exp(-1j * th0)
        # the vehicle pose at each reflector's measurement time, in the body frame at the end
        d = ((x[n:] - x0) + 1j * (y[n:] - y0)) * rot0
        dth = th[n:] - th0
        u = np.exp(1j * (dth + b))
        q = d + np.exp(1j * dth) * mount + r * u
    else:
        t_obs = start + 0.5 * period
        u = np.exp(1j * b)
        q = mount + r * u
    keep = (r >= min_range) & (r <= max_range)
    if not keep.all():
        counts = np.bincount(owner[keep], minlength=len(start))
        q, u, r, ids = q[keep], u[keep], r[keep], ids[keep]
    bounds = np.concatenate([[0], np.cumsum(counts)]).tolist()
    block = ScanPoints(q, u, r, ids, bounds)
    return [ScanObservation(ts, q[a:e], u[a:e], r[a:e], ids[a:e], block, k)
            for k, (ts, a, e) in enumerate(zip(t_obs.tolist(), bounds[:-1], bounds[1:],
                                                strict=True))]


class ReflectorMap:
    """Known reflector positions (m) with id lookup and nearest-neighbour association.

    Nearest-neighbour queries are exact. For maps of more than a few reflectors they use a
    grid over the reflectors' bounding box (plus ``margin`` m): each cell lists every reflector
    that can be the nearest to some point of the cell (those within the cell diagonal of the
    nearest to its centre), so a query compares a point with two or three candidates instead
    of the whole map. Points outside the grid are compared with the whole map.
    """

    #: maps whose ids span at most this many numbers look ids up in a table
    ID_TABLE_SPAN = 1 << 16

    def __init__(self, reflectors: tuple[Reflector, ...] | list[Reflector], *,
                 cell: float = 0.1, margin: float = 3.0) -> None:
        self.reflectors = tuple(reflectors)
        self.x = np.array([r.x for r in self.reflectors], dtype=np.float64)
        self.y = np.array([r.y for r in self.reflectors], dtype=np.float64)
        self.ids = np.array([r.id for r in self.reflectors], dtype=np.int64)
        # ids sorted, and the map index of each (the last reflector of a repeated id)
        order = np.argsort(self.ids, kind="stable")
        sorted_ids = self.ids[order]
        last = np.ones(len(order), dtype=bool)
        last[:-1] = sorted_ids[:-1] != sorted_ids[1:]
        self._sorted_ids, self._sorted_index = sorted_ids[last], order[last]
        # ids of a compact range (a NAV's are small numbers) looked up in one table: entry
        # ``id - ids.min() + 1``, with -1 at both ends for the ids outside the range
        self._table: NDArray[np.int64] | None = None
        self._table_base = 0
        if len(self._sorted_ids) and int(self._sorted_ids[0]) >= -(1 << 31) and \
                int(self._sorted_ids[-1]) <= 1 << 31 and \
                int(self._sorted_ids[-1]) - int(self._sorted_ids[0]) <= self.ID_TABLE_SPAN:
            self._table_base = int(self._sorted_ids[0]) - 1
            self._table = np.full(int(self._sorted_ids[-1]) - self._table_base + 2, -1,
                                  dtype=np.int64)
            self._table[self._sorted_ids - self._table_base] = self._sorted_index
        #: reflector positions as complex numbers x + iy, m
        self.z = self.x + 1j * self.y
        #: half the distance from each reflector to its nearest neighbour, m: a point closer
        #: than this to a reflector has that reflector as its nearest
        if len(self.x) > 1:
            sep = np.abs(self.z[:, None] - self.z[None, :])
            np.fill_diagonal(sep, np.inf)
            self.half_sep = 0.5 * sep.min(axis=1)
        else:
            self.half_sep = np.full(len(self.x), np.inf)
        self._cell = cell
        self._margin = margin
        self._grid: tuple[float, float, int, int, list[NDArray[np.int64]]] | None = None
        self._pairs: tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]] | None = None

    def pair_table(self) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64]]:
        """Every ordered pair of distinct reflectors ``(i, j)`` sorted by their distance: the
        distances (m) and the two indices, made once."""
        if self._pairs is None:
            i, j = np.nonzero(~np.eye(len(self.z), dtype=bool))
            d = np.abs(self.z[j] - self.z[i])
            order = np.argsort(d, kind="stable")
            self._pairs = (d[order], i[order].astype(np.int64), j[order].astype(np.int64))
        return self._pairs

    def __len__(self) -> int:
        return len(self.reflectors)

    def index_of(self, ids: NDArray[np.int64]) -> NDArray[np.int64]:
        """Map indices of reflector ids; -1 for an unknown or absent id."""
        ids = np.asarray(ids, dtype=np.int64)
        if self._table is not None:
            # an id outside the range lands (clipped) on an end entry, -1; with the map's ids
            # within +-2**31, an int64 id the subtraction wraps round lands on one as well
            return self._table.take(ids - self._table_base, mode="clip")
        known = self._sorted_ids
        if len(known) == 0:
            return np.full(ids.shape, -1, dtype=np.int64)
        at = np.minimum(np.searchsorted(known, ids), len(known) - 1)
        return np.where(known[at] == ids, self._sorted_index[at], -1).astype(np.int64)

    def _build_grid(self) -> tuple[float, float, int, int, list[NDArray[np.int64]]]:
        c = self._cell
        x0 = float(self.x.min()) - self._margin
        y0 = float(self.y.min()) - self._margin
        nx = math.ceil((float(self.x.max()) + self._margin - x0) / c) + 1
        ny = math.ceil((float(self.y.max()) + self._margin - y0) / c) + 1
        cx = x0 + (np.arange(nx) + 0.5) * c
        cy = y0 + (np.arange(ny) + 0.5) * c
        gx, gy = np.meshgrid(cx, cy, indexing="ij")
        d = np.sqrt((gx.ravel()[:, None] - self.x) ** 2 + (gy.ravel()[:, None] - self.y) ** 2)
        near = d <= d.min(axis=1, keepdims=True) + c * math.sqrt(2.0) + 1e-9
        width = int(near.sum(axis=1).max())
        order = np.argsort(np.where(near, d, np.inf), axis=1)[:, :width]
        # pad with the nearest candidate so every cell has ``width`` entries
        valid = np.take_along_axis(near, order, axis=1)
        table = np.where(valid, order, order[:, :1])
        self._grid = (x0, y0, nx, ny, [np.ascontiguousarray(table[:, c])
                                       for c in range(table.shape[1])])
        return self._grid

    def nearest(self, px: NDArray[np.float64], py: NDArray[np.float64]
                ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        """Index of the nearest reflector to each point and the squared distance to it (m^2).

        Works on any array shape.
        """
        shape = np.shape(px)
        fx, fy = np.ravel(px), np.ravel(py)
        if len(self.x) <= 4 or fx.size * len(self.x) <= 50_000:
            idx, d2 = self._brute(fx, fy)
            return idx.reshape(shape), d2.reshape(shape)
        x0, y0, nx, ny, columns = self._grid or self._build_grid()
        inv = 1.0 / self._cell
        ix = np.floor((fx - x0) * inv).astype(np.int64)
        iy = np.floor((fy - y0) * inv).astype(np.int64)
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        cells = np.where(inside, ix * ny + iy, 0)
        idx = columns[0][cells]
        ex, ey = self.x[idx] - fx, self.y[idx] - fy
        d2 = ex * ex + ey * ey
        for col in columns[1:]:
            j = col[cells]
            ex, ey = self.x[j] - fx, self.y[j] - fy
            dj = ex * ex + ey * ey
            better = dj < d2
            idx = np.where(better, j, idx)
            d2 = np.where(better, dj, d2)
        if not inside.all():
            out = np.nonzero(~inside)[0]
            bi, bd = self._brute(fx[out], fy[out])
            idx[out], d2[out] = bi, bd
        return idx.reshape(shape), d2.reshape(shape)

    def nearest_two(self, px: NDArray[np.float64], py: NDArray[np.float64]
                    ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
        """Index of the nearest reflector to each point (1-D arrays, m; the first of equals),
        the squared distance to it and to the second nearest (m^2; infinite for a map of one
        reflector), searching the whole map."""
        fx = np.asarray(px, dtype=np.float64)
        fy = np.asarray(py, dtype=np.float64)
        n = fx.size
        idx = np.zeros(n, dtype=np.int64)
        best = np.full(n, np.inf)
        second = np.full(n, np.inf)
        if len(self.x) == 0:
            return idx, best, second
        block = max(1, 2_000_000 // len(self.x))
        for a in range(0, n, block):
            ex = self.x - fx[a:a + block, None]
            ey = self.y - fy[a:a + block, None]
            dd = ex * ex + ey * ey
            j = np.argmin(dd, axis=1)
            rows = np.arange(len(j))
            idx[a:a + block] = j
            best[a:a + block] = dd[rows, j]
            if dd.shape[1] > 1:
                second[a:a + block] = np.partition(dd, 1, axis=1)[:, 1]
        return idx, best, second

    def nearest_distance(self, z: NDArray[np.complex128]) -> NDArray[np.float64]:
        """Distance (m) from each point (complex ``x + iy``, 1-D) to its nearest reflector."""
        if z.size * len(self.z) > 1_000_000:
            _, d2 = self.nearest(z.real, z.imag)
            return np.sqrt(d2)
        # (J, n): the reduction runs across rows, which numpy does fastest
        out: NDArray[np.float64] = np.abs(self.z[:, None] - z[None, :]).min(axis=0)
        return out

    def _brute(self, fx: NDArray[np.float64], fy: NDArray[np.float64]
               ) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
        n = fx.size
        idx = np.empty(n, dtype=np.int64)
        d2 = np.empty(n, dtype=np.float64)
        block = max(1, 2_000_000 // max(1, len(self.x)))
        for a in range(0, n, block):
            ex = fx[a:a + block, None] - self.x
            ey = fy[a:a + block, None] - self.y
            dd = ex * ex + ey * ey
            j = np.argmin(dd, axis=1)
            idx[a:a + block] = j
            d2[a:a + block] = dd[np.arange(len(j)), j]
        return idx, d2


OBSERVATION_SOURCES = ("auto", "scans", "poses", "both")


@dataclass(frozen=True)
class SourceParams:
    """Which observations an estimator uses and how they are prepared (see :func:`sources`)."""

    observations: str = param("auto", "observation source: auto (reflector scans when the log "
                              "has them, else NAV poses), scans, poses, or both",
                              choices=OBSERVATION_SOURCES)
    use_ids: bool = param(True, "use a reflector's id when the scan gives one that is in the "
                          "map and its layout reflector is inside the association gate (a wrong "
                          "id from the device is set aside); otherwise, and when false, "
                          "associate by nearest neighbour inside the gate")
    min_range_m: float = param(0.0, "ignore reflectors measured closer than this, m",
                               minimum=0.0)
    max_range_m: float = param(math.inf, "ignore reflectors measured farther than this, m",
                               minimum=0.0)
    deskew: bool = param(True, "de-skew each reflector by its time within the revolution, "
                         "along the odometry")
    pose_latency_s: float = param(0.0, "age of a NAV pose when it is received; the pose is "
                                  "applied at receive time minus this (with the rotating-head "
                                  "pose model: the age when the log does not determine it, "
                                  "plus one head period when the vehicle states no pose age), "
                                  "s", minimum=0.0, maximum=2.0)
    pose_gate: bool = param(True, "leave out NAV poses that jump farther than the odometry "
                            "allows since the last accepted one (docs/reading.md)")


def sources(observations: str, has_scans: bool, has_poses: bool) -> tuple[bool, bool]:
    """``(use scans, use poses)`` for an ``observations`` setting and what a log holds."""
    if observations == "auto":
        return has_scans, not has_scans and has_poses
    if observations == "scans":
        return has_scans, False
    if observations == "poses":
        return False, has_poses
    return has_scans, has_poses
