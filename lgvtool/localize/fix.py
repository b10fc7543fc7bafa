"""A first pose from one observation, to start the estimators (and to re-draw a lost particle
filter around).

From a NAV pose: eq. 5. From a reflector scan (:func:`scan_fix`): the reflectors' ids, checked,
else the scan's own geometry matched on the layout, so that a scan without ids (a NAV200's,
or a device that matched nothing) or with a wrong id fixes the pose too:

1. Two or more reflectors with an id in the layout: the least-squares alignment of their
   measured points on their layout reflectors. It is the fix when every one of them lies
   within its inlier radius of its reflector at that pose (the ids agree with each other);
   otherwise at least one id is wrong and the scan is fixed as if it had none, its ids
   breaking ties.
2. Without (usable) ids: every pair of measured points at least ``FIX_MIN_BASELINE_M`` apart
   whose distance matches that of a pair of layout reflectors (within the two points' inlier
   radii) gives a pose hypothesis (both orders); each hypothesis counts the measured points
   within 3 inlier radii of a layout reflector; the best few (one per 0.25 m x 0.25 m x
   0.05 rad cell) are refined by least squares on their inliers (radii 3, 1.5, then 1 x) and
   scored by their inliers at 1 x, then by how many inliers agree with their ids, then by
   their normalised squared residuals. The best is the fix when it matches at least
   ``FIX_MIN_INLIERS`` reflectors and no distinct pose (``FIX_DISTINCT_M``,
   ``FIX_DISTINCT_RAD`` away) matches as many (a symmetric layout, or a scan too poor to
   tell: no fix).

A measured point's inlier radius is ``max(FIX_FLOOR_M, FIX_GATE_SIGMAS x the larger of its
range noise hypot(sigma_range, sigma_range_per_m x range) and cross-range noise range x
sigma_bearing)``, m, with the estimator's own noise when it has one (``noise``), else
:data:`FIX_NOISE`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle, wrap_scalar
from lgvtool.localize.geometry import nav_to_o, pose_from_correspondences
from lgvtool.localize.observations import PoseObservation, ReflectorMap, ScanObservation

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: measurement noise of a fix whose estimator has none of its own: range m, range per metre
#: m/m, bearing rad (the filters' defaults)
FIX_NOISE = (0.02, 0.0, 0.005)
#: a measured point matches a layout reflector within this many standard deviations
#: (the square root of the chi-square quantile of 0.9999 with 2 degrees of freedom)
FIX_GATE_SIGMAS = 4.3
#: the least inlier radius, m: the layout's survey error, a cylinder's apparent centre and the
#: odometry's error within a revolution, which the measurement noise does not hold
FIX_FLOOR_M = 0.05
#: a fix from the scan's geometry alone needs this many reflectors matched on the layout
FIX_MIN_INLIERS = 3
#: measured pairs closer than this (m) hypothesise no pose (their direction is too uncertain)
FIX_MIN_BASELINE_M = 0.5
#: pose hypotheses weighed at most (the longest measured pairs first)
FIX_MAX_HYPOTHESES = 20_000
#: hypotheses refined at most (the best by their loose inlier count, one per cell)
FIX_REFINE = 24
#: two fixes this far apart (m, or rad in heading) are distinct poses
FIX_DISTINCT_M = 0.5
FIX_DISTINCT_RAD = 0.1


@dataclass(frozen=True)
class ScanFix:
    """A pose of O (``x``, ``y`` m, ``heading`` rad) fixed by a scan, the layout index each
    measured reflector was matched with (-1: none) and how many were."""

    x: float
    y: float
    heading: float
    index: IntArray
    inliers: int

    @property
    def pose(self) -> tuple[float, float, float]:
        """``(x, y, heading)``, m, m, rad."""
        return self.x, self.y, self.heading


def inlier_radii(obs: ScanObservation,
                 noise: tuple[float, float, float] | None = None) -> FloatArray:
    """The inlier radius of each reflector of ``obs`` (m; the module doc), with ``noise``
    (range m, range per metre m/m, bearing rad; default :data:`FIX_NOISE`)."""
    sr, spm, sb = noise if noise is not None else FIX_NOISE
    r = obs.ranges
    sigma = np.maximum(np.hypot(sr, spm * r), r * sb)
    out: FloatArray = np.maximum(FIX_FLOOR_M, FIX_GATE_SIGMAS * sigma)
    return out


def pose_fix(obs: PoseObservation | ScanObservation, nav_x: float, nav_y: float,
             rmap: ReflectorMap, *, use_ids: bool = True,
             noise: tuple[float, float, float] | None = None
             ) -> tuple[float, float, float] | None:
    """Pose of O (m, m, rad) from a NAV pose (eq. 5), or from a scan (:func:`scan_fix`);
    None when the observation does not fix the pose."""
    if isinstance(obs, PoseObservation):
        x, y, th = nav_to_o(obs.x, obs.y, obs.heading, nav_x, nav_y)
        return float(x), float(y), float(th)
    fix = scan_fix(obs, rmap, use_ids=use_ids, noise=noise)
    return None if fix is None else fix.pose


def _world(pose: tuple[float, float, float], q: NDArray[np.complex128]
           ) -> NDArray[np.complex128]:
    """Body-frame points ``q`` (complex, m) put into the world at ``pose`` (m, m, rad)."""
    out: NDArray[np.complex128] = complex(pose[0], pose[1]) + \
        complex(math.cos(pose[2]), math.sin(pose[2])) * q
    return out


def scan_fix(obs: ScanObservation, rmap: ReflectorMap, *, use_ids: bool = True,
             noise: tuple[float, float, float] | None = None) -> ScanFix | None:
    """The pose of O a scan fixes on the layout ``rmap`` (the module doc), or None.

    :param use_ids: use the reflectors' ids (checked); False: the geometry alone.
    :param noise: the estimator's measurement noise (range m, range per metre m/m, bearing
        rad) for the inlier radii; None: :data:`FIX_NOISE`.
    """
    k = len(obs)
    if k < 2 or len(rmap) == 0:
        return None
    radius = inlier_radii(obs, noise)
    known = obs.map_index(rmap) if use_ids else np.full(k, -1, dtype=np.int64)
    has = known >= 0
    if int(has.sum()) >= 2:
        j = known[has]
        pose = pose_from_correspondences(obs.qx[has], obs.qy[has], rmap.x[j], rmap.y[j])
        if pose is not None and bool(np.all(
                np.abs(rmap.z[j] - _world(pose, obs.q[has])) <= radius[has])):
            return ScanFix(*pose, np.where(has, known, -1), int(has.sum()))
    if k < FIX_MIN_INLIERS or len(rmap) < 2:
        return None
    return _geometric_fix(obs.q, radius, known, rmap)


def _hypotheses(q: NDArray[np.complex128], radius: FloatArray, rmap: ReflectorMap
                ) -> tuple[NDArray[np.complex128], FloatArray]:
    """Pose hypotheses (position complex m, heading rad) from every measured pair at least
    :data:`FIX_MIN_BASELINE_M` apart matched on a layout pair of the same distance (within the
    two inlier radii), the longest measured pairs first, at most
    :data:`FIX_MAX_HYPOTHESES`."""
    k1, k2 = np.triu_indices(len(q), 1)
    dq = np.abs(q[k2] - q[k1])
    keep = dq >= FIX_MIN_BASELINE_M
    k1, k2, dq = k1[keep], k2[keep], dq[keep]
    order = np.argsort(-dq, kind="stable")
    dist, li, lj = rmap.pair_table()
    pos: list[NDArray[np.complex128]] = []
    head: list[FloatArray] = []
    total = 0
    for p in order.tolist():
        a, b = int(k1[p]), int(k2[p])
        tol = float(radius[a] + radius[b])
        lo = int(np.searchsorted(dist, dq[p] - tol, side="left"))
        hi = int(np.searchsorted(dist, dq[p] + tol, side="right"))
        if hi <= lo:
            continue
        la, lb = rmap.z[li[lo:hi]], rmap.z[lj[lo:hi]]
        rot = (lb - la) / (q[b] - q[a])
        rot = rot / np.abs(rot)
        pos.append(0.5 * (la + lb) - rot * (0.5 * (q[a] + q[b])))
        head.append(np.angle(rot))
        total += hi - lo
        if total >= FIX_MAX_HYPOTHESES:
            break
    if not pos:
        return np.zeros(0, dtype=np.complex128), np.zeros(0)
    return np.concatenate(pos)[:FIX_MAX_HYPOTHESES], np.concatenate(head)[:FIX_MAX_HYPOTHESES]


def _align(q: NDArray[np.complex128], target: NDArray[np.complex128],
           use: NDArray[np.bool_]) -> tuple[NDArray[np.complex128], FloatArray,
                                            NDArray[np.bool_]]:
    """Least-squares rigid poses (position complex m, heading rad) mapping the body-frame
    points ``q`` (K,) onto ``target`` (C, K), each row with the points ``use`` (C, K) (2-D
    Kabsch, as :func:`lgvtool.localize.geometry.pose_from_correspondences`, for C sets at
    once), and which rows were solvable (two distinct points or more)."""
    w = use.astype(np.float64)
    n = w.sum(axis=1)
    safe = np.maximum(n, 1.0)
    mq = (w * q[None, :]).sum(axis=1) / safe
    mt = (w * target).sum(axis=1) / safe
    cross = (w * np.conj(q[None, :] - mq[:, None]) * (target - mt[:, None])).sum(axis=1)
    ok = (n >= 2) & (np.abs(cross) >= 1e-9)
    rot = np.where(ok, cross / np.where(ok, np.abs(cross), 1.0), 1.0)
    return mt - rot * mq, np.angle(rot), ok


def _geometric_fix(q: NDArray[np.complex128], radius: FloatArray, known: IntArray,
                   rmap: ReflectorMap) -> ScanFix | None:
    """The fix from the scan's geometry (step 2 of the module doc)."""
    pos, head = _hypotheses(q, radius, rmap)
    if len(pos) == 0:
        return None
    world = pos[:, None] + np.exp(1j * head)[:, None] * q[None, :]
    _, d2 = rmap.nearest(world.real, world.imag)
    loose = (d2 <= (3.0 * radius) ** 2).sum(axis=1)
    good = loose >= FIX_MIN_INLIERS
    if not good.any():
        return None
    # one hypothesis per cell of 0.25 m x 0.25 m x 0.05 rad, the best counts first
    idx = np.nonzero(good)[0]
    idx = idx[np.argsort(-loose[idx], kind="stable")]
    cells = np.stack([np.floor(pos[idx].real / 0.25), np.floor(pos[idx].imag / 0.25),
                      np.floor((wrap_angle(head[idx]) + math.pi) / 0.05)], axis=1)
    _, first = np.unique(cells, axis=0, return_index=True)
    chosen = idx[np.sort(first)][:FIX_REFINE]
    z, th = pos[chosen], head[chosen]
    alive = np.ones(len(chosen), dtype=bool)
    for factor in (3.0, 1.5, 1.0):
        world = z[:, None] + np.exp(1j * th)[:, None] * q[None, :]
        j, d2 = rmap.nearest(world.real, world.imag)
        inl = d2 <= (factor * radius) ** 2
        z2, th2, ok = _align(q, rmap.z[j], inl)
        z, th = np.where(ok, z2, z), np.where(ok, th2, th)
        alive &= ok
    world = z[:, None] + np.exp(1j * th)[:, None] * q[None, :]
    j, d2 = rmap.nearest(world.real, world.imag)
    inl = (d2 <= radius ** 2) & alive[:, None]
    n = inl.sum(axis=1)
    agree = (inl & (j == known[None, :])).sum(axis=1)
    cost = np.where(inl, d2 / radius ** 2, 0.0).sum(axis=1)
    order = np.lexsort((cost, -agree, -n))
    best = int(order[0])
    if n[best] < FIX_MIN_INLIERS:
        return None
    for other in order[1:].tolist():
        if n[other] != n[best] or agree[other] != agree[best]:
            break
        if abs(z[other] - z[best]) > FIX_DISTINCT_M or \
                abs(wrap_scalar(float(th[other] - th[best]))) > FIX_DISTINCT_RAD:
            return None  # as well matched elsewhere: ambiguous
    index = np.where(inl[best], j[best], -1).astype(np.int64)
    return ScanFix(float(z[best].real), float(z[best].imag), wrap_scalar(float(th[best])),
                   index, int(n[best]))
