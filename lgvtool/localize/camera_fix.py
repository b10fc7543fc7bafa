"""A first pose from one scan, weighted by the sensor's range and bearing noise.

:func:`lgvtool.localize.fix.pose_fix` aligns the measured points on the map, which weighs the
error along a ray and across it alike. A camera measures bearings well (about 0.01 rad) and
ranges poorly (10-30 %), so two landmarks of a cluster can give a point fix metres off.
:func:`weighted_fix` starts from that point fix and minimises the squared range and bearing
residuals, each divided by its own standard deviation (Gauss-Newton), and returns the pose with
its covariance ``(J^T W J)^-1``, so that an estimator can wait for a fix that is good enough
and start with the uncertainty it really has.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle, wrap_scalar
from lgvtool.localize.fix import pose_fix, scan_fix
from lgvtool.localize.observations import PoseObservation, ReflectorMap, ScanObservation

FloatArray = NDArray[np.float64]
ITERATIONS = 8
"""Gauss-Newton iterations from the point fix."""


def _residuals(pose: FloatArray, obs: ScanObservation, mx: FloatArray, my: FloatArray,
               origin: NDArray[np.complex128], ray: FloatArray) -> FloatArray:
    """Measured minus predicted range (m) and bearing (rad) of each landmark, stacked."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    ex, ey = mx - pose[0], my - pose[1]
    vx = c * ex + s * ey - origin.real
    vy = -s * ex + c * ey - origin.imag
    nr = obs.ranges - np.hypot(vx, vy)
    nb = wrap_angle(ray - np.arctan2(vy, vx))
    return np.concatenate([nr, nb])


def _known(obs: ScanObservation, rmap: ReflectorMap, sigma_range_m: float,
           sigma_range_per_m: float, sigma_bearing_rad: float,
           index: NDArray[np.int64] | None = None
           ) -> tuple[ScanObservation, FloatArray, FloatArray, NDArray[np.complex128], FloatArray,
                      FloatArray]:
    """The landmarks of ``obs`` with a known id (or, given ``index``, those it matches with a
    layout reflector, -1 none): the sub-scan, their map positions (m), the sensor origins of
    the rays (m, body frame), the ray angles (rad) and the weights (inverse variances) of the
    stacked range and bearing residuals."""
    j = obs.map_index(rmap) if index is None else index
    ok = j >= 0
    ranges = obs.ranges[ok]
    sub = ScanObservation(obs.t, obs.q[ok], obs.u[ok], ranges, obs.ids[ok])
    sr = np.sqrt(sigma_range_m ** 2 + (sigma_range_per_m * ranges) ** 2)
    w = np.concatenate([1.0 / sr ** 2, np.full(len(ranges), 1.0 / sigma_bearing_rad ** 2)])
    return (sub, rmap.x[j[ok]], rmap.y[j[ok]], (obs.q - obs.ranges * obs.u)[ok],
            np.angle(obs.u[ok]), w)


def residual_chi2_each(pose: tuple[float, float, float], obs: ScanObservation,
                       rmap: ReflectorMap, sigma_range_m: float, sigma_range_per_m: float,
                       sigma_bearing_rad: float) -> FloatArray:
    """The squared range and bearing residual of each known landmark of ``obs`` seen from the
    body pose ``pose`` (m, m, rad), each part divided by its variance (dimensionless, 2 degrees
    of freedom each; in the scan's order, landmarks without a known id left out)."""
    sub, mx, my, origin, ray, w = _known(obs, rmap, sigma_range_m, sigma_range_per_m,
                                         sigma_bearing_rad)
    if len(sub) == 0:
        return np.zeros(0)
    r = _residuals(np.asarray(pose, dtype=np.float64), sub, mx, my, origin, ray)
    weighted = w * r * r
    n = len(sub)
    each: FloatArray = weighted[:n] + weighted[n:]
    return each


def residual_chi2(pose: tuple[float, float, float], obs: ScanObservation, rmap: ReflectorMap,
                  sigma_range_m: float, sigma_range_per_m: float, sigma_bearing_rad: float
                  ) -> float:
    """Sum of the squared range and bearing residuals of the known landmarks of ``obs`` seen
    from the body pose ``pose`` (m, m, rad), each divided by its variance (dimensionless; 0
    with no known landmark): the sum of :func:`residual_chi2_each`."""
    return float(residual_chi2_each(pose, obs, rmap, sigma_range_m, sigma_range_per_m,
                                    sigma_bearing_rad).sum())


