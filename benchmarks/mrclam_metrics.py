"""Position error on MRCLAM logs the way the dataset's reference EKF is scored (docs/mrclam.md).

The reference figures are position RMSEs against the Vicon ground truth at every odometry step.
lgvtool's replay records an estimate at each observation (camera frame) only; between two
observations an estimator's mean follows the odometry, so :func:`estimates_at_odometry` carries
each estimate forward through the logged commanded velocities (dead reckoning from the posterior
mean) to every odometry time until the next estimate. :func:`position_rmse` then compares with
the ground truth interpolated at those times, where the ground truth exists.

Odometry semantics are those of lgvtool's replay for ``/odom/twist``: each ``(v, omega)`` holds
from its own time until the next message (zero-order hold), and a step of constant ``v`` and
``omega`` is an arc. No motion is assumed before the first or after the last message.

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

TRUTH_MAX_GAP_S = 0.5
"""Ground truth is interpolated only between samples at most this far apart, s."""


def _arc(ds: FloatArray, dth: FloatArray, th0: FloatArray) -> tuple[FloatArray, FloatArray]:
    """World displacement (m, m) of arcs of length ``ds`` (m) turning by ``dth`` (rad) from
    heading ``th0`` (rad): exact at constant curvature."""
    k = ds * np.sinc(dth / (2.0 * math.pi))  # np.sinc(x) = sin(pi x) / (pi x)
    mid = th0 + 0.5 * dth
    return k * np.cos(mid), k * np.sin(mid)


def odometry_track(t: FloatArray, v: FloatArray, omega: FloatArray
                   ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Pose (x m, y m, heading rad, unwrapped) at every odometry time ``t`` (s, ascending) in an
    odometry frame that starts at the origin; ``v`` (m/s) and ``omega`` (rad/s) hold until the
    next time."""
    n = len(t)
    if n == 0:
        return np.zeros(0), np.zeros(0), np.zeros(0)
    dt = np.diff(t)
    ds, dth = v[:-1] * dt, omega[:-1] * dt
    th = np.concatenate([[0.0], np.cumsum(dth)])
    ex, ey = _arc(ds, dth, th[:-1])
    x = np.concatenate([[0.0], np.cumsum(ex)])
    y = np.concatenate([[0.0], np.cumsum(ey)])
    return x, y, th


