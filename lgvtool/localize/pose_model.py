"""The pose observation model of a rotating-head navigation device (NAV200 and alike).

A rotating-head NAV measures each reflector when its beam passes it, at its own instant of one
head revolution (period ``T``), and fits one head pose to all of them as if they had been
measured at once; the host reads that pose later. Three consequences follow from the physics of
the device alone (docs/filter.md, "The pose observation model"):

1. **The pose refers to the middle of its revolution, and arrives late.** A fit over
   reflectors spread evenly over the revolution is, to first order, the pose at the mean of
   their instants, the revolution's middle. A host that asks for the newest solution at a time
   unrelated to the revolution gets one that was finished between 0 and ``T`` before, so the
   reference instant lies ``age`` before the receive time, with a spread uniform over ``T``
   (variance ``T^2 / 12``). The mean age (``T / 2`` to the middle, ``T / 2`` of waiting on
   average, plus the device's processing and the reply) is fitted on the log
   (:func:`fit_age`), or taken as configured.
2. **The timing spread is a motion error.** An unknown instant ``dt`` moves the head pose along
   its own velocity: ``(v_head dt, omega dt)`` with ``v_head = v + omega x (d_x, d_y)`` (the
   lever arm of the head). Its covariance is ``J J^T sigma_t^2`` with ``J`` the head's velocity
   in the map and its turn rate: fully correlated between position along the head's path and
   heading, zero at standstill.
3. **A turning head skews its own fit.** While the vehicle turns at ``omega`` the head frame
   turns by ``omega T`` over the revolution, so a bearing measured at head angle ``phi`` after
   the revolution's start is off by ``-omega T (phi / 2 pi - 1/2)``, a saw-tooth over the
   revolution. Its first harmonic, ``(omega T / pi) sin(phi)``, is what a shift of the head
   along the direction where the revolution starts would cause to reflectors at range ``r``:
   the fit moves the head by about ``kappa r omega T / pi`` (``kappa < 1`` where the ranges
   resist the shift). The result is a bias fixed in the head's frame, proportional to the turn
   rate: ``b = (omega T / pi) R(heading) s`` with a lever ``s = (s_x, s_y)`` (m) that depends
   on where the revolution starts and on the ranges of the reflectors used. It is fitted on
   the log (:func:`fit_skew`) and taken off the reported pose, and what varies of it from one
   revolution to the next (the reflectors used change) is a noise of standard deviation
   ``pose_skew_sigma_m omega T / pi``.

With the motion ``v, omega`` of the odometry at the reference instant, :func:`pose_covariance`
gives the covariance of a reported head pose; :func:`prepare_poses` turns a log's NAV poses
into :class:`lgvtool.localize.observations.PoseObservation` at their reference instants with the
skew taken off: :func:`fit_pose_model` fits the age and the lever (or takes them as stated,
:func:`stated_fit`), :func:`pose_observations` applies them (the live view calls it with the
stated model, ``lgvtool calibrate`` the fit once per drive). :func:`standstill_noise` gives the
scatter of the poses while the vehicle stands, the noise at standstill. :class:`PoseGate` is
the robust gate every estimator applies: a Mahalanobis gate on the model's covariance with a
re-anchoring to the reported pose once poses have been refused for longer than
``pose_reanchor_s``.

Pure: arrays in, arrays out. Units: m, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.localize.observations import PoseObservation
from lgvtool.localize.params import param

if TYPE_CHECKING:
    from lgvtool.localize.motion import MotionTrack

FloatArray = NDArray[np.float64]

POSE_MODELS = ("rotating-head", "plain")
"""``rotating-head``: this module's model; ``plain``: a fixed Gaussian of the pose (the
estimator's ``sigma_pose_xy_m``, ``sigma_pose_heading_rad``) at receive time minus
``pose_latency_s``."""

#: the ages a fit considers, s (0 to AGE_MAX_S in AGE_STEP_S)
AGE_MAX_S = 0.6
#: the least age a fit considers when the vehicle states a pose age (what is fitted is then
#: what the installation's correction left, which may be slightly negative), s
AGE_MIN_STATED_S = -0.2
AGE_STEP_S = 0.0025
#: a fitted age is used only when its standard error is at most this, s
AGE_MAX_SIGMA_S = 0.010
#: half the window over which the rotation between the odometry and the map is averaged, s
FRAME_WINDOW_S = 5.0
#: the longest time between two poses whose relative motion the skew fit compares, s
SKEW_PAIR_S = 3.0
#: a fitted skew lever is used only when its standard error is at most this, m
SKEW_MAX_SIGMA_M = 1.5
#: pairs whose residual exceeds this many times the median's are left out of the skew fit
SKEW_CLIP = 5.0
#: a standstill: the odometry's speed below this, m/s, ...
STANDSTILL_SPEED = 0.002
#: ... and its turn rate below this, rad/s, ...
STANDSTILL_TURN = 0.002
#: ... for at least this long, s (a shorter stop is left out of the noise at standstill)
STANDSTILL_MIN_S = 2.0
#: the noise at standstill is determined by at least this many degrees of freedom (poses less
#: one per standstill)
STANDSTILL_MIN_DOF = 10


@dataclass(frozen=True)
class PoseModelParams:
    """The rotating-head pose observation model (:mod:`lgvtool.localize.pose_model`)."""

    pose_model: str = param("rotating-head", "model of a NAV pose: rotating-head (a fit over one "
                            "head revolution while the vehicle moves: its reference instant, "
                            "age, timing spread and turn-rate skew; docs/filter.md) or plain "
                            "(a fixed Gaussian at receive time minus pose_latency_s)",
                            choices=POSE_MODELS)
    pose_period_s: float = param(0.125, "head revolution period T of the device, s",
                                 minimum=0.001, maximum=2.0)
    pose_async: bool = param(True, "the host reads the newest solution at times unrelated to "
                             "the revolution: the reference instant is uniform over one period, "
                             "a timing variance of T^2 / 12")
    pose_time_sigma_s: float = param(0.005, "further timing noise of a pose (the host's read "
                                     "jitter), s", minimum=0.0, maximum=1.0)
    pose_age_fit: bool = param(True, "fit the age of the poses on the log (their headings, "
                               "then their relative motion over up to 3 s, against the "
                               "odometry's); when the log does not determine it (standard "
                               "error above 10 ms, e.g. on a steady circle) the age is "
                               "pose_latency_s plus, when the vehicle states no pose age, one "
                               "period T (the revolution's middle and the mean wait)")
    pose_skew_fit: bool = param(True, "fit the skew lever (s_x, s_y) on the log (the poses' "
                                "relative motion against the odometry's over up to 3 s); when "
                                "the log does not determine it (standard error above 1.5 m) "
                                "pose_skew_x_m and pose_skew_y_m are used")
    pose_skew_x_m: float = param(0.0, "skew lever along the head's x axis: the pose is biased "
                                 "by (omega T / pi) (s_x, s_y) in the head frame, m",
                                 minimum=-50.0, maximum=50.0)
    pose_skew_y_m: float = param(0.0, "skew lever along the head's y axis (left), m",
                                 minimum=-50.0, maximum=50.0)
    pose_skew_sigma_m: float = param(2.0, "spread of the skew lever from one revolution to the "
                                     "next (the reflectors used change): a position noise of "
                                     "this times omega T / pi, m", minimum=0.0, maximum=50.0)
    pose_reanchor_s: float = param(3.0, "robust gate: once NAV poses have been refused by the "
                                   "gate for this long without one accepted, the estimate is "
                                   "re-anchored at the reported pose; 0: never, s", minimum=0.0)


class _PoseSettings(Protocol):
    """What the model reads of an estimator's parameters."""

    @property
    def pose_period_s(self) -> float: ...
    @property
    def pose_async(self) -> bool: ...
    @property
    def pose_time_sigma_s(self) -> float: ...
    @property
    def pose_skew_sigma_m(self) -> float: ...