def weighted_fix(obs: ScanObservation, rmap: ReflectorMap, sigma_range_m: float,
                 sigma_range_per_m: float, sigma_bearing_rad: float, *, use_ids: bool = True
                 ) -> tuple[tuple[float, float, float], FloatArray] | None:
    """Pose of the body frame (m, m, rad) from a scan that fixes it
    (:func:`lgvtool.localize.fix.scan_fix`: two landmarks of known id that agree, or the
    scan's geometry matched on the layout), refined on the landmarks that fix matched, and its
    3x3 covariance (m^2, m rad, rad^2).

    The range noise of a landmark at range ``r`` is ``hypot(sigma_range_m, sigma_range_per_m
    r)`` (m), its bearing noise ``sigma_bearing_rad`` (rad). None when the scan does not fix
    the pose (no fix, degenerate geometry).
    """
    fix = scan_fix(obs, rmap, use_ids=use_ids,
                   noise=(sigma_range_m, sigma_range_per_m, sigma_bearing_rad))
    if fix is None:
        return None
    seed = fix.pose
    sub, mx, my, origin, ray, w = _known(obs, rmap, sigma_range_m, sigma_range_per_m,
                                         sigma_bearing_rad, fix.index)
    ranges = sub.ranges
    pose = np.array(seed, dtype=np.float64)
    jac = np.empty((2 * len(ranges), 3))
    info = np.eye(3)
    for _ in range(ITERATIONS):
        r0 = _residuals(pose, sub, mx, my, origin, ray)
        for i, h in enumerate((1e-6, 1e-6, 1e-7)):
            d = np.zeros(3)
            d[i] = h
            jac[:, i] = (r0 - _residuals(pose + d, sub, mx, my, origin, ray)) / h
        info = jac.T @ (jac * w[:, None])
        try:
            step = np.linalg.solve(info, jac.T @ (w * r0))
        except np.linalg.LinAlgError:
            return None
        pose = pose + step
        if float(np.abs(step).max()) < 1e-9:
            break
    if not np.all(np.isfinite(pose)):
        return None
    try:
        cov = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        return None
    return (float(pose[0]), float(pose[1]), wrap_scalar(float(pose[2]))), 0.5 * (cov + cov.T)


@runtime_checkable
class MeasurementNoise(Protocol):
    """The reflector measurement noise among an estimator's parameters: range (m, plus m per m
    of range) and bearing (rad)."""

    @property
    def sigma_range_m(self) -> float: ...
    @property
    def sigma_range_per_m(self) -> float: ...
    @property
    def sigma_bearing_rad(self) -> float: ...


@runtime_checkable
class WeightedFixParams(MeasurementNoise, Protocol):
    """The parameters of an estimator that may start from a weighted fix: the measurement
    noise, the kind of fix (``init_fix``) and the largest standard deviation of a weighted
    fix's position it starts from (``init_max_sigma_xy_m``, m; 0: no limit)."""

    @property
    def init_fix(self) -> str: ...
    @property
    def init_max_sigma_xy_m(self) -> float: ...


def start_fix(obs: PoseObservation | ScanObservation, nav_x: float, nav_y: float,
              rmap: ReflectorMap, params: object
              ) -> tuple[tuple[float, float, float], FloatArray | None] | None:
    """The first pose an estimator with ``params`` takes from ``obs``, and the fix's
    covariance (None for a point fix or a NAV pose).

    ``params.init_fix`` ``weighted`` (when the parameters have it) fixes a scan with
    :func:`weighted_fix` and the estimator's own measurement noise, and refuses a fix whose
    position standard deviation along its larger axis exceeds ``params.init_max_sigma_xy_m``
    (m, 0: no limit); otherwise :func:`lgvtool.localize.fix.pose_fix`. None when ``obs`` gives
    no (good enough) fix.
    """
    use_ids = getattr(params, "use_ids", True)
    noise: tuple[float, float, float] | None = None
    if isinstance(params, MeasurementNoise):
        noise = (params.sigma_range_m, params.sigma_range_per_m, params.sigma_bearing_rad)
    if isinstance(obs, ScanObservation) and isinstance(params, WeightedFixParams) and \
            params.init_fix == "weighted":
        fix = weighted_fix(obs, rmap, params.sigma_range_m, params.sigma_range_per_m,
                           params.sigma_bearing_rad, use_ids=use_ids)
        if fix is None:
            return None
        pose, cov = fix
        worst = math.sqrt(max(0.0, float(np.linalg.eigvalsh(cov[:2, :2])[-1])))
        limit = params.init_max_sigma_xy_m
        if limit > 0.0 and worst > limit:
            return None
        return pose, cov
    point = pose_fix(obs, nav_x, nav_y, rmap, use_ids=use_ids, noise=noise)
    return None if point is None else (point, None)
