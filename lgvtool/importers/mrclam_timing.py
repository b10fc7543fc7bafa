"""How late the MRCLAM robots carry out their commanded velocities, measured without ground truth.

The odometry of the dataset is the robot's *commanded* velocities, stamped when commanded; the
robot follows them some 0.2 s later. Between two camera frames that see the same landmark, its
bearing changes by minus the robot's turn (plus a small parallax from its travel), so the delay
shows in the camera data alone: :func:`odometry_delay` takes, for each candidate delay, the
commanded turn and travel between the two frame times moved back by that delay, predicts the
bearing change from them, and keeps the delay with the least RMS residual over all such pairs
of frames. Nothing here reads the ground truth.

Pure: arrays in, numbers out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle

FloatArray = NDArray[np.float64]

MAX_DELAY_S = 0.6
"""Largest delay considered, s."""
STEP_S = 0.01
"""Spacing of the candidate delays, s."""
MAX_PAIR_S = 0.6
"""Two sightings of a landmark at most this far apart form a pair, s."""
MAX_BEARING_CHANGE_RAD = 0.3
"""Pairs whose bearing changes by more than this are left out (a misread barcode), rad."""
MIN_PAIRS = 100
"""Fewer pairs than this give no estimate."""


@dataclass(frozen=True)
class DelayEstimate:
    """The delay between the commands' stamps and the motion the camera sees.

    ``delay_s``: the delay with the least residual, s (0 when there are too few ``pairs`` to
    measure it); ``pairs``: pairs of sightings compared; ``rms_rad``: RMS bearing-change
    residual at that delay (None when not measured) and ``rms_at_zero_rad`` without a delay
    (None without pairs), rad.
    """

    delay_s: float
    pairs: int
    rms_rad: float | None
    rms_at_zero_rad: float | None


def _cumulative(t: FloatArray, rate: FloatArray) -> FloatArray:
    """The integral of a zero-order-hold ``rate`` at the times ``t`` (0 at ``t[0]``)."""
    return np.concatenate([[0.0], np.cumsum(rate[:-1] * np.diff(t))])


def odometry_delay(odo_t: FloatArray, v: FloatArray, omega: FloatArray, obs_t: FloatArray,
                   landmark: NDArray[np.int64], rng: FloatArray, bearing: FloatArray, *,
                   max_delay_s: float = MAX_DELAY_S, step_s: float = STEP_S,
                   max_pair_s: float = MAX_PAIR_S, min_pairs: int = MIN_PAIRS) -> DelayEstimate:
    """Measure how long after its stamp a commanded velocity takes effect.

    :param odo_t: odometry stamps, s (ascending; any origin, the same as ``obs_t``).
    :param v: commanded speed, m/s, held until the next stamp.
    :param omega: commanded yaw rate, rad/s, held until the next stamp.
    :param obs_t: landmark observation times, s (non-decreasing).
    :param landmark: the landmark of each observation.
    :param rng: measured range, m.
    :param bearing: measured bearing, rad (counter-clockwise from the heading).
    :returns: the delay in ``[0, max_delay_s]`` whose delayed commands explain the bearing
        changes of consecutive sightings of a landmark (at most ``max_pair_s`` apart) best, on
        a grid of ``step_s`` refined by a parabola through the least three residuals.
    """
    odo_t = np.asarray(odo_t, dtype=np.float64)
    obs_t = np.asarray(obs_t, dtype=np.float64)
    if len(odo_t) < 2 or len(obs_t) < 2:
        return DelayEstimate(0.0, 0, None, None)
    landmark = np.asarray(landmark)
    rng = np.asarray(rng, dtype=np.float64)
    bearing = np.asarray(bearing, dtype=np.float64)
    order = np.lexsort((obs_t, landmark))
    same = landmark[order][1:] == landmark[order][:-1]
    dt = np.diff(obs_t[order])
    pair = same & (dt > 0.0) & (dt <= max_pair_s)
    first, second = order[:-1][pair], order[1:][pair]
    db = wrap_angle(bearing[second] - bearing[first])
    keep = np.abs(db) <= MAX_BEARING_CHANGE_RAD
    first, second, db = first[keep], second[keep], db[keep]
    n = len(db)
    if n == 0:
        return DelayEstimate(0.0, 0, None, None)
    turn = _cumulative(odo_t, np.asarray(omega, dtype=np.float64))
    travel = _cumulative(odo_t, np.asarray(v, dtype=np.float64))
    # parallax: travelling d forward turns the bearing of a landmark at (r, b) by d sin(b) / r
    parallax = np.sin(bearing[first]) / np.maximum(rng[first], 1e-3)
    t1, t2 = obs_t[first], obs_t[second]

    def rms(delay: float) -> float:
        dturn = np.interp(t2 - delay, odo_t, turn) - np.interp(t1 - delay, odo_t, turn)
        dtravel = np.interp(t2 - delay, odo_t, travel) - np.interp(t1 - delay, odo_t, travel)
        e = db + dturn - dtravel * parallax
        return float(np.sqrt(np.mean(e * e)))

    if n < min_pairs:
        return DelayEstimate(0.0, n, None, rms(0.0))
    candidates = np.arange(0.0, max_delay_s + 0.5 * step_s, step_s)
    costs = np.array([rms(float(d)) for d in candidates])
    k = int(np.argmin(costs))
    best = float(candidates[k])
    if 0 < k < len(candidates) - 1:
        a, b, c = costs[k - 1], costs[k], costs[k + 1]
        curvature = a - 2.0 * b + c
        if curvature > 0.0:
            best += 0.5 * step_s * (a - c) / curvature
    best = round(float(min(max(best, 0.0), max_delay_s)), 4)
    return DelayEstimate(best, n, rms(best), float(costs[0]))


def delay_ns(delay_s: float) -> int:
    """A delay in s as integer ns, rounded to the microsecond like every MRCLAM stamp."""
    return math.floor(delay_s * 1e6 + 0.5) * 1000