def time_variance(p: _PoseSettings) -> float:
    """Variance of a pose's reference instant about its fitted age, s^2."""
    t = p.pose_period_s
    return (t * t / 12.0 if p.pose_async else 0.0) + p.pose_time_sigma_s ** 2


def pose_covariance(heading: float, v: float, omega: float, nav_x: float, nav_y: float,
                    sigma_xy_m: float, sigma_heading_rad: float, p: _PoseSettings
                    ) -> FloatArray:
    """Covariance (3 x 3: x m, y m, heading rad, map frame) of a reported head pose.

    :param heading: the head's heading, rad (the estimate's or the report's).
    :param v: forward speed of O at the reference instant, m/s; ``omega`` its turn rate, rad/s.
    :param nav_x: head position in the vehicle frame, forward (m); ``nav_y`` left (m).
    :param sigma_xy_m: the pose's noise at standstill, m; ``sigma_heading_rad`` rad.
    """
    c, s = math.cos(heading), math.sin(heading)
    # the head's velocity in the body frame (O moves forward at v and turns at omega)
    hx, hy = v - omega * nav_y, omega * nav_x
    j = np.array([c * hx - s * hy, s * hx + c * hy, omega])
    cov = np.outer(j, j) * time_variance(p)
    skew = p.pose_skew_sigma_m * abs(omega) * p.pose_period_s / math.pi
    var_xy = sigma_xy_m * sigma_xy_m + skew * skew
    cov[0, 0] += var_xy
    cov[1, 1] += var_xy
    cov[2, 2] += sigma_heading_rad * sigma_heading_rad
    return cov