def track_at(t: FloatArray, v: FloatArray, omega: FloatArray,
             track: tuple[FloatArray, FloatArray, FloatArray], when: FloatArray
             ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Odometry-frame pose (m, m, rad) at arbitrary times ``when`` (s): the track pose at the
    last odometry time before, plus the arc of the command holding then. Before the first
    odometry time the first pose; after the last one the last pose."""
    x, y, th = track
    i = np.searchsorted(t, when, side="right") - 1
    before = i < 0
    last = i >= len(t) - 1
    i = np.clip(i, 0, len(t) - 1)
    dt = np.where(before | last, 0.0, when - t[i])
    ds, dth = v[i] * dt, omega[i] * dt
    ex, ey = _arc(ds, dth, th[i])
    return x[i] + ex, y[i] + ey, th[i] + dth


def estimates_at_odometry(estimate: pd.DataFrame, odometry: pd.DataFrame) -> pd.DataFrame:
    """The estimate carried to every odometry time from its first row on.

    :param estimate: ``t`` (s), ``x``, ``y`` (m), ``heading`` (rad), ascending ``t``; optional
        ``scale_v``, ``scale_w`` (dimensionless) and ``drift`` (rad/m): the odometry
        calibration the estimator holds at that row (an EKF with ``odometry_scales`` or
        ``odometry_drift``), applied until the next row as the estimator's own prediction does:
        ``v' = scale_v v``, ``omega' = scale_w omega + drift |v|``. Without them the commands
        are taken as they are.
    :param odometry: ``t`` (s), ``v`` (m/s), ``omega`` (rad/s), ascending ``t``.
    :returns: ``t`` (s, the odometry times at or after the first estimate), ``x``, ``y`` (m),
        ``heading`` (rad): the latest estimate at or before each time, moved by the odometry
        since that estimate.
    """
    te = estimate["t"].to_numpy(dtype=np.float64)
    to = odometry["t"].to_numpy(dtype=np.float64)
    cols = ["t", "x", "y", "heading"]
    if len(te) == 0 or len(to) == 0:
        return pd.DataFrame({c: np.zeros(0) for c in cols})
    base = to[0]  # relative times: Unix seconds lose precision in products
    te, to = te - base, to - base
    ne, no = len(te), len(to)
    # one track over the odometry and the estimate times together: each interval moves by the
    # command holding then (none before the first or after the last odometry row), scaled by
    # the scales of the estimate it follows
    tm = np.concatenate([to, te])
    order = np.argsort(tm, kind="stable")
    where = np.empty(no + ne, dtype=np.int64)
    where[order] = np.arange(no + ne)
    tm = tm[order]
    cmd = np.searchsorted(to, tm, side="right") - 1
    moving = (cmd >= 0) & (cmd < no - 1)
    cmd = np.clip(cmd, 0, no - 1)
    v = np.where(moving, odometry["v"].to_numpy(dtype=np.float64)[cmd], 0.0)
    w = np.where(moving, odometry["omega"].to_numpy(dtype=np.float64)[cmd], 0.0)
    follows = np.searchsorted(te, tm, side="right") - 1
    row = np.clip(follows, 0, ne - 1)

    def per_interval(col: str, default: float) -> FloatArray:
        if col not in estimate.columns:
            return np.full(len(tm), default)
        return np.where(follows >= 0, estimate[col].to_numpy(dtype=np.float64)[row], default)

    # heading drift per commanded metre, then the scales
    w = per_interval("scale_w", 1.0) * w + per_interval("drift", 0.0) * np.abs(v)
    v = per_interval("scale_v", 1.0) * v
    dt = np.diff(tm)
    ds, dth = v[:-1] * dt, w[:-1] * dt
    th = np.concatenate([[0.0], np.cumsum(dth)])
    ex_, ey_ = _arc(ds, dth, th[:-1])
    x = np.concatenate([[0.0], np.cumsum(ex_)])
    y = np.concatenate([[0.0], np.cumsum(ey_)])
    sel = to >= te[0]
    tj = to[sel]
    k = np.searchsorted(te, tj, side="right") - 1  # the estimate each odometry time follows
    pe = where[no + k]  # track node of estimate k
    qj = where[:no][sel]  # track node of each odometry time
    # body-frame motion from estimate k's time to the odometry time, composed onto estimate k
    c, s = np.cos(th[pe]), np.sin(th[pe])
    ddx, ddy = x[qj] - x[pe], y[qj] - y[pe]
    bx, by = c * ddx + s * ddy, -s * ddx + c * ddy
    dh = th[qj] - th[pe]
    ex = estimate["x"].to_numpy(dtype=np.float64)[k]
    ey = estimate["y"].to_numpy(dtype=np.float64)[k]
    eh = estimate["heading"].to_numpy(dtype=np.float64)[k]
    ce, se = np.cos(eh), np.sin(eh)
    heading = np.remainder(eh + dh + math.pi, 2.0 * math.pi) - math.pi
    return pd.DataFrame({"t": tj + base, "x": ex + ce * bx - se * by,
                         "y": ey + se * bx + ce * by, "heading": heading})


def position_rmse(estimate: pd.DataFrame, truth: pd.DataFrame,
                  max_gap_s: float = TRUTH_MAX_GAP_S) -> tuple[float, int]:
    """Position RMSE (m) of ``estimate`` [t s, x m, y m] against ``truth`` [t, x, y] linearly
    interpolated at the estimate times, and the number of rows compared. Rows outside the ground
    truth's span, or inside a ground-truth gap longer than ``max_gap_s`` (s), are left out."""
    tt = truth["t"].to_numpy(dtype=np.float64)
    te = estimate["t"].to_numpy(dtype=np.float64)
    if len(tt) < 2 or len(te) == 0:
        return math.nan, 0
    j = np.clip(np.searchsorted(tt, te, side="right"), 1, len(tt) - 1)
    use = (te >= tt[0]) & (te <= tt[-1]) & ((tt[j] - tt[j - 1]) <= max_gap_s)
    if not use.any():
        return math.nan, 0
    t0 = tt[0]
    x = np.interp(te[use] - t0, tt - t0, truth["x"].to_numpy(dtype=np.float64))
    y = np.interp(te[use] - t0, tt - t0, truth["y"].to_numpy(dtype=np.float64))
    dx = estimate["x"].to_numpy(dtype=np.float64)[use] - x
    dy = estimate["y"].to_numpy(dtype=np.float64)[use] - y
    return float(np.sqrt(np.mean(dx * dx + dy * dy))), int(use.sum())


def truth_at(truth: pd.DataFrame, when: FloatArray) -> pd.DataFrame:
    """Ground truth [t s, x m, y m, heading rad] linearly interpolated at ``when`` (s; the
    heading unwrapped first), as an estimate table: the perfect estimator."""
    tt = truth["t"].to_numpy(dtype=np.float64)
    t0 = tt[0]
    rel = np.asarray(when, dtype=np.float64) - t0
    heading = np.interp(rel, tt - t0, np.unwrap(truth["heading"].to_numpy(dtype=np.float64)))
    return pd.DataFrame({
        "t": np.asarray(when, dtype=np.float64),
        "x": np.interp(rel, tt - t0, truth["x"].to_numpy(dtype=np.float64)),
        "y": np.interp(rel, tt - t0, truth["y"].to_numpy(dtype=np.float64)),
        "heading": np.remainder(heading + math.pi, 2.0 * math.pi) - math.pi,
    })


def odometry_vs_truth(odometry: pd.DataFrame, truth: pd.DataFrame, window_s: float = 1.0,
                      min_distance_m: float = 0.05) -> dict[str, float | int]:
    """How far and how much the robot really moved per commanded metre and radian.

    Over consecutive windows of ``window_s`` (s) inside the ground truth's span: the distance
    travelled by the truth against the distance the odometry integrates (windows where the
    odometry moves at least ``min_distance_m``), and the least-squares factor from the
    odometry's heading change to the truth's. 1 means the commands are exact.

    :returns: ``distance_ratio``, ``turn_ratio``, ``windows``.
    """
    tt = truth["t"].to_numpy(dtype=np.float64)
    to = odometry["t"].to_numpy(dtype=np.float64)
    base = tt[0]
    edges = np.arange(max(tt[0], to[0]) + window_s, min(tt[-1], to[-1]) - window_s, window_s)
    if len(edges) < 2:
        return {"distance_ratio": math.nan, "turn_ratio": math.nan, "windows": 0}
    ref = truth_at(truth, edges)
    d_truth = np.hypot(np.diff(ref["x"].to_numpy()), np.diff(ref["y"].to_numpy()))
    h_truth = np.diff(np.unwrap(ref["heading"].to_numpy()))
    v = odometry["v"].to_numpy(dtype=np.float64)
    w = odometry["omega"].to_numpy(dtype=np.float64)
    track = odometry_track(to - base, v, w)
    px, py, pth = track_at(to - base, v, w, track, edges - base)
    d_odo = np.hypot(np.diff(px), np.diff(py))
    h_odo = np.diff(pth)
    moving = d_odo >= min_distance_m
    return {
        "distance_ratio": float(d_truth[moving].sum() / d_odo[moving].sum()),
        "turn_ratio": float(np.dot(h_truth, h_odo) / np.dot(h_odo, h_odo)),
        "windows": len(d_odo),
    }
