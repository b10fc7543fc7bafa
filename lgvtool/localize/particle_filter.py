"""``pf``: the paper's filter with the improvements expected of an AMCL-class localiser.

Each improvement is a switch (``--set pf.<name>=false`` turns it off):

- ``log_weights``: weights are kept and multiplied as logarithms and normalised with
  log-sum-exp, so a long scan of sharp likelihoods never underflows to all-zero weights.
- ``resample = ess``: low-variance (systematic) resampling only when the effective sample size
  ``1 / sum w^2`` drops below ``ess_threshold`` times the particle count (``always``: after
  every update, like the paper).
- ``kld``: KLD-sampling chooses the particle count at each resampling between
  ``min_particles`` and ``particles`` from the number of occupied histogram bins.
- ``recovery``: augmented MCL. Short- and long-term averages of the measurement likelihood per
  reflector (``alpha_fast``, ``alpha_slow``) decide the fraction ``max(0, 1 - w_fast/w_slow)``
  of particles re-drawn uniformly over the work area when the likelihood collapses
  (kidnapping, a wrong convergence).
- ``deskew``: each reflector is placed at the odometry pose of its own measurement time within
  the head revolution (done by the replay driver, see
  :func:`lgvtool.localize.observations.scan_observations`).
- ``outlier``: each reflector's likelihood is a mixture ``(1 - eps) N + eps U``: a Gaussian in
  range (``sigma_range_m``) and bearing (``sigma_bearing_rad``, i.e. ``r sigma_b`` across the
  ray) plus a uniform density over a disc of radius ``outlier_gate_m``, so a false reflector
  (a shiny object) or a wrong association cannot zero a good particle.
- association (:mod:`lgvtool.localize.association`, per particle): a reflector's id is a hint
  the navigation device gives, sometimes wrong and often absent. It is used only when the id's
  layout reflector lies inside the gate (``association_gate_probability``: a radius of 4.3 x
  the larger of the reflector's range and cross-range noise); otherwise the reflector goes to
  its nearest layout reflector inside the gate, and counts as an outlier (the mixture's floor)
  when the gate holds none or two alike (``ambiguity_ratio``). A particle that puts a reflector
  on another layout reflector than its id's is weighed by ``id_error_prob / ((J - 1)(1 -
  id_error_prob))``, so the ids still tell the particles apart where they agree. Recovery and
  the start fix the pose from the scan's geometry when its ids are missing or disagree
  (:func:`lgvtool.localize.fix.scan_fix`).
- ``start_particles`` (off by default): a uniform start with more particles, kept for the first
  ``start_updates`` updates, then resampled down to ``particles``.
- ``fix_reset_probability`` (off by default): a frame that the cloud's mean does not explain,
  in none of its landmarks, whose landmark fix fits its own measurements and lies outside the
  cloud's region, re-draws ``fix_reset_fraction`` of the particles around that fix (a confident
  cloud in the wrong place; a misread id contradicts the cloud in its own landmark only).
- ``proposal = ekf`` (off by default): the particles are moved by the noise-free odometry
  between frames and carry the accumulated motion noise as a Gaussian each; a frame's
  landmarks update every particle's Gaussian by one Kalman step, the particle is drawn from
  that posterior and weighted by prior x likelihood / proposal
  (:mod:`lgvtool.localize.pf_proposal`), so that a broad prediction (a large heading noise)
  needs no particle in every heading it spans.
- ``proposal = marginal`` (off by default): Rao-Blackwellised over the pose. As with ``ekf``,
  each particle carries a Gaussian over its pose, moved by the noise-free odometry (its own
  odometry scales); a frame's Kalman step moves it to the posterior mean and keeps the
  posterior covariance instead of drawing from it, and weighs it by the evidence of the
  frame (the linearised marginal likelihood, corrected at the mean by the outlier mixture).
  Each particle is then an EKF of the pose conditioned on its own odometry-scale trajectory,
  and the particles sample what the EKF linearises least well: the scales.
- pose-only observations: with no reflector scans in the log (or ``observations = poses``) the
  particles are weighed against the NAV head pose with the Gaussian of the rotating-head pose
  model's covariance (:mod:`lgvtool.localize.pose_model`; ``pose_model = plain``:
  ``sigma_pose_xy_m`` and ``sigma_pose_heading_rad``) and the same outlier mixture, behind the
  robust gate (a pose far off is refused; refused for ``pose_reanchor_s``, the particles are
  drawn afresh around it).

Unlike the paper's product of one Gaussian over the summed distances, reflectors are treated as
independent measurements (the likelihood is the product of the per-reflector terms).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Unpack

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.camera_fix import residual_chi2, residual_chi2_each, start_fix
from lgvtool.localize.estimator import (
    Estimate,
    EstimateRows,
    EstimatorContext,
    Motion,
    Observation,
)
from lgvtool.localize.kld import KldSizing
from lgvtool.localize.noise import MotionParams, MotionSize
from lgvtool.localize.observations import PoseObservation, ScanObservation, SourceParams
from lgvtool.localize.params import param
from lgvtool.localize.particle_backend import (
    ParticleArrays,
    ParticleBackend,
    Survivors,
    TrackSettings,
    TrackState,
)
from lgvtool.localize.particles import ParticleInitParams, ParticleSet
from lgvtool.localize.pf_likelihood import ScanModel, associate, mixed
from lgvtool.localize.pf_proposal import (
    Proposal,
    gaussian_offsets,
    kalman_proposal,
    ray_residuals,
)
from lgvtool.localize.pose_model import PoseGate, PoseModelParams, pose_covariance
from lgvtool.localize.resampling import (
    RESAMPLERS,
    effective_sample_size,
    uniform_poses,
)
from lgvtool.quantiles import chi2_quantile

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class PfParams(MotionParams, SourceParams, ParticleInitParams, PoseModelParams):
    """Parameters of the improved particle filter."""

    particles: int = param(2000, "particles at the start, and the most KLD-sampling may use "
                           "(the fixed count when kld is off)", minimum=1)
    min_particles: int = param(100, "the fewest particles KLD-sampling may use", minimum=1)
    sigma_range_m: float = param(0.02, "range noise of a reflector, m", minimum=1e-6)
    sigma_bearing_rad: float = param(0.005, "bearing noise of a reflector, rad", minimum=1e-9)
    sigma_range_per_m: float = param(0.0, "range noise that grows with the range (a scale "
                                     "error), added in quadrature, m per m", minimum=0.0)
    sigma_pose_xy_m: float = param(0.03, "position noise of a NAV pose observation (with the "
                                   "rotating-head model: at standstill), m", minimum=1e-6)
    sigma_pose_heading_rad: float = param(0.005, "heading noise of a NAV pose observation "
                                          "(with the rotating-head model: at standstill), rad",
                                          minimum=1e-9)
    pose_gate_probability: float = param(0.99, "robust gate on NAV poses: a pose whose squared "
                                         "Mahalanobis distance from the estimate (the pose's "
                                         "and the cloud's covariances added) exceeds the "
                                         "chi-square quantile (3 dof) of this probability is "
                                         "refused", minimum=0.5, maximum=0.999999)
    log_weights: bool = param(True, "keep weights as logarithms")
    resample: str = param("ess", "when to resample: ess (when the effective sample size drops) "
                          "or always", choices=("ess", "always"))
    ess_threshold: float = param(0.5, "resample when ESS < this x particle count", minimum=0.0,
                                 maximum=1.0)
    resampler: str = param("low-variance", "resampling scheme",
                           choices=("low-variance", "multinomial"))
    kld: bool = param(True, "adapt the particle count by KLD-sampling")
    kld_epsilon: float = param(0.02, "KLD-sampling error bound", minimum=1e-6)
    kld_delta: float = param(0.01, "KLD-sampling: the bound holds with probability 1 - delta",
                             minimum=1e-9, maximum=0.5)
    kld_bin_m: float = param(0.25, "KLD histogram bin size in x and y, m", minimum=1e-6)
    kld_bin_rad: float = param(0.1, "KLD histogram bin size in heading, rad", minimum=1e-6)
    recovery: bool = param(True, "recovery: augmented-MCL injection, and sensor resetting when "
                           "the likelihood shows the filter is lost")
    inject: str = param("sensor", "where recovery particles come from: sensor (around the pose "
                        "the observation itself fixes: a landmark fix from reflector ids that "
                        "agree or from the scan's geometry matched on the layout, or the NAV "
                        "pose; uniform when it fixes none) or uniform",
                        choices=("sensor", "uniform"))
    reset_likelihood: float = param(1.0, "sensor resetting: mean likelihood per measurement "
                                    "(density, per m^2 for a reflector) below which the filter "
                                    "counts as lost", minimum=0.0)
    alpha_slow: float = param(0.001, "long-term likelihood average rate", minimum=0.0,
                              maximum=1.0)
    alpha_fast: float = param(0.1, "short-term likelihood average rate", minimum=0.0,
                              maximum=1.0)
    outlier: bool = param(True, "outlier-tolerant likelihood (Gaussian + uniform mixture)")
    outlier_prob: float = param(0.05, "prior probability that a reflector is an outlier",
                                minimum=1e-9, maximum=0.999)
    outlier_gate_m: float = param(1.0, "radius of the disc over which an outlier is uniform, m",
                                  minimum=1e-6)
    association_gate_probability: float = param(
        0.9999, "association gate: a layout reflector is inside the gate of a measured one when "
        "their distance is within the square root of the chi-square quantile (2 degrees of "
        "freedom) of this probability times the larger of the measurement's range and "
        "cross-range noise (4.3 x at 0.9999); per particle, a reflector's id is used only when "
        "the id's layout reflector is inside the gate, else (and without an id) the nearest "
        "inside it, and none (the outlier density) when the gate holds nothing or two alike "
        "(ambiguity_ratio)", minimum=0.5, maximum=0.999999999)
    ambiguity_ratio: float = param(2.0, "per particle, a reflector without a usable id counts "
                                   "as none (the outlier density) when a second layout "
                                   "reflector is inside the gate at less than this times the "
                                   "distance of the nearest, dimensionless (1: never)",
                                   minimum=1.0)
    id_error_prob: float = param(0.1, "probability that the navigation device reports a wrong "
                                 "layout id for a reflector: a particle that associates a "
                                 "reflector with another layout reflector than its id's is "
                                 "weighed by this / ((J - 1) (1 - this)), J the layout's "
                                 "reflectors; 0: ids only select, never weigh",
                                 minimum=0.0, maximum=0.999)
    init_fix: str = param("points", "landmark fix of a start around a pose: points (align the "
                          "measured points on the map) or weighted (least squares in range and "
                          "bearing with this filter's measurement noise)",
                          choices=("points", "weighted"))
    init_max_sigma_xy_m: float = param(0.0, "weighted fix: start only from a scan whose fix has "
                                       "a position standard deviation (the larger axis) at "
                                       "most this, m; 0 takes the first fix", minimum=0.0)
    odometry_scales: bool = param(False, "every particle carries a distance scale s_v and a "
                                  "heading-change scale s_w of the odometry (prior mean 1), "
                                  "for biased odometry such as commanded velocities")
    scale_sigma_v: float = param(0.05, "prior standard deviation of each particle's s_v, "
                                 "dimensionless", minimum=0.0)
    scale_sigma_w: float = param(0.05, "prior standard deviation of each particle's s_w, "
                                 "dimensionless", minimum=0.0)
    scale_walk_v: float = param(0.003, "random walk of s_v per sqrt(metre) travelled, "
                                "1/sqrt(m)", minimum=0.0)
    scale_walk_w: float = param(0.003, "random walk of s_w per sqrt(radian) turned, "
                                "1/sqrt(rad)", minimum=0.0)
    start_particles: int = param(0, "particles of a uniform start (init = uniform), kept for "
                                 "the first start_updates updates, then resampled down to "
                                 "particles; 0 (or at most particles): no separate start",
                                 minimum=0)
    start_updates: int = param(10, "updates weighed with start_particles before the set "
                               "shrinks to particles", minimum=0)
    fix_reset_probability: float = param(0.0, "fix disagreement reset: a scan's landmark fix "
                                         "(as for the start) that fits its own measurements "
                                         "(squared residual below the chi-square quantile of "
                                         "this probability) and lies beyond that quantile "
                                         "from the cloud's mean (squared Mahalanobis distance "
                                         "in position, the fix's and the cloud's covariances "
                                         "added), at a scan none of whose landmarks the "
                                         "cloud's mean explains on its own (2 degrees of "
                                         "freedom), makes recovery re-draw fix_reset_fraction "
                                         "of the particles around the fix; 0: off", minimum=0.0,
                                         maximum=0.999999)
    fix_reset_fraction: float = param(0.5, "fraction of the particles the fix disagreement "
                                      "reset re-draws around the fix", minimum=0.0,
                                      maximum=1.0)
    jitter_m: float = param(0.001, "prior proposal: position noise added to every motion, "
                            "along and across track alike (in quadrature with the motion "
                            "noise), m per update: keeps the cloud able to move while the "
                            "vehicle stands, when the motion noise is zero", minimum=0.0, maximum=0.1)
    jitter_rad: float = param(0.0005, "prior proposal: heading noise added to every motion (in "
                              "quadrature), rad per update", minimum=0.0, maximum=0.1)
    proposal: str = param("prior", "where a reflector scan's particles are drawn from: prior "
                          "(the motion model, the particles moved with motion noise), ekf "
                          "(each particle's motion Gaussian updated by the scan's landmarks "
                          "with one Kalman step, weighted by prior x likelihood / proposal) "
                          "or marginal (that Gaussian kept, not drawn from: each particle an "
                          "EKF of the pose given its odometry scales, weighted by the scan's "
                          "evidence)", choices=("prior", "ekf", "marginal"))
    proposal_gate_probability: float = param(0.999, "ekf proposal: a landmark whose squared "
                                             "Mahalanobis distance from a particle's "
                                             "prediction exceeds the chi-square quantile (2 "
                                             "degrees of freedom) of this probability is left "
                                             "out of that particle's proposal (not of its "
                                             "weight)", minimum=0.5, maximum=0.999999999)

    def noise_sigmas(self, dist: MotionSize, rot: MotionSize
                     ) -> tuple[MotionSize, MotionSize, MotionSize]:
        """The motion noise (:meth:`MotionParams.noise_sigmas`: along m, across m, heading
        rad), with the prior proposal ``jitter_m`` and ``jitter_rad`` added in quadrature (the
        ekf and marginal proposals move each particle's Gaussian by its own Kalman step, also
        at a standstill)."""
        sa, sl, st = super().noise_sigmas(dist, rot)
        if self.proposal != "prior" or (self.jitter_m == 0.0 and self.jitter_rad == 0.0):
            return sa, sl, st
        jm, jr = self.jitter_m ** 2, self.jitter_rad ** 2
        return (np.sqrt(sa * sa + jm), np.sqrt(sl * sl + jm), np.sqrt(st * st + jr))


class ParticleFilter(ParticleSet[PfParams]):
    """The improved particle filter (``pf``); its array operations by its backend
    (:class:`lgvtool.localize.particle_backend.PfBackend`)."""

    name = "pf"
    Params = PfParams
    summary = "the paper's filter with log weights, ESS/low-variance resampling, KLD, " \
              "augmented MCL, de-skew, outlier-tolerant and pose-only likelihoods"

    def __init__(self, params: PfParams | None = None, *,
                 backend: ParticleBackend | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, backend=backend, **context)
        p = self.params
        self.logw = np.zeros(0)
        self.w_slow: dict[str, float] = {}
        self.w_fast: dict[str, float] = {}
        self.injected = 0
        self.resamplings = 0
        self._cached: tuple[float, float, float, np.ndarray] | None = None
        #: per-particle odometry scales (``odometry_scales``), dimensionless
        self.s_v = np.zeros(0)
        self.s_w = np.zeros(0)
        #: updates left before a large uniform start set shrinks to ``particles``
        self._start_left = 0
        #: ``proposal = ekf``: each particle's motion noise since its last draw; ``marginal``:
        #: the covariance of each particle's pose Gaussian; (N, 3, 3) in x m, y m, heading rad
        #: (None: zero, the particles are draws)
        self._pcov: FloatArray | None = None
        #: KLD-sampling's rule (its count between min_particles and particles)
        self.kld_sizing = KldSizing(p.kld_epsilon, p.kld_delta, p.min_particles,
                                    max(p.particles, p.min_particles), p.kld_bin_m,
                                    p.kld_bin_rad)
        eps = p.outlier_prob
        #: the reflector likelihood's constants (the association gate in standard deviations:
        #: the square root of its chi-square quantile, 2 dof)
        self.model = ScanModel(p.sigma_range_m, p.sigma_range_per_m, p.sigma_bearing_rad,
                               p.use_ids, p.outlier, math.log1p(-eps),
                               math.log(eps) + self._log_outlier(2),
                               math.sqrt(chi2_quantile(p.association_gate_probability, 2)),
                               p.ambiguity_ratio, self._log_mismatch())
        #: log(eps) + the log density of an outlier NAV pose (the pose likelihood's mixture)
        self._log_pose_outlier = math.log(eps) + self._log_outlier(3)
        #: the robust gate on NAV poses (refused poses, re-anchoring)
        self.pose_gate = PoseGate(chi2_quantile(p.pose_gate_probability, 3), p.pose_reanchor_s,
                                  self.events)
        if self.initial_pose is not None:
            self._start_around(self.initial_pose, p.particles)
        elif p.init == "uniform":
            if p.start_updates > 0 and p.start_particles > p.particles:
                self._start_uniform(p.start_particles)
                self._start_left = p.start_updates
            else:
                self._start_uniform(p.particles)
        self.logw = np.full(len(self.z), -math.log(max(1, len(self.z))))

    # ------------------------------------------------------------------ likelihoods
    def _log_outlier(self, dims: int) -> float:
        """Log density of an outlier: uniform over the gate's disc (2-D, per m^2), and over
        every heading too (3-D)."""
        g = self.params.outlier_gate_m
        return -math.log(math.pi * g ** 2) if dims == 2 else -math.log(math.pi * g ** 2 * 2.0 * math.pi)

    def ray_sigmas(self, obs: ScanObservation) -> tuple[FloatArray, FloatArray]:
        """Noise standard deviations (m) of each reflector of ``obs`` along its ray (range)
        and across it (range x bearing noise)."""
        return self.model.ray_sigmas(obs.ranges)

    def gate_radii(self, obs: ScanObservation) -> FloatArray:
        """The association gate of each reflector of ``obs``, m: the square root of the
        chi-square quantile (2 dof) of ``association_gate_probability`` times the larger of
        its range and cross-range noise (:meth:`ray_sigmas`)."""
        return self.model.gate_radii(obs.ranges)

    def associate_scan(self, obs: ScanObservation
                       ) -> tuple[ComplexArray, NDArray[np.bool_], NDArray[np.bool_]]:
        """Every particle's association of the reflectors of ``obs``
        (:func:`lgvtool.localize.pf_likelihood.associate`, the candidates seen from the
        reference pose): the residual ``L_j - p_mk`` (M, K complex, m) from each measured
        point to its layout reflector (the nearest when it has none), whether the point has
        none (nothing inside the gate, or two alike: ambiguous) and whether a point with an id
        went to another reflector than the id's."""
        return associate(self.z, self.rot, obs, self.map, self._reference_nearest(obs),
                         self.model)

    def _log_mismatch(self) -> float:
        """The log weight of a particle that associates a reflector with an id with another
        layout reflector than the id's: ``log(id_error_prob / (J - 1)) - log(1 -
        id_error_prob)`` for a layout of ``J`` reflectors (0 when off or ``J < 2``)."""
        eps = self.params.id_error_prob
        if eps <= 0.0 or len(self.map) < 2:
            return 0.0
        return math.log(eps / (len(self.map) - 1)) - math.log1p(-eps)

    def scan_loglik(self, obs: ScanObservation) -> tuple[FloatArray, int]:
        """Log-likelihood of each particle for a scan, and the number of reflectors used."""
        return (self.backend.scan_loglik(self.z, self.rot, obs, self.map,
                                         self._reference_pose(), self.model), len(obs))

    def pose_noise(self, obs: PoseObservation) -> FloatArray:
        """Covariance of a NAV head pose (3 x 3: m^2, m rad, rad^2): the rotating-head model's
        at the observation's motion (:func:`lgvtool.localize.pose_model.pose_covariance`), or
        the plain ``sigma_pose_xy_m``, ``sigma_pose_heading_rad``."""
        p = self.params
        if p.pose_model == "rotating-head":
            return pose_covariance(obs.heading, obs.v, obs.omega, self.vehicle.nav_x,
                                   self.vehicle.nav_y, p.sigma_pose_xy_m,
                                   p.sigma_pose_heading_rad, p)
        return np.diag([p.sigma_pose_xy_m ** 2, p.sigma_pose_xy_m ** 2,
                        p.sigma_pose_heading_rad ** 2])

    def pose_loglik(self, obs: PoseObservation) -> FloatArray:
        """Log-likelihood of each particle for a NAV head pose (a Gaussian of
        :meth:`pose_noise`, mixed with the outlier density)."""
        p = self.params
        dx, dy, dh = self.head_residuals(obs)
        r = np.stack([dx, dy, dh], axis=-1)
        cov = self.pose_noise(obs)
        d2 = np.einsum("ni,ij,nj->n", r, np.linalg.inv(cov), r)
        ll = -0.5 * d2 - (1.5 * _LOG_2PI + 0.5 * math.log(float(np.linalg.det(cov))))
        return mixed(ll, p.outlier, self.model.log_inlier, self._log_pose_outlier)

    def _judge_pose(self, obs: PoseObservation) -> str:
        """The robust gate's verdict on ``obs`` (:class:`lgvtool.localize.pose_model.PoseGate`):
        the squared Mahalanobis distance of the weighted mean's head residual, with the pose's
        covariance and the weighted spread of the particles' residuals added."""
        dx, dy, dh = self.head_residuals(obs)
        r = np.stack([dx, dy, dh], axis=-1)
        w = self.w if len(self.w) == len(r) else np.full(len(r), 1.0 / max(1, len(r)))
        mean = w @ r
        dev = r - mean
        spread = (dev * w[:, None]).T @ dev
        S = self.pose_noise(obs) + spread
        return self.pose_gate.judge(obs.t, float(mean @ np.linalg.solve(S, mean)))

    def _reanchor(self, obs: PoseObservation) -> None:
        """Draw the particles afresh around the NAV pose ``obs`` converted to O, with the
        pose's covariance carried through the lever arm."""
        th = obs.heading
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        J = np.array([[1.0, 0.0, s * mx + c * my], [0.0, 1.0, -c * mx + s * my],
                      [0.0, 0.0, 1.0]])
        cov = J @ self.pose_noise(obs) @ J.T
        pose = (obs.x - c * mx + s * my, obs.y - s * mx - c * my, th)
        self._start_at(pose, cov, len(self.z))
        self.logw = np.full(len(self.z), -math.log(max(1, len(self.z))))
        self.w = np.exp(self.logw)
        self._cached = self._with_spread(self.weighted_pose(self.w))
        self._ref = self._cached[:3]

    # ------------------------------------------------------------------ update
    def update(self, obs: Observation) -> bool:
        p = self.params
        if not self.initialized:
            fix = start_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map, p)
            if fix is None:
                return False
            self._start_at(fix[0], fix[1], p.particles)
            self.logw = np.full(len(self.z), -math.log(len(self.z)))
            return True
        # ekf or marginal: the particles are the means of Gaussians
        gaussian = p.proposal != "prior"
        if isinstance(obs, PoseObservation):
            verdict = self._judge_pose(obs)
            if verdict == "refuse":
                return False
            if verdict == "reanchor":
                self._reanchor(obs)
                return True
            if gaussian:
                self._draw_prior()
            ll, kind, count = self.pose_loglik(obs), "pose", 1
        else:
            if len(obs) == 0 or len(self.map) == 0:
                return False
            ll, count = self.proposal_loglik(obs) if gaussian else self.scan_loglik(obs)
            kind = "scan"
        if p.log_weights:
            weighed = self.backend.weigh(self.logw, ll, self.z, self.rot)
            if weighed is None:
                return False  # every weight is 0: the observation cannot be used
            self.w, self.logw = weighed.w, weighed.logw
            log_avg, ess, pose = weighed.log_avg, weighed.ess, weighed.pose
        else:
            e = self.w * np.exp(ll)
            total = float(e.sum())
            if not (total > 0.0 and math.isfinite(total)):
                return False  # every weight underflowed: the observation cannot be used
            log_avg = math.log(total)
            self.w = e / total
            self.logw = np.log(np.maximum(self.w, 1e-300))
            ess, pose = effective_sample_size(self.w), self.weighted_pose(self.w)
        per_obs = log_avg / count
        self._track_likelihood(kind, per_obs)
        self.last_ess = ess
        self._cached = self._with_spread(pose)
        self._ref = self._cached[:3]
        self.after_weighing(kind, obs, per_obs)
        return True

    def after_weighing(self, kind: str, obs: Observation, per_obs: float) -> None:
        """The end of :meth:`update` once the particles are weighed with ``obs`` (``kind``
        "scan" or "pose"; the log-likelihood ``per_obs`` per measurement): the resampling
        when due, with recovery's re-drawn particles."""
        p = self.params
        n = len(self.z)
        lost = 0.0
        if p.recovery and p.reset_likelihood > 0.0:
            lost = max(0.0, 1.0 - math.exp(min(per_obs, 700.0)) / p.reset_likelihood)
        cloud = self._cached
        if p.recovery and p.fix_reset_probability > 0.0 and kind == "scan" and \
                cloud is not None and self._fix_disagrees(obs, cloud):
            lost = max(lost, p.fix_reset_fraction)
        shrink = False
        if self._start_left > 0:
            self._start_left -= 1
            shrink = self._start_left == 0
        if shrink or lost > 0.0 or p.resample == "always" or \
                self.last_ess < p.ess_threshold * n:
            injected = self.injected
            self._resample(kind, obs, lost)
            if self.injected != injected:
                # recovery re-drew particles: the belief, and so the estimate, is the new set
                self._cached = self._with_spread(self.weighted_pose(self.w))
                self._ref = self._cached[:3]

    # ------------------------------------------------------------------ fused replay
    @property
    def tracking(self) -> bool:
        """Whether the filter is started and past a large start set: its reflector scans
        may be tracked by a fused replay (:mod:`lgvtool.localize.pf_run`)."""
        return self.initialized and self._start_left == 0

    def track_settings(self) -> TrackSettings:
        """What a fused replay of scans needs of the parameters."""
        p = self.params
        return TrackSettings(self.model, p.alpha_slow, p.alpha_fast, p.reset_likelihood,
                             p.recovery, p.ess_threshold, p.resample == "always", p.kld,
                             self.kld_sizing, p.particles)

    def particle_arrays(self) -> ParticleArrays:
        """The particles and their weights."""
        return ParticleArrays(self.z, self.th, self.rot, self.w, self.logw)

    def tracking_state(self) -> TrackState:
        """The scalars a fused replay of scans carries, as they are now."""
        return TrackState(self.w_slow.get("scan", 0.0), self.w_fast.get("scan", 0.0),
                          self.last_ess, self._ref, self._cached, self.resamplings)

    def resume(self, particles: ParticleArrays, state: TrackState) -> None:
        """Take over the particles and the scalars a fused replay of scans leaves."""
        self.z, self.th, self.rot, self.w, self.logw = particles
        if state.tracked:
            self.w_slow["scan"] = state.slow
            self.w_fast["scan"] = state.fast
        self.last_ess = state.ess
        if state.ref is not None:
            self._ref = state.ref
        self._cached = state.cached
        self.resamplings = state.resamplings

    def ekf_proposal(self, obs: ScanObservation) -> tuple[Proposal, FloatArray]:
        """Every particle's motion Gaussian updated by the landmarks of ``obs`` (linearised at
        the particle, each landmark associated as :meth:`associate_scan` does), and the
        Gaussians' prior covariances (N, 3, 3)."""
        cov = self._gaussians()
        landmarks = self.associate_scan(obs)[0] + self.world_points(obs)
        r, jac = ray_residuals(self.z, self.rot, landmarks, obs.q, obs.u)
        sr, st = self.ray_sigmas(obs)
        gate = chi2_quantile(self.params.proposal_gate_probability, 2)
        return kalman_proposal(cov, r, jac, sr, st, gate), cov

    def proposal_loglik(self, obs: ScanObservation) -> tuple[FloatArray, int]:
        """``proposal = ekf``: move every particle to a draw of its :meth:`ekf_proposal`, and
        return the log of its importance weight's factor (prior x likelihood / proposal) and
        the number of reflectors used. ``proposal = marginal``: move it to the posterior
        mean and keep the posterior covariance; the factor is then the frame's evidence
        (corrected at the mean by the true likelihood over the linearised one)."""
        n = len(self.z)
        marginal = self.params.proposal == "marginal"
        cov = self._gaussians()
        landmarks = self.associate_scan(obs)[0] + self.world_points(obs)
        sr, st = self.ray_sigmas(obs)
        g = None if marginal else self.rng.standard_normal((n, 3))
        dx, corr, post = self.backend.gaussian_proposal(
            self.z, self.rot, cov, landmarks, obs, sr, st,
            chi2_quantile(self.params.proposal_gate_probability, 2), g)
        self._shift(dx)
        if marginal:
            self._pcov = post
        ll, count = self.scan_loglik(obs)
        return ll + corr, count

    def _gaussians(self) -> FloatArray:
        """The covariances of the particles' Gaussians (N, 3, 3; zero when they are draws)."""
        n = len(self.z)
        pcov = self._pcov
        return pcov if pcov is not None and len(pcov) == n else np.zeros((n, 3, 3))

    def _shift(self, dx: FloatArray) -> None:
        """Move every particle by its offset (N, 3: x m, y m, heading rad); the particles are
        draws from then on."""
        self.z = self.z + (dx[:, 0] + 1j * dx[:, 1])
        self._set_headings(self.th + dx[:, 2])
        self._pcov = None

    def _with_spread(self, pose: tuple[float, float, float, FloatArray]
                     ) -> tuple[float, float, float, FloatArray]:
        """The weighted ``pose`` of the particles with the weighted mean of their Gaussians'
        covariances added to its covariance, when the particles are the means of Gaussians
        (``proposal`` ekf between frames, marginal always)."""
        if self._pcov is None or len(self._pcov) != len(self.z):
            return pose
        x, y, t, c = pose
        return x, y, t, c + np.einsum("n,nij->ij", self.w, self._pcov)

    def _draw_prior(self) -> None:
        """``proposal`` ekf or marginal: draw every particle from its Gaussian (for an
        observation the proposal does not use)."""
        if self._pcov is not None and len(self._pcov) == len(self.z):
            self._shift(gaussian_offsets(self._pcov, self.rng.standard_normal((len(self.z), 3))))

    def _fix_disagrees(self, obs: Observation,
                       cloud: tuple[float, float, float, FloatArray]) -> bool:
        """Whether ``obs`` gives a landmark fix (weighted, within ``init_max_sigma_xy_m``) that
        fits its own measurements and contradicts the cloud: its squared residual in range and
        bearing (``2n - 3`` degrees of freedom for ``n`` landmarks) below, and its squared
        Mahalanobis distance in position from the cloud's weighted mean (fix plus cloud
        covariance, 2 degrees of freedom) above, the chi-square quantile of
        ``fix_reset_probability``. A scan whose landmarks contradict each other (a misread id)
        fits no pose and so resets nothing; a scan the cloud's mean already explains (squared
        residual within the quantile with ``2n`` degrees of freedom) contradicts nothing; nor
        does a scan one of whose landmarks the cloud's mean explains on its own (2 degrees of
        freedom): a cloud in the wrong place explains none of them but by chance, while a
        misread id contradicts the cloud in its own landmark only, and with two landmarks the
        fix's residual (one degree of freedom, ranges known to tens of percent) cannot tell."""
        p = self.params
        if not isinstance(obs, ScanObservation):
            return False
        known = int(np.count_nonzero(obs.map_index(self.map) >= 0))
        if known < 2:
            return False
        # the cloud's mean explains the frame (2n degrees of freedom), or one of its landmarks
        # (2): nothing contradicts it (and no fix need be computed)
        each = residual_chi2_each(cloud[:3], obs, self.map, p.sigma_range_m,
                                  p.sigma_range_per_m, p.sigma_bearing_rad)
        if float(each.sum()) <= chi2_quantile(p.fix_reset_probability, 2 * known) or \
                bool((each <= chi2_quantile(p.fix_reset_probability, 2)).any()):
            return False
        fix = start_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map, p)
        if fix is None:
            return False
        (fx, fy, fh), fcov = fix
        if fcov is None:
            return False
        d = np.array([cloud[0] - fx, cloud[1] - fy])
        try:
            m2 = float(d @ np.linalg.solve(fcov[:2, :2] + cloud[3][:2, :2], d))
        except np.linalg.LinAlgError:
            return False
        if m2 <= chi2_quantile(p.fix_reset_probability, 2):
            return False
        fit = residual_chi2((fx, fy, fh), obs, self.map, p.sigma_range_m, p.sigma_range_per_m,
                            p.sigma_bearing_rad)
        return fit <= chi2_quantile(p.fix_reset_probability, max(1, 2 * known - 3))

    def _around(self, pose: tuple[float, float, float], cov: FloatArray | None, n: int
                ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``n`` poses (m, m, rad) drawn from a Gaussian around ``pose``: the start spread
        (``init_sigma_xy_m``, ``init_sigma_heading_rad``) plus the fix's covariance ``cov``
        when given."""
        p = self.params
        if cov is None:
            g = self.rng.standard_normal((3, n))
            return (pose[0] + p.init_sigma_xy_m * g[0], pose[1] + p.init_sigma_xy_m * g[1],
                    pose[2] + p.init_sigma_heading_rad * g[2])
        full = self._start_covariance(cov)
        d = self.rng.multivariate_normal(np.asarray(pose, dtype=np.float64), full, n,
                                         method="cholesky")
        return d[:, 0], d[:, 1], d[:, 2]

    def _start_covariance(self, cov: FloatArray | None) -> FloatArray:
        """The start spread (``init_sigma_xy_m``, ``init_sigma_heading_rad``) as a covariance
        (3 x 3: m^2, rad^2), plus the fix's covariance ``cov`` when given."""
        p = self.params
        spread = np.diag([p.init_sigma_xy_m ** 2, p.init_sigma_xy_m ** 2,
                          p.init_sigma_heading_rad ** 2])
        return spread if cov is None else cov + spread

    def _start_around(self, pose: tuple[float, float, float], n: int) -> None:
        self._start_at(pose, None, n)

    def _start_at(self, pose: tuple[float, float, float], cov: FloatArray | None,
                  n: int) -> None:
        """``n`` particles around ``pose`` (m, m, rad) with the start's Gaussian
        (:meth:`_start_covariance`, the fix's covariance ``cov`` included when given): drawn
        from it, or with ``proposal = marginal`` all at ``pose``, each carrying it as its own
        (the EKF's start; the particles then differ only in their odometry scales)."""
        if self.params.proposal != "marginal":
            self.set_particles(*self._around(pose, cov, n))
            return
        self.set_particles(np.full(n, pose[0]), np.full(n, pose[1]), np.full(n, pose[2]))
        self._pcov = np.repeat(self._start_covariance(cov)[None], n, axis=0)

    def run(self, times: FloatArray, observations: Sequence[Observation | None],
            steps: Deltas | None, *, progress: Callable[[int], None] | None = None,
            cloud_period_s: float = 2.0, cloud_size: int = 50) -> EstimateRows:
        """:meth:`Estimator.run`, its reflector scans tracked by the backend's fused replay
        when it has one and the settings allow (:mod:`lgvtool.localize.pf_run`: the same rows
        and random stream)."""
        from lgvtool.localize import pf_run

        tracker = pf_run.tracker(self, steps, len(observations))
        if tracker is None:
            return super().run(times, observations, steps, progress=progress,
                               cloud_period_s=cloud_period_s, cloud_size=cloud_size)
        return pf_run.track(self, tracker, times, observations, steps, progress=progress,
                            cloud_period_s=cloud_period_s, cloud_size=cloud_size)

    def predict(self, motion: Motion) -> None:
        p = self.params
        n = len(self.z)
        sigmas = p.noise_sigmas(motion.dist, motion.rot)
        if p.proposal != "prior" and n > 0:
            self._predict_mean(motion, sigmas)
        elif p.odometry_scales and n > 0:
            self._predict_scaled(motion)
        elif n > 0:
            self._move(motion, sigmas)
        self._cached = None

    def _prior_scales(self, n: int) -> tuple[FloatArray, FloatArray]:
        """``n`` draws of the scales' prior (mean 1)."""
        p = self.params
        g = self.rng.standard_normal((2, n))
        return 1.0 + p.scale_sigma_v * g[0], 1.0 + p.scale_sigma_w * g[1]

    def _predict_scaled(self, motion: Motion) -> None:
        """Each particle's odometry motion scaled by its own ``s_v``, ``s_w``
        (:func:`lgvtool.localize.ekf.scaled_motion`: turn, chord, turn), plus the motion
        noise; then the scales' random walk."""
        from lgvtool.localize.ekf import scaled_motion

        p = self.params
        n = len(self.z)
        if len(self.s_v) != n:
            self.s_v, self.s_w = self._prior_scales(n)
        _, _, _, a, d = scaled_motion(motion.dx, motion.dy, motion.dth, 1.0, 1.0)
        sa, sl, st = p.noise_sigmas(motion.dist, motion.rot)
        g = self.rng.standard_normal((5, n))
        turn = self.s_w * a
        chord = self.s_v * d
        dx = chord * np.cos(turn) + sa * g[0]
        dy = chord * np.sin(turn) + sl * g[1]
        dth = self.s_w * motion.dth + st * g[2]
        self.z = self.z + self.rot * (dx + 1j * dy)
        self._set_headings(self.th + dth)
        self.s_v = self.s_v + p.scale_walk_v * math.sqrt(motion.dist) * g[3]
        self.s_w = self.s_w + p.scale_walk_w * math.sqrt(motion.rot) * g[4]
        self._move_ref(motion)

    def _predict_mean(self, motion: Motion, sigmas: tuple[float, float, float]) -> None:
        """``proposal`` ekf or marginal: each particle moved by the noise-free odometry motion
        (scaled by its own ``s_v``, ``s_w`` with ``odometry_scales``, then the scales' random
        walk), its Gaussian's covariance carried along and the motion noise ``sigmas`` (along
        m, across m, heading rad) added."""
        p = self.params
        n = len(self.z)
        body: complex | ComplexArray
        dth: float | FloatArray
        if p.odometry_scales:
            from lgvtool.localize.ekf import scaled_motion

            if len(self.s_v) != n:
                self.s_v, self.s_w = self._prior_scales(n)
            _, _, _, a, d = scaled_motion(motion.dx, motion.dy, motion.dth, 1.0, 1.0)
            body = (self.s_v * d) * np.exp(1j * (self.s_w * a))
            dth = self.s_w * motion.dth
            g = self.rng.standard_normal((2, n))
            self.s_v = self.s_v + p.scale_walk_v * math.sqrt(motion.dist) * g[0]
            self.s_w = self.s_w + p.scale_walk_w * math.sqrt(motion.rot) * g[1]
        else:
            body, dth = complex(motion.dx, motion.dy), motion.dth
        step = self.rot * body
        self._pcov = self.backend.predict_covariance(self._gaussians(), self.rot, step, sigmas)
        self.z = self.z + step
        self._set_headings(self.th + dth)
        self._move_ref(motion)

    @property
    def odometry_calibration(self) -> dict[str, float]:
        """The weighted mean of the particles' odometry scales ``s_v``, ``s_w``
        (dimensionless); empty without ``odometry_scales`` or before the first pose."""
        if not self.params.odometry_scales or len(self.z) == 0:
            return {}
        if len(self.s_v) != len(self.z):
            return {"s_v": 1.0, "s_w": 1.0}
        return {"s_v": float(self.w @ self.s_v), "s_w": float(self.w @ self.s_w)}

    def _track_likelihood(self, kind: str, log_avg_per_obs: float) -> None:
        p = self.params
        w_avg = math.exp(max(log_avg_per_obs, -700.0))
        slow = self.w_slow.get(kind, 0.0)
        fast = self.w_fast.get(kind, 0.0)
        self.w_slow[kind] = slow + p.alpha_slow * (w_avg - slow)
        self.w_fast[kind] = fast + p.alpha_fast * (w_avg - fast)

    def _resample(self, kind: str, obs: Observation, lost: float) -> None:
        """Resample (:meth:`_survivors`), the particles' odometry scales and Gaussians
        following theirs (:meth:`_carry`); recovery re-draws a part of the new set
        (:meth:`_recovery_count`, :meth:`_inject`); equal weights."""
        kept = self._survivors(kind)
        n_new = len(kept.idx)
        n_inject = self._recovery_count(kind, lost, n_new)
        scaled, pcov = self._carry(kept.idx)
        if n_inject > 0:
            # (the re-drawn headings wrapped with the others, from the parents' as they were)
            z, th = (kept.z, kept.th) if kept.rot is None else \
                (self.z[kept.idx], self.th[kept.idx])
            self._inject(kind, obs, n_inject, z, th, scaled, pcov)
        elif kept.rot is None:
            self.z = kept.z
            self._set_headings(kept.th)
        else:
            self.z, self.th, self.rot = kept.z, kept.th, kept.rot
        self.w = np.full(n_new, 1.0 / n_new)
        self.logw = np.full(n_new, -math.log(n_new))
        self.resamplings += 1

    def _survivors(self, kind: str = "scan") -> Survivors:
        """The particles a resampling keeps: as many as the set has while a large start set
        has not shrunk, else KLD-sampling's count (``kld``; after a reflector scan) or
        ``particles``, drawn by the ``resampler`` (systematic by the backend, with the copy).

        After a NAV pose (``kind`` "pose") the set keeps ``particles``: the belief a pose
        leaves is centimetres wide, far inside KLD-sampling's bins (``kld_bin_m``,
        ``kld_bin_rad``), which would cut the set to about ``min_particles`` and leave the
        estimate the noise of so few draws."""
        p = self.params
        rng = self.rng
        systematic = p.resampler == "low-variance"
        if self._start_left > 0:
            # the large start set keeps its size until it shrinks
            return self._gathered(RESAMPLERS[p.resampler](self.w, len(self.z), rng))
        if p.kld and kind != "pose":
            sizing = self.kld_sizing
            if systematic:
                # the draw (its offset, then the permutation), the bins, the count, the copy
                u0 = rng.random()
                perm = rng.permutation(sizing.cap)
                return self.backend.kld_systematic(self.w, u0, perm, sizing, self.z, self.th,
                                                   self.rot)
            idx = RESAMPLERS[p.resampler](self.w, sizing.cap, rng)
            idx = idx[rng.permutation(sizing.cap)]
            return self._gathered(idx[:sizing.count(self.z.real[idx], self.z.imag[idx],
                                                    self.th[idx])])
        if systematic:
            return self.backend.systematic(self.w, p.particles, rng.random(), self.z, self.th,
                                           self.rot)
        return self._gathered(RESAMPLERS[p.resampler](self.w, p.particles, rng))

    def _gathered(self, idx: NDArray[np.intp]) -> Survivors:
        """The particles ``idx`` (their headings as they were)."""
        return Survivors(idx, self.z[idx], self.th[idx], None)

    def _recovery_count(self, kind: str, lost: float, n_new: int) -> int:
        """How many of ``n_new`` resampled particles recovery re-draws (none without
        ``recovery``): the larger of the fraction ``lost`` (sensor resetting) and augmented
        MCL's ``1 - w_fast / w_slow`` for the ``kind`` of observation."""
        if not self.params.recovery:
            return 0
        frac = lost
        slow, fast = self.w_slow.get(kind, 0.0), self.w_fast.get(kind, 0.0)
        if slow > 0.0:
            frac = max(frac, 1.0 - fast / slow)
        return min(n_new, round(frac * n_new))

    def _carry(self, idx: NDArray[np.intp]) -> tuple[bool, FloatArray | None]:
        """The odometry scales and the Gaussians' covariances of the resampled particles
        ``idx`` (before the particles are replaced); returns whether the particles carry
        scales and their new covariances (None: the particles are draws)."""
        scaled = self.params.odometry_scales and len(self.s_v) == len(self.z)
        if scaled:
            self.s_v, self.s_w = self.s_v[idx], self.s_w[idx]
        pcov = self._pcov
        if pcov is not None and len(pcov) == len(self.z):
            pcov = self._pcov = pcov[idx]
        else:
            pcov = None
        return scaled, pcov

    def _inject(self, kind: str, obs: Observation, n: int, z: ComplexArray, th: FloatArray,
                scaled: bool, pcov: FloatArray | None) -> None:
        """Recovery: the first ``n`` of the resampled particles ``z``, ``th`` (new arrays)
        re-drawn (:meth:`_recovery_poses`; their scales from the prior, no spread of their
        own), then the set is theirs; the likelihood averages of ``kind`` start over."""
        gx, gy, gt = self._recovery_poses(obs, n)
        z[:n] = gx + 1j * gy
        th[:n] = gt
        if scaled:
            self.s_v[:n], self.s_w[:n] = self._prior_scales(n)
        if pcov is not None:
            pcov[:n] = 0.0   # draws: no spread of their own
        self.injected += n
        self.w_slow[kind] = self.w_fast[kind] = 0.0
        self.z = z
        self._set_headings(th)

    def _recovery_poses(self, obs: Observation, n: int
                        ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """``n`` poses for recovery: around the pose the observation fixes (a landmark fix or
        the NAV pose), else uniform over the work area."""
        p = self.params
        if p.inject == "sensor":
            fix = start_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map, p)
            if fix is not None:
                return self._around(fix[0], fix[1], n)
        return uniform_poses(self.rng, n, self.area)

    def estimate(self) -> Estimate | None:
        if not self.initialized:
            return None
        if self._cached is None:
            # the particles may be the means of Gaussians: their spread adds
            self._cached = self._with_spread(self.weighted_pose(self.w))
        return self._as_estimate(self._cached)