def pose_covariances(heading: FloatArray, v: FloatArray, omega: FloatArray, nav_x: float,
                     nav_y: float, sigma_xy_m: float, sigma_heading_rad: float,
                     p: _PoseSettings) -> FloatArray:
    """:func:`pose_covariance` of many poses at once, (n, 3, 3)."""
    c, s = np.cos(heading), np.sin(heading)
    hx, hy = v - omega * nav_y, omega * nav_x
    j = np.stack([c * hx - s * hy, s * hx + c * hy, omega], axis=-1)
    cov = j[:, :, None] * j[:, None, :] * time_variance(p)
    skew = p.pose_skew_sigma_m * np.abs(omega) * p.pose_period_s / math.pi
    var_xy = sigma_xy_m * sigma_xy_m + skew * skew
    cov[:, 0, 0] += var_xy
    cov[:, 1, 1] += var_xy
    cov[:, 2, 2] += sigma_heading_rad * sigma_heading_rad
    return cov


@dataclass(frozen=True)
class PoseFit:
    """What :func:`prepare_poses` used: the age (s) and skew lever (m, head frame), whether
    each came from the log (``age_fitted``, ``skew_fitted``), and their standard errors (s, m;
    NaN when not fitted). ``age_tried_sigma_s`` and ``skew_tried_sigma_m`` are the standard
    errors of the fits tried, used or not (s, m; inf when nothing determined them, NaN when no
    fit was tried): how far the log was from determining them."""

    age_s: float
    age_sigma_s: float
    age_fitted: bool
    skew_x_m: float
    skew_y_m: float
    skew_sigma_m: float
    skew_fitted: bool
    age_tried_sigma_s: float = math.nan
    skew_tried_sigma_m: float = math.nan


def vehicle_states_age(nav_time_offset: float, nav_pose_age: float) -> bool:
    """Whether a vehicle configuration states the age of its NAV poses: a ``nav_time_offset``
    or a ``nav_pose_age`` (s) other than 0, which the installation takes off the poses' times
    (:mod:`lgvtool.localize.installation`) before this model sees them."""
    return nav_time_offset != 0.0 or nav_pose_age != 0.0


