"""``ekf``: extended Kalman filter on the pose of O.

Prediction: the body-frame odometry motion (encoders + gyro by default) composed onto the
mean, ``P <- F P F^T + G Q G^T`` with the motion noise of :mod:`lgvtool.localize.noise`.

Update from a reflector scan: each reflector's measured range and bearing are compared with
the range and bearing of the map reflector seen from the sensor (its origin and heading in the
body frame include the mounting offset and, when de-skewed, the motion since the reflector was
measured), with noise ``diag(sigma_range^2, sigma_bearing^2)``. Association: the reflector's
id when known, else the map reflector with the smallest Mahalanobis distance. An innovation
whose squared Mahalanobis distance exceeds the chi-square quantile (2 dof) of
``gate_probability`` is rejected as an outlier. The accepted reflectors are applied together in
information form (exact for the linearised model). Update from a NAV pose: ``h = pose of the
head`` (eq. 5 inverted), 3 dof gate.

Odometry scale factors (``odometry_scales``, off by default): the state grows to
``(x, y, theta, s_v, s_w)``, where ``s_v`` multiplies the odometry's distance and ``s_w`` its
heading change (dimensionless, prior mean 1). Odometry that is biased rather than noisy, e.g.
commanded velocities of a robot that travels and turns less than commanded, then becomes a
state the observations estimate: they see the pose only, and reach the scales through the
correlation the prediction builds between them and the pose. The scales follow a random walk
whose variance grows with the distance travelled and the angle turned (:func:`scaled_motion`,
:meth:`GaussianPoseEstimator._predict_scaled`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from lgvtool.angles import wrap_angle, wrap_scalar
from lgvtool.localize.camera_fix import start_fix
from lgvtool.localize.chunks import KIND_OTHER, chunks, scan_chunk
from lgvtool.localize.estimator import (
    Estimate,
    EstimateRows,
    Estimator,
    Motion,
    Observation,
    Reporter,
    RowRecorder,
)
from lgvtool.localize.kernel_choice import compiled
from lgvtool.localize.noise import MotionParams
from lgvtool.localize.observations import PoseObservation, ScanObservation, SourceParams
from lgvtool.localize.params import param
from lgvtool.quantiles import chi2_quantile

if TYPE_CHECKING:
    from lgvtool.localize.estimator import FloatArray
    from lgvtool.localize.motion import Deltas

POSE = 3
"""Size of the pose part ``(x, y, theta)`` of the state."""
SCALED = 5
"""Size of the state with the odometry scales, ``(x, y, theta, s_v, s_w)``."""

def gaussian_kernels() -> ModuleType | None:
    """The compiled loops of the Gaussian estimators (:mod:`lgvtool.localize.ekf_kernels`), or
    None for the numpy path (numba not installed, or ``LGVTOOL_KERNELS=numpy``)."""
    return compiled("lgvtool.localize.ekf_kernels")


@dataclass(frozen=True)
class GaussianInitParams:
    """How a Gaussian estimator starts."""

    init: str = param("auto", "first pose: auto (first NAV pose or landmark fix, whichever "
                      "comes first), laser (first valid NAV pose), landmarks (first scan with "
                      "two known ids); a caller's initial pose always wins",
                      choices=("auto", "laser", "landmarks"))
    init_sigma_xy_m: float = param(0.05, "initial position standard deviation, m", minimum=0.0)
    init_sigma_heading_rad: float = param(0.02, "initial heading standard deviation, rad",
                                          minimum=0.0)


@dataclass(frozen=True)
class EkfParams(MotionParams, SourceParams, GaussianInitParams):
    """Parameters of the EKF."""

    sigma_range_m: float = param(0.02, "range noise of a reflector measurement, m",
                                 minimum=1e-6)
    sigma_bearing_rad: float = param(0.005, "bearing noise of a reflector measurement, rad",
                                     minimum=1e-9)
    sigma_range_per_m: float = param(0.0, "range noise that grows with the range (a scale "
                                     "error), added in quadrature, m per m", minimum=0.0)
    sigma_pose_xy_m: float = param(0.05, "position noise of a NAV pose, m", minimum=1e-6)
    sigma_pose_heading_rad: float = param(0.01, "heading noise of a NAV pose, rad",
                                          minimum=1e-9)
    gate_probability: float = param(0.99, "chi-square gate: innovations less likely than this "
                                    "are rejected", minimum=0.5, maximum=0.999999)
    odometry_scales: bool = param(False, "estimate a distance scale s_v and a heading-change "
                                  "scale s_w of the odometry in the state (x, y, theta, s_v, "
                                  "s_w); for biased odometry such as commanded velocities")
    scale_sigma_v: float = param(0.05, "prior standard deviation of the distance scale s_v "
                                 "(prior mean 1), dimensionless", minimum=1e-6)
    scale_sigma_w: float = param(0.05, "prior standard deviation of the heading-change scale "
                                 "s_w (prior mean 1), dimensionless", minimum=1e-6)
    scale_walk_v: float = param(0.0, "random walk of s_v: its variance grows by this squared "
                                "per metre travelled, 1/sqrt(m)", minimum=0.0)
    scale_walk_w: float = param(0.0, "random walk of s_w: its variance grows by this squared "
                                "per radian turned, 1/sqrt(rad)", minimum=0.0)
    init_fix: str = param("points", "landmark fix of the start: points (align the measured "
                          "points on the map) or weighted (least squares in range and bearing "
                          "with this filter's measurement noise, the fix's own covariance added "
                          "to the start uncertainty)", choices=("points", "weighted"))
    init_max_sigma_xy_m: float = param(0.0, "weighted fix: start only from a scan whose fix has "
                                       "a position standard deviation (the larger axis) at "
                                       "most this, m; 0 takes the first fix", minimum=0.0)


def scaled_motion(dx: float, dy: float, dth: float, s_v: float, s_w: float
                  ) -> tuple[float, float, float, float, float]:
    """A body-frame odometry motion with its distance scaled by ``s_v`` and its turn by ``s_w``.

    The motion ``(dx, dy)`` (m, in the frame of the earlier pose) and ``dth`` (rad) is read as
    a turn ``a``, a straight chord ``d`` and a turn ``dth - a`` (``a`` the chord's direction,
    ``d < 0`` when the chord points backwards); the scaled motion turns ``s_w a``, travels
    ``s_v d`` and turns ``s_w (dth - a)``. This is exact for a turn-drive-turn path and, for an
    arc, keeps the chord in the middle of the scaled turn (the chord's length is then off by
    ``sinc(s_w dth / 2) / sinc(dth / 2) - 1``: 0.8 % for a 1 rad arc at ``s_w`` 0.9). With
    ``s_v = s_w = 1`` it is the motion itself. ``s_v`` and ``s_w`` are dimensionless.

    :returns: ``(dx', dy', dth')`` (m, m, rad) and ``a``, ``d`` (rad, m), which the Jacobians
        need.
    """
    d = math.hypot(dx, dy)
    a = math.atan2(dy, dx) if d > 0.0 else 0.0
    if abs(a) > 0.5 * math.pi:
        a = wrap_scalar(a - math.pi)
        d = -d
    sa = s_w * a
    sd = s_v * d
    return sd * math.cos(sa), sd * math.sin(sa), s_w * dth, a, d


class GaussianPoseEstimator(Estimator):
    """Shared state and prediction of the Gaussian estimators (EKF, dead reckoning)."""

    kernel_modules: ClassVar[tuple[str, ...]] = ("lgvtool.localize.ekf_kernels",)
    #: False when observations after the start never change the state (dead reckoning)
    corrects: ClassVar[bool] = True

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]
        #: True when the state carries the odometry scales ``(s_v, s_w)`` after the pose
        self.scaled = bool(getattr(self.params, "odometry_scales", False))
        n = SCALED if self.scaled else POSE
        self.mu: np.ndarray | None = None
        self.P = np.zeros((n, n))
        if self.initial_pose is not None:
            self._start(self.initial_pose)

    def _start(self, pose: tuple[float, float, float],
               fix_covariance: np.ndarray | None = None) -> None:
        p = self.params
        mu = [pose[0], pose[1], wrap_scalar(pose[2])]
        var = [p.init_sigma_xy_m ** 2, p.init_sigma_xy_m ** 2, p.init_sigma_heading_rad ** 2]
        if self.scaled:
            mu += [1.0, 1.0]
            var += [p.scale_sigma_v ** 2, p.scale_sigma_w ** 2]
        self.mu = np.array(mu, dtype=np.float64)
        self.P = np.diag(var)
        if fix_covariance is not None:
            self.P[:POSE, :POSE] += fix_covariance

    @property
    def odometry_calibration(self) -> dict[str, float]:
        """The estimated odometry scales ``s_v`` and ``s_w`` (dimensionless); empty without
        them in the state or before the first pose."""
        if self.mu is None or not self.scaled:
            return {}
        return {"s_v": float(self.mu[POSE]), "s_w": float(self.mu[POSE + 1])}

    def _try_start(self, obs: Observation) -> bool:
        init = self.params.init
        if isinstance(obs, PoseObservation) and init == "landmarks":
            return False
        if isinstance(obs, ScanObservation) and init == "laser":
            return False
        fix = start_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map, self.params)
        if fix is None:
            return False
        self._start(*fix)
        return True

    @property
    def initialized(self) -> bool:
        return self.mu is not None

    def predict(self, motion: Motion) -> None:
        if self.mu is None:
            return
        if self.scaled:
            self._predict_scaled(motion)
            return
        x, y, th = self.mu
        c, s = math.cos(th), math.sin(th)
        dx, dy = motion.dx, motion.dy
        self.mu = np.array([x + c * dx - s * dy, y + s * dx + c * dy,
                            wrap_scalar(th + motion.dth)])
        F = np.array([[1.0, 0.0, -s * dx - c * dy], [0.0, 1.0, c * dx - s * dy],
                      [0.0, 0.0, 1.0]])
        sa, sl, st = self.params.noise_sigmas(motion.dist, motion.rot)
        G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        Q = np.diag([sa * sa, sl * sl, st * st])
        self.P = F @ self.P @ F.T + G @ Q @ G.T

    def _predict_scaled(self, motion: Motion) -> None:
        """Prediction of the state ``(x, y, theta, s_v, s_w)``: the odometry motion scaled by
        the current scales (:func:`scaled_motion`), the body-frame motion noise of the odometry
        motion as in the 3-state prediction, and the scales' random walk (variances
        ``scale_walk_v^2 dist`` and ``scale_walk_w^2 rot``)."""
        assert self.mu is not None
        p = self.params
        x, y, th, sv, sw = (float(v) for v in self.mu)
        dx, dy, dth, a, d = scaled_motion(motion.dx, motion.dy, motion.dth, sv, sw)
        c, s = math.cos(th), math.sin(th)
        # world displacement e = s_v d (cos(th + s_w a), sin(th + s_w a))
        ex, ey = c * dx - s * dy, s * dx + c * dy
        self.mu = np.array([x + ex, y + ey, wrap_scalar(th + dth), sv, sw])
        ang = th + sw * a
        F = np.eye(SCALED)
        F[0, 2], F[1, 2] = -ey, ex
        F[0, 3], F[1, 3] = d * math.cos(ang), d * math.sin(ang)
        F[0, 4], F[1, 4], F[2, 4] = -ey * a, ex * a, motion.dth
        sa, sl, st = p.noise_sigmas(motion.dist, motion.rot)
        G = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        P = F @ self.P @ F.T
        P[:POSE, :POSE] += G @ np.diag([sa * sa, sl * sl, st * st]) @ G.T
        P[3, 3] += p.scale_walk_v ** 2 * motion.dist
        P[4, 4] += p.scale_walk_w ** 2 * motion.rot
        self.P = P

    def _kernel_params(self) -> FloatArray:
        """The parameter vector of the compiled loops (:mod:`lgvtool.localize.ekf_kernels`):
        the motion noise here, the measurement model in :class:`Ekf`."""
        from lgvtool.localize import ekf_kernels as k

        p = self.params
        prm = np.zeros(k.N_PARAMS)
        prm[[k.P_NOISE_DIST, k.P_NOISE_LAT, k.P_NOISE_ROT, k.P_NOISE_ROT_PER_M]] = (
            p.noise_dist, p.noise_lat, p.noise_rot, p.noise_rot_per_m)
        return prm

    def run(self, times: FloatArray, observations: Sequence[Observation | None],
            steps: Deltas | None, *, progress: Callable[[int], None] | None = None,
            cloud_period_s: float = 2.0, cloud_size: int = 50) -> EstimateRows:
        """As :meth:`Estimator.run`, one compiled call per observation (and one for all the
        predictions of dead reckoning after its start) when numba is installed; the numpy
        path otherwise and for the state with the odometry scales. The same rows (within the
        last bits: :mod:`lgvtool.localize.ekf_kernels`)."""
        kern = None if self.scaled else gaussian_kernels()
        if kern is None:
            return super().run(times, observations, steps, progress=progress,
                               cloud_period_s=cloud_period_s, cloud_size=cloud_size)
        f64 = np.float64
        n = len(observations)
        ts = np.ascontiguousarray(times, dtype=f64)
        moving = steps is not None and self.uses_motion and n > 1
        moves = tuple(np.ascontiguousarray(a, dtype=f64) for a in (
            (steps.dx, steps.dy, steps.dth, steps.dist, steps.rot) if steps is not None
            and moving else ((),) * 5))
        # the rows (no particles: counts and ESS 0), written by the kernels
        rec = RowRecorder(ts, cloud_period_s, 0)
        rec.particles[:] = 0
        rec.ess[:] = 0.0
        prm = self._kernel_params()
        counts = np.zeros(2, dtype=np.int64)
        mx, my = np.ascontiguousarray(self.map.x), np.ascontiguousarray(self.map.y)
        mids = np.ascontiguousarray(self.map.ids, dtype=np.int64)
        rows = (rec.t, rec.x, rec.y, rec.heading, rec.covariance)
        k = i0 = 0
        report = Reporter(progress)
        tl = ts.tolist()
        coasted = False
        for chunk in chunks(observations):
            c = scan_chunk(chunk, lambda o: o.ids)
            j = 0
            while j < len(chunk) and not coasted:
                i = i0 + j
                o = chunk[j]
                if self.mu is None:  # not started: predictions are no-ops until then
                    if o is not None:
                        self.update(o)
                    if self.mu is not None:
                        kern._record(self.mu, self.P, tl[i], k, *rows)
                        k += 1
                    j += 1
                elif not self.corrects:
                    k = kern.coast(self.mu, self.P, i, *moves, prm, ts, k, *rows)
                    coasted = True
                elif c.kinds[j] == KIND_OTHER:
                    if moving and i > 0:
                        kern._predict(self.mu, self.P, *(float(a[i - 1]) for a in moves), prm)
                    assert o is not None
                    self.update(o)
                    kern._record(self.mu, self.P, tl[i], k, *rows)
                    k += 1
                    j += 1
                else:
                    # the scans and times without an observation from here, in one call
                    j, k = kern.track(self.mu, self.P, j, i0, *moves, c.kinds, c.offs, c.q,
                                      c.u, c.ranges, c.ints, mx, my, mids, prm, counts, ts, k,
                                      *rows)
            i0 += len(chunk)
            report.at(i0)
            if coasted:
                break
        self._count_kernel_updates(int(counts[0]), int(counts[1]))
        report.at(n, last=True)
        rec.k = k
        return rec.rows()

    def _count_kernel_updates(self, accepted: int, rejected: int) -> None:
        """Add the reflectors the compiled loop accepted and rejected (:class:`Ekf`)."""

    def estimate(self) -> Estimate | None:
        if self.mu is None:
            return None
        P = self.P[:POSE, :POSE]
        return Estimate(float(self.mu[0]), float(self.mu[1]), float(self.mu[2]),
                        0.5 * (P + P.T))


class Ekf(GaussianPoseEstimator):
    """Extended Kalman filter: odometry + gyro prediction, reflector or NAV pose updates."""

    name = "ekf"
    Params = EkfParams
    summary = "EKF: odometry + gyro, reflector range/bearing or NAV pose updates, chi2 gating"

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self._gate2 = chi2_quantile(self.params.gate_probability, 2)
        self._gate3 = chi2_quantile(self.params.gate_probability, 3)
        self.rejected = 0
        self.accepted = 0

    def _kernel_params(self) -> FloatArray:
        from lgvtool.localize import ekf_kernels as k

        p = self.params
        prm = super()._kernel_params()
        prm[[k.P_SIGMA_RANGE, k.P_SIGMA_RANGE_PER_M, k.P_SIGMA_BEARING, k.P_GATE2,
             k.P_USE_IDS]] = (p.sigma_range_m, p.sigma_range_per_m, p.sigma_bearing_rad,
                              self._gate2, 1.0 if p.use_ids else 0.0)
        return prm

    def _count_kernel_updates(self, accepted: int, rejected: int) -> None:
        self.accepted += accepted
        self.rejected += rejected

    def update(self, obs: Observation) -> bool:
        if self.mu is None:
            return self._try_start(obs)
        if isinstance(obs, PoseObservation):
            return self._update_pose(obs)
        return self._update_scan(obs)

    def _update_pose(self, obs: PoseObservation) -> bool:
        p = self.params
        x, y, th = (float(v) for v in self.mu[:POSE])  # type: ignore[index]
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        nu = np.array([obs.x - (x + c * mx - s * my), obs.y - (y + s * mx + c * my),
                       wrap_scalar(obs.heading - th)])
        n = len(self.P)
        H = np.zeros((3, n))
        H[:, :POSE] = [[1.0, 0.0, -s * mx - c * my], [0.0, 1.0, c * mx - s * my],
                       [0.0, 0.0, 1.0]]
        R = np.diag([p.sigma_pose_xy_m ** 2, p.sigma_pose_xy_m ** 2,
                     p.sigma_pose_heading_rad ** 2])
        S = H @ self.P @ H.T + R
        if float(nu @ np.linalg.solve(S, nu)) > self._gate3:
            self.rejected += 1
            return False
        K = self.P @ H.T @ np.linalg.inv(S)
        self.mu = self.mu + K @ nu
        self.mu[2] = wrap_scalar(float(self.mu[2]))
        IKH = np.eye(n) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self.accepted += 1
        return True

    def _update_scan(self, obs: ScanObservation) -> bool:
        if len(obs) == 0 or len(self.map) == 0:
            return False
        p = self.params
        x, y, th = (float(v) for v in self.mu[:POSE])  # type: ignore[index]
        c, s = math.cos(th), math.sin(th)
        # map reflectors in the body frame h[j], and each sensor origin o[k] (body frame)
        ex, ey = self.map.x - x, self.map.y - y
        hx, hy = c * ex + s * ey, -s * ex + c * ey
        origin = obs.q - obs.ranges * obs.u
        ray = np.angle(obs.u)
        # predicted vector sensor -> reflector for every (k, j): v = h[j] - o[k]
        vx = hx[None, :] - origin.real[:, None]
        vy = hy[None, :] - origin.imag[:, None]
        r2 = np.maximum(vx * vx + vy * vy, 1e-12)
        rng = np.sqrt(r2)
        nr = obs.ranges[:, None] - rng
        nb = wrap_angle(ray[:, None] - np.arctan2(vy, vx))
        # Jacobians of (range, ray angle) wrt (x, y, theta); dv/dx = (-c, s), dv/dy = (-s, -c),
        # dv/dtheta = (hy, -hx)
        dvx: tuple[Any, ...] = (-c, -s, hy[None, :])
        dvy: tuple[Any, ...] = (s, -c, -hx[None, :])
        Hr = [(vx * a + vy * b) / rng for a, b in zip(dvx, dvy, strict=True)]
        Hb = [(vx * b - vy * a) / r2 for a, b in zip(dvx, dvy, strict=True)]
        P = self.P
        sr2 = p.sigma_range_m ** 2 + (p.sigma_range_per_m * obs.ranges[:, None]) ** 2
        sb2 = p.sigma_bearing_rad ** 2

        def quad(a: list[np.ndarray], b: list[np.ndarray]) -> np.ndarray:
            total: np.ndarray = sum(a[i] * P[i, j] * b[j] for i in range(3) for j in range(3))
            return total

        srr = quad(Hr, Hr) + sr2
        srb = quad(Hr, Hb)
        sbb = quad(Hb, Hb) + sb2
        det = srr * sbb - srb * srb
        d2 = (sbb * nr * nr - 2.0 * srb * nr * nb + srr * nb * nb) / det
        k_idx = np.arange(len(obs))
        known = (obs.map_index(self.map) if p.use_ids
                 else np.full(len(obs), -1, dtype=np.int64))
        j = np.where(known >= 0, known, np.argmin(d2, axis=1))
        ok = d2[k_idx, j] <= self._gate2
        self.rejected += int((~ok).sum())
        if not ok.any():
            return False
        kk, jj = k_idx[ok], j[ok]
        n = len(kk)
        # the measurements depend on the pose only: zero columns for the odometry scales
        H = np.zeros((n, 2, len(P)))
        for i in range(3):
            H[:, 0, i] = np.broadcast_to(Hr[i], vx.shape)[kk, jj]
            H[:, 1, i] = np.broadcast_to(Hb[i], vx.shape)[kk, jj]
        nu = np.stack([nr[kk, jj], nb[kk, jj]], axis=1)
        # information form with R = diag(sr2, sb2): Y = sum H^T R^-1 H, yv = sum H^T R^-1 nu
        w = np.empty((n, 2))
        w[:, 0] = 1.0 / np.broadcast_to(sr2, vx.shape)[kk, jj]
        w[:, 1] = 1.0 / sb2
        HtRi = H.transpose(0, 2, 1) * w[:, None, :]
        Y = np.einsum("kia,kaj->ij", HtRi, H)
        yv = np.einsum("kia,ka->i", HtRi, nu)
        P_new = np.linalg.inv(np.linalg.inv(self.P) + Y)
        self.mu = self.mu + P_new @ yv
        self.mu[2] = wrap_scalar(float(self.mu[2]))
        self.P = 0.5 * (P_new + P_new.T)
        self.accepted += n
        return True
