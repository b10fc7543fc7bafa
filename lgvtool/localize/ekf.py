"""``ekf``: extended Kalman filter on the pose of O.

Prediction: the body-frame odometry motion (encoders + gyro by default) composed onto the
mean, ``P <- F P F^T + G Q G^T`` with the motion noise of :mod:`lgvtool.localize.noise`.

Update from a reflector scan: each reflector's measured range and bearing are compared with
the range and bearing of the map reflector seen from the sensor (its origin and heading in the
body frame include the mounting offset and, when de-skewed, the motion since the reflector was
measured), with noise ``diag(sigma_range^2, sigma_bearing^2)``. Association
(:mod:`lgvtool.localize.association`): the map reflector of the reflector's id when its
squared Mahalanobis distance is inside the gate, the chi-square quantile (2 dof) of
``gate_probability``; otherwise (no id, an id not in the map, or a wrong one) the map reflector
with the smallest Mahalanobis distance, inside the gate, unless a second one is inside it too
at less than ``ambiguity_ratio`` times that distance (ambiguous: dropped). A reflector with
nothing inside the gate is rejected as an outlier. The accepted reflectors are applied together in
information form (exact for the linearised model). A filter that has lost the vehicle (it
slipped, was lifted, or started confidently in the wrong place) rejects every reflector from
then on; so once scans of at least two reflectors have found nothing for ``scan_recover_s``,
the pose restarts at the next such scan's landmark fix, as the start does (:meth:`Ekf.recover`,
:func:`lost_scan`). Update from a NAV pose: ``h = pose of the
head`` (eq. 5 inverted), its noise the rotating-head pose model's covariance at the pose's
motion (:mod:`lgvtool.localize.pose_model`), behind its robust gate (3 dof; refused poses move
nothing, and after ``pose_reanchor_s`` of them the state is re-anchored at the pose).

Odometry scale factors (``odometry_scales``, off by default): the state grows to
``(x, y, theta, s_v, s_w)``, where ``s_v`` multiplies the odometry's distance and ``s_w`` its
heading change (dimensionless, prior mean 1). Odometry that is biased rather than noisy, e.g.
commanded velocities of a robot that travels and turns less than commanded, then becomes a
state the observations estimate: they see the pose only, and reach the scales through the
correlation the prediction builds between them and the pose. The scales follow a random walk
whose variance grows with the distance travelled and the angle turned (:func:`scaled_motion`,
:meth:`Ekf._predict_scaled`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Protocol, TypeVar, Unpack

import numpy as np

from lgvtool.angles import wrap_angle, wrap_scalar
from lgvtool.localize.association import AMBIGUOUS, BY_ID, associate
from lgvtool.localize.camera_fix import start_fix
from lgvtool.localize.estimator import (
    Estimate,
    EstimateRows,
    Estimator,
    EstimatorContext,
    Motion,
    Observation,
)
from lgvtool.localize.gaussian_backend import GaussianBackend, GaussianModel
from lgvtool.localize.kernel_choice import gaussian_backend
from lgvtool.localize.noise import MotionParams
from lgvtool.localize.observations import PoseObservation, ScanObservation, SourceParams
from lgvtool.localize.params import param
from lgvtool.localize.pose_model import PoseGate, PoseModelParams, pose_covariance
from lgvtool.quantiles import chi2_quantile

if TYPE_CHECKING:
    from lgvtool.localize.estimator import FloatArray
    from lgvtool.localize.motion import Deltas

POSE = 3
"""Size of the pose part ``(x, y, theta)`` of the state."""
SCALED = 5
"""Size of the state with the odometry scales, ``(x, y, theta, s_v, s_w)``."""
ITERATION_STEP = 1e-6
"""The iterated reflector update stops once an iteration moves the pose by less than this in
every coordinate (m, m, rad)."""

@dataclass(frozen=True)
class GaussianInitParams:
    """How a Gaussian estimator starts."""

    init: str = param("auto", "first pose: auto (first NAV pose or landmark fix, whichever "
                      "comes first), laser (first valid NAV pose), landmarks (first scan that "
                      "fixes the pose: two reflector ids that agree, or three reflectors "
                      "matched on the layout by their geometry); a caller's initial pose "
                      "always wins", choices=("auto", "laser", "landmarks"))
    init_sigma_xy_m: float = param(0.05, "initial position standard deviation, m", minimum=0.0)
    init_sigma_heading_rad: float = param(0.02, "initial heading standard deviation, rad",
                                          minimum=0.0)


@dataclass(frozen=True)
class EkfParams(MotionParams, SourceParams, GaussianInitParams, PoseModelParams):
    """Parameters of the EKF."""

    sigma_range_m: float = param(0.02, "range noise of a reflector measurement, m",
                                 minimum=1e-6)
    sigma_bearing_rad: float = param(0.005, "bearing noise of a reflector measurement, rad",
                                     minimum=1e-9)
    sigma_range_per_m: float = param(0.0, "range noise that grows with the range (a scale "
                                     "error), added in quadrature, m per m", minimum=0.0)
    sigma_pose_xy_m: float = param(0.03, "position noise of a NAV pose (with the "
                                   "rotating-head model: at standstill), m", minimum=1e-6)
    sigma_pose_heading_rad: float = param(0.005, "heading noise of a NAV pose (with the "
                                          "rotating-head model: at standstill), rad",
                                          minimum=1e-9)
    gate_probability: float = param(0.99, "chi-square gate (2 degrees of freedom for a "
                                    "reflector, 3 for a NAV pose): innovations less likely "
                                    "than this are rejected, and a reflector's id is used only "
                                    "when its layout reflector is inside this gate (else the "
                                    "reflector is associated as if it had none)",
                                    minimum=0.5, maximum=0.999999)
    ambiguity_ratio: float = param(2.0, "a reflector without a usable id is dropped as "
                                   "ambiguous when a second layout reflector is inside the gate "
                                   "at less than this times the Mahalanobis distance of the "
                                   "nearest, dimensionless (1: never)", minimum=1.0)
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
    update_iterations: int = param(1, "linearisations of each reflector update: 1 is the "
                                   "EKF's single update at the prediction; more relinearise "
                                   "the range and bearing at the last result until it moves "
                                   "less than 1e-6 m and rad (the iterated EKF, Gauss-Newton "
                                   "on the frame's posterior mode; the association stays the "
                                   "prediction's), for measurements far from linear over the "
                                   "prior, e.g. a camera after a long stretch without "
                                   "landmarks", unit="", minimum=1, maximum=50)
    scan_recover_s: float = param(2.0, "recovery on reflector scans: once every scan of at "
                                  "least two reflectors has had none accepted (and no NAV pose "
                                  "was) for this long, "
                                  "the next such scan that fixes a pose (as the start does, "
                                  "init_fix) restarts the pose there with the start's "
                                  "uncertainty, the odometry scales kept; 0: never, s",
                                  minimum=0.0)


class GaussianParams(Protocol):
    """What :class:`GaussianPoseEstimator` reads of its parameters (a start and the motion
    noise: :class:`GaussianInitParams`, :class:`lgvtool.localize.noise.MotionParams`)."""

    @property
    def init(self) -> str: ...
    @property
    def init_sigma_xy_m(self) -> float: ...
    @property
    def init_sigma_heading_rad(self) -> float: ...
    @property
    def noise_dist(self) -> float: ...
    @property
    def noise_lat(self) -> float: ...
    @property
    def noise_rot(self) -> float: ...
    @property
    def noise_rot_per_m(self) -> float: ...
    def noise_sigmas(self, dist: float, rot: float) -> tuple[float, float, float]: ...


#: the parameters of a Gaussian estimator (covariant, as :data:`lgvtool.localize.estimator.P`:
#: an ``Ekf`` is a ``GaussianPoseEstimator[GaussianParams]``)
GP = TypeVar("GP", bound=GaussianParams, covariant=True)


def lost_scan(lost: FloatArray, t: float, reflectors: int, accepted: bool,
              recover_s: float) -> bool:
    """Keep ``lost[0]``, the time (s) of the first scan of at least two reflectors with none
    accepted since the last scan with one accepted or the last NAV pose taken (NaN: none;
    :meth:`Ekf._update_pose` clears it too), after a scan at ``t`` (s)
    of ``reflectors`` reflectors; True when a recovery is due: such a scan has come
    ``recover_s`` (s, 0: never) or more after the first. A scan of one reflector says
    nothing either way (one stray reflection is no sign of being lost)."""
    if accepted:
        lost[0] = math.nan
        return False
    if reflectors < 2:
        return False
    if math.isnan(lost[0]):
        lost[0] = t
        return False
    return recover_s > 0.0 and t - lost[0] >= recover_s


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


class GaussianPoseEstimator(Estimator[GP]):
    """Shared state and prediction of the Gaussian estimators (EKF, dead reckoning); a replay
    runs through the estimator's backend (:mod:`lgvtool.localize.gaussian_backend`)."""

    kernel_family: ClassVar[str] = "gaussian"
    #: False when observations after the start never change the state (dead reckoning)
    corrects: ClassVar[bool] = True

    def __init__(self, params: GP | None = None, *, backend: GaussianBackend | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, **context)
        #: how a replay runs (the numpy reference or the compiled kernels), chosen once
        self.backend = backend if backend is not None else gaussian_backend()
        #: True when the state carries the odometry scales ``(s_v, s_w)`` after the pose
        self.scaled = bool(getattr(self.params, "odometry_scales", False))
        n = SCALED if self.scaled else POSE
        self.mu: np.ndarray | None = None
        self.P = np.zeros((n, n))
        #: time of the first scan with nothing accepted since the last one with a reflector
        #: accepted, s (NaN: none; :func:`lost_scan`); an array, which the compiled loop keeps
        self.scan_lost = np.full(1, math.nan)
        if self.initial_pose is not None:
            self._start(self.initial_pose)

    def _start(self, pose: tuple[float, float, float],
               fix_covariance: np.ndarray | None = None) -> None:
        p = self.params
        mu = [pose[0], pose[1], wrap_scalar(pose[2])]
        var = [p.init_sigma_xy_m ** 2, p.init_sigma_xy_m ** 2, p.init_sigma_heading_rad ** 2]
        extra_mu, extra_var = self._scale_prior()
        mu += extra_mu
        var += extra_var
        self.mu = np.array(mu, dtype=np.float64)
        self.P = np.diag(var)
        if fix_covariance is not None:
            self.P[:POSE, :POSE] += fix_covariance

    def _scale_prior(self) -> tuple[list[float], list[float]]:
        """Means and variances of the state after the pose at the start (none here: the
        odometry scales are the EKF's, :meth:`Ekf._scale_prior`)."""
        return [], []

    def recover(self, obs: Observation) -> bool:
        """Restart the pose from a landmark fix of ``obs`` after scans have found nothing
        (:meth:`Ekf.recover`); True when it did. This one never does."""
        return False

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

    def model(self) -> GaussianModel:
        """What a replay of this estimator computes with: the motion noise (the reflector
        noise and gate of :class:`Ekf`)."""
        p = self.params
        return GaussianModel(p.noise_dist, p.noise_lat, p.noise_rot, p.noise_rot_per_m)

    def run(self, times: FloatArray, observations: Sequence[Observation | None],
            steps: Deltas | None, *, progress: Callable[[int], None] | None = None,
            cloud_period_s: float = 2.0, cloud_size: int = 50) -> EstimateRows:
        """As :meth:`Estimator.run`, run by the estimator's backend (step by step, or in
        compiled chunks: the same rows within the last bits)."""
        return self.backend.run(self, times, observations, steps, progress=progress,
                                cloud_period_s=cloud_period_s, cloud_size=cloud_size)

    def count_reflectors(self, accepted: int, rejected: int, id_rejected: int,
                         ambiguous: int) -> None:
        """Add the reflectors a replay accepted, rejected, whose id it rejected and that it
        dropped as ambiguous (:class:`Ekf` counts them)."""

    def estimate(self) -> Estimate | None:
        if self.mu is None:
            return None
        P = self.P[:POSE, :POSE]
        return Estimate(float(self.mu[0]), float(self.mu[1]), float(self.mu[2]),
                        0.5 * (P + P.T))