def stated_age(latency_s: float, period_s: float, configured_age: bool) -> float:
    """The age (s) of a pose when none is fitted: ``pose_latency_s`` plus, when the vehicle
    states no pose age, one head period ``T`` (s: the revolution's middle and the mean wait)."""
    return latency_s + (0.0 if configured_age else period_s)


def latency_for(age_s: float, period_s: float, configured_age: bool) -> float:
    """The ``pose_latency_s`` (s) that makes :func:`stated_age` give ``age_s`` (s): its
    inverse; negative when ``age_s`` is below what the vehicle's statement already gives."""
    return age_s - (0.0 if configured_age else period_s)


def stated_fit(p: PoseModelParams, latency_s: float, configured_age: bool) -> PoseFit:
    """The model as configured, nothing fitted: the age of :func:`stated_age` and the lever
    ``(pose_skew_x_m, pose_skew_y_m)`` (m)."""
    return PoseFit(stated_age(latency_s, p.pose_period_s, configured_age), math.nan, False,
                   p.pose_skew_x_m, p.pose_skew_y_m, math.nan, False)


def _local_mean(t: FloatArray, values: FloatArray, half: float) -> FloatArray:
    """Mean of ``values`` over the samples within ``half`` s of each time ``t`` (sorted)."""
    cs = np.concatenate([[0.0], np.cumsum(values)])
    lo = np.searchsorted(t, t - half, side="left")
    hi = np.searchsorted(t, t + half, side="right")
    out: FloatArray = (cs[hi] - cs[lo]) / np.maximum(hi - lo, 1)
    return out


def fit_age(t: FloatArray, heading: FloatArray, track: MotionTrack, *, min_age: float = 0.0
            ) -> tuple[float, float]:
    """The age of NAV poses (s) and its standard error (s): the shift that best aligns their
    headings (rad, at receive times ``t`` s) with the odometry's, after the slowly varying
    rotation between the two frames (averaged over 2 x 5 s) is taken off. The ages tried run
    from ``min_age`` to :data:`AGE_MAX_S` (s).

    Only changes of the turn rate determine it (on a steady circle a late pose looks like a
    rotated frame): the standard error is then large, or infinite with fewer than 10 poses.
    """
    if len(t) < 10:
        return 0.0, math.inf
    ages = min_age + np.arange(0.0, AGE_MAX_S - min_age + 0.5 * AGE_STEP_S, AGE_STEP_S)
    h = np.unwrap(heading)
    cost = np.empty(len(ages))
    for i, a in enumerate(ages):
        th = track.poses_at(t - a)[2]
        e = h - th
        e = e - 2.0 * math.pi * np.round((e - e[0]) / (2.0 * math.pi))
        r = e - _local_mean(t, e, FRAME_WINDOW_S)
        cost[i] = float(np.mean(r * r))
    k = int(np.argmin(cost))
    if k == 0 or k == len(ages) - 1:
        return float(ages[k]), math.inf
    c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
    curv = (c0 - 2.0 * c1 + c2) / (AGE_STEP_S * AGE_STEP_S)
    if curv <= 0.0:
        return float(ages[k]), math.inf
    shift = 0.5 * (c0 - c2) / (c0 - 2.0 * c1 + c2)
    age = float(ages[k] + shift * AGE_STEP_S)
    # cost(a) ~ cost_min + curv / 2 (a - a*)^2, a mean of n squares of noise cost_min:
    # the standard error of a* is sqrt(2 cost_min / (n curv))
    return age, math.sqrt(2.0 * c1 / (len(t) * curv))


def odometry_motion(track: MotionTrack, t: FloatArray, period: float
                    ) -> tuple[FloatArray, FloatArray]:
    """Forward speed (m/s) and turn rate (rad/s) of O over the revolution ``[t - T/2,
    t + T/2]`` about each time ``t`` (s), from the odometry track."""
    half = 0.5 * period
    x0, y0, th0, _, _ = track.poses_at(t - half)
    x1, y1, th1, _, _ = track.poses_at(t + half)
    c, s = np.cos(th0), np.sin(th0)
    v: FloatArray = (c * (x1 - x0) + s * (y1 - y0)) / period
    w: FloatArray = (th1 - th0) / period
    return v, w


