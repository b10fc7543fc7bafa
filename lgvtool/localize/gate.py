"""The plausibility gate on NAV poses: a pose that jumps farther than the odometry allows
since the last accepted pose is left out (docs/reading.md).

The NAV200's 8-bit XOR lets about 6 % of 2-bit corruptions of a telegram through, and such a
telegram is delivered as a valid pose. The gate predicts each pose from the last accepted one
and the odometry between them and rejects a pose whose position or heading differs from the
prediction by more than the NAV's noise and the odometry's drift can explain, and differs
as much from the next pose (so a small error of the last accepted pose does not make a good
pose look wrong). Pure: arrays
in, a mask out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle, wrap_scalar

FloatArray = NDArray[np.float64]

#: position tolerance (m): at least GATE_POSITION_M, else GATE_POSITION_MEDIANS times the
#: median deviation of consecutive poses in the log (the NAV's own noise), plus drift per metre
GATE_POSITION_M = 0.20
GATE_POSITION_MEDIANS = 9.0
GATE_POSITION_PER_M = 0.05
#: heading tolerance (rad): at least GATE_HEADING_RAD, else GATE_HEADING_MEDIANS times the
#: median deviation, plus drift per radian turned and per metre travelled
GATE_HEADING_RAD = math.radians(2.5)
GATE_HEADING_MEDIANS = 4.0
GATE_HEADING_PER_RAD = 0.05
GATE_HEADING_PER_M = math.radians(1.0)
#: after this many rejections in a row the next pose is accepted as a new anchor (the vehicle
#: was moved, or the first accepted pose was the corrupt one)
GATE_REANCHOR = 5


@dataclass(frozen=True)
class GateResult:
    """Which poses passed (``accepted``); for each rejected one its index, position and heading
    deviation from the prediction (m, rad) and the tolerances it exceeded; and per pose its
    deviations (``position_dev`` m, ``heading_dev`` rad; NaN where not judged)."""

    accepted: NDArray[np.bool_]
    rejected: list[tuple[int, float, float, float, float]]
    position_dev: FloatArray
    heading_dev: FloatArray


def gate_poses(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
               valid: NDArray[np.bool_], odometry: tuple[FloatArray, ...] | None,
               nav_x: float, nav_y: float) -> GateResult:
    """Gate the NAV head poses ``(x, y, heading)`` (m, rad) at times ``t`` (s).

    :param valid: the poses to judge (others are neither accepted nor counted).
    :param odometry: the odometry pose of O ``(x, y, th, cum_dist, cum_rot)`` at each ``t``
        (:meth:`MotionTrack.poses_at`), or None: without odometry every valid pose passes.
    :param nav_x: head position in the vehicle frame, forward (m); ``nav_y`` left (m).
    """
    n = len(t)
    accepted = np.zeros(n, dtype=bool)
    rejected: list[tuple[int, float, float, float, float]] = []
    pdev = np.full(n, np.nan)
    hdev = np.full(n, np.nan)
    if odometry is None:
        accepted[:] = valid
        return GateResult(accepted, rejected, pdev, hdev)
    ox, oy, oth, odist, orot = (np.asarray(a, dtype=np.float64).tolist() for a in odometry)
    xs, ys, hs = x.tolist(), y.tolist(), heading.tolist()

    def deviation(k: int, last: int) -> tuple[float, float, float, float]:
        """Position and heading deviation (m, rad) of pose ``k`` from its prediction from pose
        ``last`` along the odometry, and the distance (m) and rotation (rad) between them."""
        c0, s0 = math.cos(oth[last]), math.sin(oth[last])
        ex, ey = ox[k] - ox[last], oy[k] - oy[last]
        bx, by = c0 * ex + s0 * ey, -s0 * ex + c0 * ey
        dth = oth[k] - oth[last]
        # the head pose at ``last`` moved along the odometry: head -> O, move, O -> head
        h0 = hs[last]
        c, s = math.cos(h0), math.sin(h0)
        o_x = xs[last] - (c * nav_x - s * nav_y) + c * bx - s * by
        o_y = ys[last] - (s * nav_x + c * nav_y) + s * bx + c * by
        h1 = h0 + dth
        px = o_x + math.cos(h1) * nav_x - math.sin(h1) * nav_y
        py = o_y + math.sin(h1) * nav_x + math.cos(h1) * nav_y
        return (math.hypot(xs[k] - px, ys[k] - py), abs(wrap_scalar(hs[k] - h1)),
                abs(odist[k] - odist[last]), abs(orot[k] - orot[last]))

    judged = np.nonzero(valid)[0].tolist()
    # each valid pose against the valid one before it, all at once; the NAV's own noise is
    # their median deviation
    pairs = _consecutive(np.asarray(judged, dtype=np.int64), x, y, heading, odometry,
                         nav_x, nav_y)
    base_pos, base_head = GATE_POSITION_M, GATE_HEADING_RAD
    if len(judged) > 1:
        base_pos = max(base_pos, GATE_POSITION_MEDIANS * float(np.median(pairs[0])))
        base_head = max(base_head, GATE_HEADING_MEDIANS * float(np.median(pairs[1])))
    after_previous = [tuple(row) for row in np.stack(pairs, axis=1).tolist()]
    last = -1
    misses = 0
    for i, k in enumerate(judged):
        if last < 0 or misses >= GATE_REANCHOR:
            accepted[k] = True
            last, misses = k, 0
            continue
        # against the last accepted pose (the one before unless that was left out)
        dpos, dhead, dist, rot = (after_previous[i - 1] if last == judged[i - 1]
                                  else deviation(k, last))
        pdev[k], hdev[k] = dpos, dhead
        tol_pos = base_pos + GATE_POSITION_PER_M * dist
        tol_head = base_head + GATE_HEADING_PER_RAD * rot + GATE_HEADING_PER_M * dist
        if dpos <= tol_pos and dhead <= tol_head:
            accepted[k] = True
            last, misses = k, 0
            continue
        # the pose disagrees with the last accepted one: it is left out only if it disagrees
        # with the next pose too (else the accepted one was the odd one, within tolerance)
        if i + 1 < len(judged):
            npos, nhead, ndist, nrot = deviation(k, judged[i + 1])
            if (npos <= base_pos + GATE_POSITION_PER_M * ndist
                    and nhead <= base_head + GATE_HEADING_PER_RAD * nrot
                    + GATE_HEADING_PER_M * ndist):
                accepted[k] = True
                last, misses = k, 0
                continue
        rejected.append((k, dpos, dhead, tol_pos, tol_head))
        misses += 1
    return GateResult(accepted, rejected, pdev, hdev)


def _consecutive(idx: NDArray[np.int64], x: FloatArray, y: FloatArray, heading: FloatArray,
                 odometry: tuple[FloatArray, ...], nav_x: float, nav_y: float
                 ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Position and heading deviation (m, rad), distance (m) and rotation (rad) of each pose
    ``idx[1:]`` from its prediction from the pose before it in ``idx`` (as ``deviation`` in
    :func:`gate_poses`, for all pairs at once)."""
    ox, oy, oth, odist, orot = (np.asarray(a, dtype=np.float64) for a in odometry)
    a, k = idx[:-1], idx[1:]
    c0, s0 = np.cos(oth[a]), np.sin(oth[a])
    ex, ey = ox[k] - ox[a], oy[k] - oy[a]
    bx, by = c0 * ex + s0 * ey, -s0 * ex + c0 * ey
    h0 = heading[a]
    c, s = np.cos(h0), np.sin(h0)
    o_x = x[a] - (c * nav_x - s * nav_y) + c * bx - s * by
    o_y = y[a] - (s * nav_x + c * nav_y) + s * bx + c * by
    h1 = h0 + (oth[k] - oth[a])
    px = o_x + np.cos(h1) * nav_x - np.sin(h1) * nav_y
    py = o_y + np.sin(h1) * nav_x + np.cos(h1) * nav_y
    dh = np.abs(wrap_angle(heading[k] - h1))
    return (np.hypot(x[k] - px, y[k] - py), dh, np.abs(odist[k] - odist[a]),
            np.abs(orot[k] - orot[a]))