class Ekf(GaussianPoseEstimator[EkfParams]):
    """Extended Kalman filter: odometry + gyro prediction, reflector or NAV pose updates."""

    name = "ekf"
    Params = EkfParams
    summary = "EKF: odometry + gyro, reflector range/bearing or NAV pose updates, chi2 gating"

    def __init__(self, params: EkfParams | None = None, *,
                 backend: GaussianBackend | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, backend=backend, **context)
        self._gate2 = chi2_quantile(self.params.gate_probability, 2)
        self._gate3 = chi2_quantile(self.params.gate_probability, 3)
        #: the robust gate on NAV poses (refused poses, re-anchoring)
        self.pose_gate = PoseGate(self._gate3, self.params.pose_reanchor_s, self.events)
        self.rejected = 0
        self.accepted = 0
        #: reflectors whose id failed its gate (then associated without it, or dropped)
        self.id_rejected = 0
        #: reflectors dropped as ambiguous (two layout reflectors alike inside the gate)
        self.ambiguous = 0

    def _scale_prior(self) -> tuple[list[float], list[float]]:
        if not self.scaled:
            return [], []
        p = self.params
        return [1.0, 1.0], [p.scale_sigma_v ** 2, p.scale_sigma_w ** 2]

    def predict(self, motion: Motion) -> None:
        if self.scaled and self.mu is not None:
            self._predict_scaled(motion)
            return
        super().predict(motion)

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

    def model(self) -> GaussianModel:
        p = self.params
        return GaussianModel(p.noise_dist, p.noise_lat, p.noise_rot, p.noise_rot_per_m,
                             p.sigma_range_m, p.sigma_range_per_m, p.sigma_bearing_rad,
                             self._gate2, p.use_ids, p.ambiguity_ratio, p.scan_recover_s,
                             p.update_iterations)

    def recover(self, obs: Observation) -> bool:
        """After scans have found nothing for ``scan_recover_s`` (:func:`lost_scan`): the pose
        restarted at the landmark fix of the scan ``obs`` (:func:`start_fix`, as the start:
        the reflector ids when they agree, else the scan's geometry on the layout), with the
        start's uncertainty plus the fix's covariance and no correlation with the odometry
        scales, which keep their estimate and variance. False (nothing changed) when the scan
        gives no fix."""
        if self.mu is None or not isinstance(obs, ScanObservation):
            return False
        fix = start_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map, self.params)
        if fix is None:
            return False
        (x, y, th), cov = fix
        p = self.params
        self.events.append((obs.t, "restarted", (
            f"restarted at a scan's landmark fix {math.hypot(x - self.mu[0], y - self.mu[1]):.2f}"
            f" m from its estimate, after {obs.t - self.scan_lost[0]:.1f} s of scans that "
            f"found nothing")))
        self.mu[:POSE] = [x, y, wrap_scalar(th)]
        P = np.zeros_like(self.P)
        P[:POSE, :POSE] = np.diag([p.init_sigma_xy_m ** 2, p.init_sigma_xy_m ** 2,
                                   p.init_sigma_heading_rad ** 2])
        if cov is not None:
            P[:POSE, :POSE] += cov
        P[POSE:, POSE:] = self.P[POSE:, POSE:]
        self.P = P
        self.scan_lost[0] = math.nan
        return True

    def count_reflectors(self, accepted: int, rejected: int, id_rejected: int,
                         ambiguous: int) -> None:
        self.accepted += accepted
        self.rejected += rejected
        self.id_rejected += id_rejected
        self.ambiguous += ambiguous

    def update(self, obs: Observation) -> bool:
        if self.mu is None:
            return self._try_start(obs)
        if isinstance(obs, PoseObservation):
            return self._update_pose(obs)
        return self._update_scan(obs)

    def _update_pose(self, obs: PoseObservation) -> bool:
        x, y, th = (float(v) for v in self.mu[:POSE])  # type: ignore[index]
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        nu = np.array([obs.x - (x + c * mx - s * my), obs.y - (y + s * mx + c * my),
                       wrap_scalar(obs.heading - th)])
        n = len(self.P)
        H = np.zeros((3, n))
        H[:, :POSE] = [[1.0, 0.0, -s * mx - c * my], [0.0, 1.0, c * mx - s * my],
                       [0.0, 0.0, 1.0]]
        R = self.pose_noise(obs, th)
        S = H @ self.P @ H.T + R
        verdict = self.pose_gate.judge(obs.t, float(nu @ np.linalg.solve(S, nu)))
        if verdict == "refuse":
            self.rejected += 1
            return False
        # a pose taken: the filter is not lost, whatever the scans found (lost_scan)
        self.scan_lost[0] = math.nan
        if verdict == "reanchor":
            self._reanchor(obs, R)
            return True
        K = self.P @ H.T @ np.linalg.inv(S)
        self.mu = self.mu + K @ nu
        self.mu[2] = wrap_scalar(float(self.mu[2]))
        IKH = np.eye(n) - K @ H
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T
        self.accepted += 1
        return True

    def pose_noise(self, obs: PoseObservation, heading: float) -> np.ndarray:
        """Covariance of a NAV head pose (3 x 3: m^2, m rad, rad^2): the rotating-head model's
        at the observation's motion (:func:`lgvtool.localize.pose_model.pose_covariance`,
        ``heading`` rad), or the plain ``sigma_pose_xy_m``, ``sigma_pose_heading_rad``."""
        p = self.params
        if p.pose_model == "rotating-head":
            return pose_covariance(heading, obs.v, obs.omega, self.vehicle.nav_x,
                                   self.vehicle.nav_y, p.sigma_pose_xy_m,
                                   p.sigma_pose_heading_rad, p)
        return np.diag([p.sigma_pose_xy_m ** 2, p.sigma_pose_xy_m ** 2,
                        p.sigma_pose_heading_rad ** 2])

    def _reanchor(self, obs: PoseObservation, R: np.ndarray) -> None:
        """Put the pose at the NAV pose ``obs`` converted to O, its covariance the pose's
        ``R`` (m, rad) carried through the lever arm (the odometry scales keep theirs)."""
        th = obs.heading
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        assert self.mu is not None
        self.mu[:POSE] = [obs.x - c * mx + s * my, obs.y - s * mx - c * my, wrap_scalar(th)]
        # d(O)/d(head pose): identity plus the lever arm's turn
        J = np.array([[1.0, 0.0, s * mx + c * my], [0.0, 1.0, -c * mx + s * my],
                      [0.0, 0.0, 1.0]])
        n = len(self.P)
        P = np.zeros((n, n))
        P[:POSE, :POSE] = J @ R @ J.T
        if n > POSE:
            P[POSE:, POSE:] = self.P[POSE:, POSE:]
        self.P = P
        self.accepted += 1

    def _update_scan(self, obs: ScanObservation) -> bool:
        """The reflector update (:meth:`_correct_scan`), then the recovery when scans have
        found nothing for ``scan_recover_s`` (:meth:`recover`)."""
        accepted = self._correct_scan(obs)
        if lost_scan(self.scan_lost, obs.t, len(obs), accepted, self.params.scan_recover_s):
            return self.recover(obs)
        return accepted

    def _scan_geometry(self, pose: tuple[float, float, float], obs: ScanObservation
                       ) -> tuple[np.ndarray, np.ndarray, list[np.ndarray], list[np.ndarray]]:
        """Every (measured reflector k, map reflector j) of ``obs`` seen from ``pose`` (x, y m,
        heading rad): the range and bearing innovations (m, rad; K x J) and the Jacobians of
        the predicted range and ray angle with respect to x, y and theta (three K x J arrays
        each: 1, 1, m per rad for the range; 1/m, 1/m, 1 for the angle)."""
        x, y, th = pose
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
        Hr = [np.broadcast_to((vx * a + vy * b) / rng, vx.shape)
              for a, b in zip(dvx, dvy, strict=True)]
        Hb = [np.broadcast_to((vx * b - vy * a) / r2, vx.shape)
              for a, b in zip(dvx, dvy, strict=True)]
        return nr, nb, Hr, Hb

    def _correct_scan(self, obs: ScanObservation) -> bool:
        if len(obs) == 0 or len(self.map) == 0:
            return False
        p = self.params
        mu0 = self.mu
        assert mu0 is not None
        prior = (float(mu0[0]), float(mu0[1]), float(mu0[2]))
        nr, nb, Hr, Hb = self._scan_geometry(prior, obs)
        P = self.P
        sr2 = np.broadcast_to(p.sigma_range_m ** 2
                              + (p.sigma_range_per_m * obs.ranges[:, None]) ** 2, nr.shape)
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
        # the id's reflector when inside the gate, else the nearest inside it unless a second
        # is nearly as near (lgvtool.localize.association)
        j, how = associate(d2, known, self._gate2, p.ambiguity_ratio)
        ok = j >= 0
        self.rejected += int((~ok).sum())
        self.id_rejected += int(((known >= 0) & (how != BY_ID)).sum())
        self.ambiguous += int((how == AMBIGUOUS).sum())
        if not ok.any():
            return False
        kk, jj = k_idx[ok], j[ok]
        n = len(kk)
        # information form with R = diag(sr2, sb2): Y = sum H^T R^-1 H, yv = sum H^T R^-1 nu
        w = np.empty((n, 2))
        w[:, 0] = 1.0 / sr2[kk, jj]
        w[:, 1] = 1.0 / sb2
        P_inv = np.linalg.inv(P)
        mu = mu0
        for it in range(p.update_iterations):
            if it > 0:
                # relinearised at the last result (the iterated EKF: Gauss-Newton on the
                # frame's posterior mode, the association kept)
                nr, nb, Hr, Hb = self._scan_geometry(
                    (float(mu[0]), float(mu[1]), float(mu[2])), obs)
            # the measurements depend on the pose only: zero columns for the odometry scales
            H = np.zeros((n, 2, len(P)))
            for i in range(3):
                H[:, 0, i] = Hr[i][kk, jj]
                H[:, 1, i] = Hb[i][kk, jj]
            nu = np.stack([nr[kk, jj], nb[kk, jj]], axis=1)
            if it > 0:
                d = mu - mu0
                d[2] = wrap_scalar(float(d[2]))
                nu = nu + np.einsum("kai,i->ka", H, d)
            HtRi = H.transpose(0, 2, 1) * w[:, None, :]
            Y = np.einsum("kia,kaj->ij", HtRi, H)
            yv = np.einsum("kia,ka->i", HtRi, nu)
            P_new = np.linalg.inv(P_inv + Y)
            new = mu0 + P_new @ yv
            new[2] = wrap_scalar(float(new[2]))
            step = new[:POSE] - mu[:POSE]
            step[2] = wrap_scalar(float(step[2]))
            mu = new
            if float(np.abs(step).max()) < ITERATION_STEP:
                break
        self.mu = mu
        self.P = 0.5 * (P_new + P_new.T)
        self.accepted += n
        return True