def fit_skew(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
             track: MotionTrack, nav_x: float, nav_y: float, period: float, *,
             with_age: bool = True) -> tuple[float, float, float, float, float]:
    """The skew lever ``(s_x, s_y)`` (m, head frame) and its standard error (m), and a
    correction ``da`` (s) of the poses' age with its standard error (s), from the relative
    motion of the head poses ``(x, y, heading)`` (m, rad) at their reference instants ``t``
    (s) against the odometry's over up to 3 s: the difference of two poses' biases is
    ``(T / pi) (omega_j R(h_j) - omega_i R(h_i)) s``, and a pose older by ``da`` than taken is
    off by ``-da`` times the head's velocity, both linear; the odometry's frame is turned onto
    the map by the rotation averaged over 2 x 5 s. The age from the positions is the one that
    places the vehicle in time (a heading from a gyro integrated over its frames may lag).
    Without ``with_age`` the age is not fitted (``da`` 0, infinite error): on a steady circle
    a late pose and a skewed one look alike. Infinite errors when nothing determines them."""
    n = len(t)
    if n < 10:
        return 0.0, 0.0, math.inf, 0.0, math.inf
    ox, oy, oth, _, _ = track.poses_at(t)
    c, s = np.cos(oth), np.sin(oth)
    hx = ox + c * nav_x - s * nav_y
    hy = oy + s * nav_x + c * nav_y
    d = np.unwrap(heading) - oth
    d = d - 2.0 * math.pi * np.round((d - d[0]) / (2.0 * math.pi))
    phi = _local_mean(t, d, FRAME_WINDOW_S)
    _, w = odometry_motion(track, t, period)
    # the head's velocity in the odometry frame (central difference over one revolution)
    h = 0.5 * period
    xa, ya, tha, _, _ = track.poses_at(t - h)
    xb, yb, thb, _, _ = track.poses_at(t + h)
    vx = ((xb + np.cos(thb) * nav_x - np.sin(thb) * nav_y)
          - (xa + np.cos(tha) * nav_x - np.sin(tha) * nav_y)) / period
    vy = ((yb + np.sin(thb) * nav_x + np.cos(thb) * nav_y)
          - (ya + np.sin(tha) * nav_x + np.cos(tha) * nav_y)) / period
    k = period / math.pi
    rows_a: list[FloatArray] = []
    rows_r: list[FloatArray] = []
    for lag in range(1, n):
        i = np.arange(n - lag)
        j = i + lag
        near = (t[j] - t[i]) <= SKEW_PAIR_S
        if not near.any():
            break
        i, j = i[near], j[near]
        cp, sp = np.cos(phi[i]), np.sin(phi[i])
        ex, ey = hx[j] - hx[i], hy[j] - hy[i]
        rx = (x[j] - x[i]) - (cp * ex - sp * ey)
        ry = (y[j] - y[i]) - (sp * ex + cp * ey)
        aj, ai = oth[j] + phi[i], oth[i] + phi[i]
        # (omega_j R(a_j) - omega_i R(a_i)) k: columns s_x, s_y
        a11 = k * (w[j] * np.cos(aj) - w[i] * np.cos(ai))
        a21 = k * (w[j] * np.sin(aj) - w[i] * np.sin(ai))
        # -(V_j - V_i), the odometry's velocity turned onto the map: column da
        ux, uy = vx[j] - vx[i], vy[j] - vy[i]
        a13 = -(cp * ux - sp * uy)
        a23 = -(sp * ux + cp * uy)
        rows_a.append(np.stack([np.stack([a11, -a21, a13], -1),
                                np.stack([a21, a11, a23], -1)], 1).reshape(-1, 3))
        rows_r.append(np.stack([rx, ry], -1).reshape(-1))
    if not rows_a:
        return 0.0, 0.0, math.inf, 0.0, math.inf
    a_mat = np.concatenate(rows_a)
    if not with_age:
        a_mat = a_mat[:, :2]
    r = np.concatenate(rows_r)
    keep = np.isfinite(r)
    for _ in range(2):  # least squares, then again without the pairs far off it
        ata = a_mat[keep].T @ a_mat[keep]
        if np.linalg.cond(ata) > 1e12:
            return 0.0, 0.0, math.inf, 0.0, math.inf
        sol = np.linalg.solve(ata, a_mat[keep].T @ r[keep])
        res = r - a_mat @ sol
        med = float(np.median(np.abs(res[keep])))
        keep = keep & (np.abs(res) <= SKEW_CLIP * max(med, 1e-6) / 0.6745)
    ata = a_mat[keep].T @ a_mat[keep]
    res = (r - a_mat @ sol)[keep]
    # each pose takes part in about (pairs per pose) pairs: the errors of the pairs are not
    # independent, so the variance is scaled by that count
    per_pose = max(1.0, float(keep.sum()) / (2.0 * n))
    var = float(np.mean(res * res)) * per_pose * np.linalg.inv(ata)
    skew_sigma = float(math.sqrt(max(var[0, 0], var[1, 1])))
    if not with_age:
        return float(sol[0]), float(sol[1]), skew_sigma, 0.0, math.inf
    return float(sol[0]), float(sol[1]), skew_sigma, float(sol[2]), float(math.sqrt(var[2, 2]))


def fit_pose_model(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
                   track: MotionTrack | None, nav_x: float, nav_y: float, p: PoseModelParams,
                   latency_s: float, configured_age: bool) -> PoseFit:
    """The age (s) and skew lever (m, head frame) of a log's NAV head poses (m, rad; receive
    times ``t`` s, after the installation's corrections) against the odometry ``track``: fitted
    where ``pose_age_fit`` and ``pose_skew_fit`` ask for it and the log determines them (see
    the module docstring), else as stated (:func:`stated_fit`).

    :param track: the odometry; without it nothing is fitted.
    :param latency_s: the estimator's ``pose_latency_s``, s: the age when it is not fitted,
        plus one period when ``configured_age`` is False (the vehicle states no pose age).
    """
    stated = stated_fit(p, latency_s, configured_age)
    age, age_sigma, age_fitted = stated.age_s, math.nan, False
    sx, sy, s_sigma, skew_fitted = stated.skew_x_m, stated.skew_y_m, math.nan, False
    tried_age = tried_skew = math.nan
    # what the installation took off may leave a slightly negative age to fit
    lowest = AGE_MIN_STATED_S if configured_age else 0.0
    if track is not None and p.pose_age_fit:
        a, sa = fit_age(t, heading, track, min_age=lowest)
        tried_age = sa
        if sa <= AGE_MAX_SIGMA_S:
            age, age_sigma, age_fitted = a, sa, True
    if track is not None and (p.pose_skew_fit or p.pose_age_fit):
        # the age from the positions when they determine it (the heading's may lag),
        # else the skew alone
        fit = fit_skew(t - age, x, y, heading, track, nav_x, nav_y, p.pose_period_s,
                       with_age=p.pose_age_fit)
        if p.pose_age_fit:
            tried_age = fit[4] if not math.isfinite(tried_age) else min(tried_age, fit[4])
        if fit[4] <= AGE_MAX_SIGMA_S and lowest <= age + fit[3] <= AGE_MAX_S:
            age, age_sigma, age_fitted = age + fit[3], fit[4], True
        else:
            fit = fit_skew(t - age, x, y, heading, track, nav_x, nav_y, p.pose_period_s,
                           with_age=False)
        tried_skew = fit[2]
        if p.pose_skew_fit and fit[2] <= SKEW_MAX_SIGMA_M:
            sx, sy, s_sigma, skew_fitted = fit[0], fit[1], fit[2], True
    return PoseFit(age, age_sigma, age_fitted, sx, sy, s_sigma, skew_fitted, tried_age,
                   tried_skew)


def pose_observations(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
                      track: MotionTrack | None, fit: PoseFit, period_s: float
                      ) -> list[PoseObservation]:
    """NAV head poses (m, rad; receive times ``t`` s) as observations at their reference
    instants ``t - fit.age_s``, with the skew ``(omega T / pi) R(heading) (s_x, s_y)`` of the
    ``fit``'s lever taken off and the odometry's forward speed (m/s) and turn rate (rad/s) over
    the revolution about that instant (0 without a ``track``). ``period_s``: the head period
    ``T``, s. Replay (:func:`prepare_poses`) and the live view call it alike."""
    tr = t - fit.age_s
    if track is not None:
        v, w = odometry_motion(track, tr, period_s)
    else:
        v = w = np.zeros(len(t))
    k = w * period_s / math.pi
    c, s = np.cos(heading), np.sin(heading)
    cx = x - k * (c * fit.skew_x_m - s * fit.skew_y_m)
    cy = y - k * (s * fit.skew_x_m + c * fit.skew_y_m)
    return [PoseObservation(*row) for row in zip(tr.tolist(), cx.tolist(), cy.tolist(),
                                                 wrap_angle(heading).tolist(), v.tolist(),
                                                 w.tolist(), strict=True)]


def prepare_poses(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
                  track: MotionTrack | None, nav_x: float, nav_y: float, p: PoseModelParams,
                  latency_s: float, configured_age: bool) -> tuple[list[PoseObservation],
                                                                    PoseFit]:
    """A log's NAV head poses (m, rad; receive times ``t`` s, after the installation's
    corrections) as observations at their reference instants, with the skew taken off and the
    odometry's motion at that instant: :func:`fit_pose_model`, then
    :func:`pose_observations`.

    :param track: the odometry; without it no fit is made and the motion is 0.
    :param latency_s: the estimator's ``pose_latency_s``, s: the age when it is not fitted,
        plus one period when ``configured_age`` is False (the vehicle states no pose age).
    """
    fit = fit_pose_model(t, x, y, heading, track, nav_x, nav_y, p, latency_s, configured_age)
    return pose_observations(t, x, y, heading, track, fit, p.pose_period_s), fit


@dataclass(frozen=True)
class StandstillNoise:
    """The scatter of NAV poses while the vehicle stood still: the position noise (m, per
    axis) and heading noise (rad), each with its standard error (m, rad), from ``poses`` poses
    over ``standstills`` standstills lasting ``duration_s`` s in all; ``determined`` when they
    give at least :data:`STANDSTILL_MIN_DOF` degrees of freedom (else the sigmas are NaN)."""

    sigma_xy_m: float
    sigma_xy_se_m: float
    sigma_heading_rad: float
    sigma_heading_se_rad: float
    poses: int
    standstills: int
    duration_s: float

    @property
    def determined(self) -> bool:
        """Whether enough poses were seen at standstill to give the noise."""
        return self.poses - self.standstills >= STANDSTILL_MIN_DOF


def standstills(track: MotionTrack, t: FloatArray, *, min_s: float = STANDSTILL_MIN_S
                ) -> list[tuple[float, float]]:
    """The stretches ``(start, end)`` (s) within the times ``t`` (s, sorted) during which the
    odometry moved slower than :data:`STANDSTILL_SPEED` (m/s) and turned slower than
    :data:`STANDSTILL_TURN` (rad/s) for at least ``min_s`` s (a head period is left off at
    each end, where the pose may still be a moving one)."""
    if len(track.t) < 2 or len(t) == 0:
        return []
    grid = np.arange(max(track.t[0], t[0]), min(track.t[-1], t[-1]), 0.05)
    if len(grid) < 2:
        return []
    x, y, th, _, _ = track.poses_at(grid)
    dt = np.diff(grid)
    still = ((np.hypot(np.diff(x), np.diff(y)) / dt < STANDSTILL_SPEED)
             & (np.abs(np.diff(th)) / dt < STANDSTILL_TURN))
    out: list[tuple[float, float]] = []
    start: float | None = None
    for i, s in enumerate(still.tolist()):
        if s and start is None:
            start = float(grid[i])
        elif not s and start is not None:
            out.append((start, float(grid[i])))
            start = None
    if start is not None:
        out.append((start, float(grid[-1])))
    return [(a, b) for a, b in out if b - a >= min_s]


def standstill_noise(t: FloatArray, x: FloatArray, y: FloatArray, heading: FloatArray,
                     track: MotionTrack, *, min_s: float = STANDSTILL_MIN_S,
                     margin_s: float = 0.25) -> StandstillNoise:
    """The noise of NAV head poses (m, rad; reference instants ``t`` s) at standstill: their
    scatter about each standstill's mean (:func:`standstills` of at least ``min_s`` s, less
    ``margin_s`` s at each end), pooled over the standstills (one degree of freedom taken per
    standstill). The position's is the mean of the x and y variances, per axis (m); the
    standard errors are those of a sigma from that many degrees of freedom."""
    xs: list[FloatArray] = []
    ys: list[FloatArray] = []
    hs: list[FloatArray] = []
    used = 0
    duration = 0.0
    for a, b in standstills(track, t, min_s=min_s):
        inside = (t >= a + margin_s) & (t <= b - margin_s)
        if int(inside.sum()) < 2:
            continue
        used += 1
        duration += b - a
        xs.append(x[inside] - float(np.mean(x[inside])))
        ys.append(y[inside] - float(np.mean(y[inside])))
        h = np.unwrap(heading[inside])
        hs.append(h - float(np.mean(h)))
    n = sum(len(v) for v in xs)
    dof = n - used
    if dof < STANDSTILL_MIN_DOF:
        return StandstillNoise(math.nan, math.nan, math.nan, math.nan, n, used, duration)
    ex, ey, eh = np.concatenate(xs), np.concatenate(ys), np.concatenate(hs)
    sxy = math.sqrt(float(np.sum(ex * ex) + np.sum(ey * ey)) / (2.0 * dof))
    sh = math.sqrt(float(np.sum(eh * eh)) / dof)
    # the standard error of a sigma from k degrees of freedom: sigma / sqrt(2 k)
    return StandstillNoise(sxy, sxy / math.sqrt(4.0 * dof), sh, sh / math.sqrt(2.0 * dof), n,
                           used, duration)


class PoseGate:
    """The robust gate on NAV poses: a pose is refused when its squared Mahalanobis distance
    exceeds the chi-square quantile (3 dof); once poses have been refused for ``reanchor_s``
    (s; 0: never) since the first of them, with no pose accepted in between, the next refused
    one re-anchors the estimate instead (the filter had lost the vehicle, or the device moved).
    Each re-anchoring is added to ``events`` (an estimator's :attr:`Estimator.events`) when
    given."""

    __slots__ = ("events", "gate2", "reanchor_s", "reanchored", "refused", "since")

    def __init__(self, gate2: float, reanchor_s: float,
                 events: list[tuple[float, str, str]] | None = None) -> None:
        self.gate2 = gate2
        self.reanchor_s = reanchor_s
        self.events = events
        #: time of the first pose refused since the last accepted one, s (None: none refused)
        self.since: float | None = None
        self.refused = 0
        self.reanchored = 0

    def judge(self, t: float, d2: float) -> str:
        """``accept``, ``refuse`` or ``reanchor`` for a pose at ``t`` (s) whose squared
        Mahalanobis distance is ``d2``."""
        if d2 <= self.gate2:
            self.since = None
            return "accept"
        if self.since is None:
            self.since = t
        if self.reanchor_s > 0.0 and t - self.since >= self.reanchor_s:
            if self.events is not None:
                self.events.append((t, "reanchored", f"re-anchored at the NAV pose: its poses "
                                    f"were refused for {t - self.since:.1f} s"))
            self.since = None
            self.reanchored += 1
            return "reanchor"
        self.refused += 1
        return "refuse"
