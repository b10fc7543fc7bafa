"""``pf-paper``: the particle filter of the paper, section 3.2, step by step.

1. Initialisation: poses of O uniform over the work area, uniform heading: ``start_particles``
   (5000) of them for the first ``start_updates`` (10) updates, then the ``particles`` (150)
   heaviest go on (``start_updates = 0``: the paper's 150 from the start).
2. Prediction (eq. 9): the encoder + gyro motion composed onto every particle.
3. Correction: each measured reflector is put into the world at the particle's sensor pose at
   its own measurement time (``deskew``: the reflector carried by the odometry from its instant
   in the revolution to the observation time; the sensor sits at ``(nav_x, nav_y)`` in the
   vehicle frame) and associated with the
   nearest known reflector; the distances are summed, ``D_m = sum_k |L_j(k) - p_mk|``, and the
   weight is the Gaussian of eq. 10 with mean 0, ``w_m = (2 pi sigma^2)^(-1/2)
   exp(-D_m^2 / (2 sigma^2))``.
4. Estimate (eq. 11): the weighted mean of the particles (the heading as a circular mean, since
   a plain mean of angles breaks at +-pi).
5. Redistribution: ``local_fraction`` (95 %) of the new particles uniformly within
   ``+-spread_m`` (25 cm) and ``+-heading_spread_rad`` around parents drawn from the
   ``top_fraction`` (25 %) of particles by weight; the rest uniform over the work area.

Without reflector scans (a log with the NAV pose only; the paper gives no weight for a pose)
the same weight is computed from ``sigma_m`` times the Mahalanobis distance of each particle's
head from the reported pose under the rotating-head pose model
(:mod:`lgvtool.localize.pose_model`, behind its robust gate), or with ``pose_model = plain``
from the distance between the head positions plus ``pose_heading_m`` times the heading
difference.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Unpack

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_scalar
from lgvtool.localize.estimator import (
    Cloud,
    Estimate,
    EstimateRows,
    EstimatorContext,
    Motion,
    Observation,
    Reporter,
    cloud_sample,
)
from lgvtool.localize.fix import pose_fix
from lgvtool.localize.noise import MotionParams
from lgvtool.localize.observations import PoseObservation, ScanObservation, SourceParams
from lgvtool.localize.obsstream import BlockwiseMap
from lgvtool.localize.params import param
from lgvtool.localize.particle_backend import (
    KnownSpread,
    PaperBlock,
    PaperMotions,
    PaperScan,
    ParticleBackend,
    Spread,
)
from lgvtool.localize.particles import ParticleInitParams, ParticleSet
from lgvtool.localize.pose_model import (
    POSE_MODELS,
    PoseGate,
    PoseModelParams,
    pose_covariance,
)
from lgvtool.localize.resampling import RedistributionDraws, RedistributionPlan
from lgvtool.quantiles import chi2_quantile
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: redistributions whose random numbers are drawn in one call (about 2^14 numbers at most:
#: larger blocks no longer fit the caches)
_DRAW_NUMBERS = 1 << 14

#: heading spread of the redistribution, rad. The paper gives none. A heading offset moves a
#: reflector at range r by r times the offset; this spread moves a reflector 25 m away (across
#: the paper's 25 m x 20 m hall) by at most the paper's position spread of 25 cm, so position
#: and heading spread disturb the measured reflectors alike.
DEFAULT_HEADING_SPREAD = 0.25 / 25.0


@dataclass(frozen=True)
class PaperPfParams(MotionParams, SourceParams, ParticleInitParams, PoseModelParams):
    """Parameters of the paper's filter; defaults are the paper's values where it gives one."""

    particles: int = param(150, "number of particles (paper: 150)", minimum=1)
    sigma_m: float = param(1.0, "standard deviation of the eq. 10 Gaussian on the summed "
                           "association distance, m (paper: standard normal, sigma = 1)",
                           minimum=1e-9)
    top_fraction: float = param(0.25, "fraction of particles, by weight, that parent the "
                                "redistribution (paper: top 25 %)", minimum=0.0, maximum=1.0)
    local_fraction: float = param(0.95, "fraction of particles redistributed around the "
                                  "parents; the rest go uniform over the work area (paper: "
                                  "95 %)", minimum=0.0, maximum=1.0)
    spread_m: float = param(0.25, "half width of the uniform redistribution in x and y, m "
                            "(paper: +-25 cm)", minimum=0.0)
    heading_spread_rad: float = param(DEFAULT_HEADING_SPREAD, "half width of the uniform "
                                      "redistribution in heading, rad (not in the paper: "
                                      "moves a reflector 25 m away by 25 cm)",
                                      minimum=0.0)
    pose_heading_m: float = param(1.0, "pose-only weight (pose_model = plain): metres of "
                                  "distance per radian of heading difference, m/rad",
                                  minimum=0.0)
    pose_model: str = param("rotating-head", "model of a NAV pose (the paper weighs reflector "
                            "scans and gives none): rotating-head (the pose at its reference "
                            "instant with its skew taken off, weighed by the Gaussian of its "
                            "covariance, with the robust gate; docs/filter.md) or plain (the "
                            "distance plus pose_heading_m times the heading difference)",
                            choices=POSE_MODELS)
    sigma_pose_xy_m: float = param(0.03, "pose_model = rotating-head: position noise of a NAV "
                                   "pose at standstill, m", minimum=1e-6)
    sigma_pose_heading_rad: float = param(0.005, "pose_model = rotating-head: heading noise of "
                                          "a NAV pose at standstill, rad", minimum=1e-9)
    noise_dist: float = param(0.0, "along-track motion noise per metre, m/m (the paper adds "
                              "none: redistribution spreads the particles)", minimum=0.0)
    noise_lat: float = param(0.0, "across-track motion noise per metre, m/m", minimum=0.0)
    noise_rot: float = param(0.0, "heading noise per radian turned, rad/rad", minimum=0.0)
    noise_rot_per_m: float = param(0.0, "heading noise per metre travelled, rad/m",
                                   minimum=0.0)
    use_ids: bool = param(False, "use reflector ids for association (the paper associates "
                          "with the nearest known reflector)")
    id_gate_m: float = param(1.0, "with use_ids: a reflector's distance to its id's layout "
                             "reflector counts at most this plus its distance to the nearest "
                             "layout reflector (a wrong id from the device costs the particles "
                             "near the truth alike and cannot pull them), m", minimum=0.0)
    deskew: bool = param(True, "weigh each reflector at the particle carried by the "
                         "odometry to its own measurement time in the revolution (eq. 9 "
                         "applied within the revolution); false: all reflectors of a "
                         "revolution at one instant, the NAV200's own skew kept")
    start_particles: int = param(5000, "particles of the uniform start, kept for the first "
                                 "start_updates updates, then the heaviest become the "
                                 "particles (the paper: 150, i.e. no separate start)",
                                 minimum=1)
    start_updates: int = param(10, "updates weighed with start_particles before the set "
                               "shrinks to particles (the paper: 0)", minimum=0)
    scans: str = param("nav-poll", "which revolutions weigh the particles: nav-poll (the "
                       "paper: when the NAV is polled, every 450 ms, the last revolution "
                       "completed before the poll) or all", choices=("nav-poll", "all"))


class PaperParticleFilter(ParticleSet[PaperPfParams]):
    """The paper's particle filter (section 3.2), every constant a parameter.

    The particles are kept packed as the rows of one complex array (position ``z``, heading
    rotor ``rot`` and what else the backend keeps: the numpy reference a column of ones, so
    that putting a scan's reflectors into the world at every particle and comparing them with
    candidate map reflectors is one matrix product, and the weighted sums of eq. 11 another;
    :class:`lgvtool.localize.particle_backend.PaperBackend`). The redistribution's random
    numbers are drawn ahead for several updates at once when the filter draws nothing else
    per update (no motion noise, the paper's default): the same numbers in the same order as
    one draw per update, so results do not depend on it.
    """

    name = "pf-paper"
    Params = PaperPfParams
    summary = "the paper's particle filter: 150 particles, eq. 9-11, 95/25 redistribution"

    def __init__(self, params: PaperPfParams | None = None, *,
                 backend: ParticleBackend | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, backend=backend, **context)
        p = self.params
        #: pose of the last estimate (x, y m, heading rad), moved by the odometry since
        self._mean: tuple[float, float, float] | None = None
        #: the covariance and ESS of the last estimate (made when first asked for)
        self._cov: Spread | None = None
        self._plan: RedistributionPlan | None = None
        self._draws: RedistributionDraws | None = None
        self._drawn = 0
        self._quiet_motion = (p.noise_dist == 0.0 and p.noise_lat == 0.0 and p.noise_rot == 0.0
                              and p.noise_rot_per_m == 0.0)
        #: exponent factor of eq. 10: w = exp(factor D^2)
        self._factor = -0.5 / (p.sigma_m * p.sigma_m)
        #: the robust gate on NAV poses of the rotating-head model
        self.pose_gate = PoseGate(chi2_quantile(0.99, 3), p.pose_reanchor_s, self.events)
        self._packing: tuple[ComplexArray, ComplexArray, ComplexArray] | None = None
        n = p.particles
        self._uniform_w = np.full(n, 1.0 / n)
        #: updates left before a large uniform start set shrinks to ``particles``
        self._start_left = 0
        if self.initial_pose is not None:
            self._start_around(self.initial_pose, p.particles)
        elif p.init == "uniform":
            if p.start_updates > 0 and p.start_particles > p.particles:
                self._start_uniform(p.start_particles)
                self._start_left = p.start_updates
            else:
                self._start_uniform(p.particles)

    # ------------------------------------------------------------------ packed particles
    def _packed(self) -> ComplexArray:
        """The particles packed as the backend keeps them (:meth:`PaperBackend.pack`)."""
        pk = self._packing
        if pk is not None and pk[1] is self.z and pk[2] is self.rot:
            return pk[0]
        s = self.backend.pack(self.z, self.rot)
        self._adopt(s, self._th)
        return s

    def _adopt(self, s: ComplexArray, th: FloatArray | None = None) -> None:
        """Make the packed array ``s`` the particle set (headings ``th`` if known)."""
        self.z, self.rot = s[:, 0], s[:, 1]
        self._th = th
        self._packing = (s, self.z, self.rot)

    def _move_refs(self, dx: float, dy: float, dth: float) -> None:
        """Move the last estimate and the reference pose by a body-frame motion (m, rad)."""
        if self._ref is not None:
            self._ref = _moved(self._ref, dx, dy, dth, wrap=False)
        if self._mean is not None:
            self._mean = _moved(self._mean, dx, dy, dth)

    def predict(self, motion: Motion) -> None:
        if not (self._quiet_motion and len(self.z)):
            super().predict(motion)
            if self._mean is not None:
                self._mean = _moved(self._mean, motion.dx, motion.dy, motion.dth)
            return
        b = self.backend
        step = b.paper_motions(np.array([motion.dx]), np.array([motion.dy]),
                               np.array([motion.dth]))
        s = self._packed()
        new = np.empty_like(s)
        b.paper_move(s, new, step, 0)
        self._adopt(new)
        self._move_refs(motion.dx, motion.dy, motion.dth)

    # ------------------------------------------------------------------ correction
    def distances(self, obs: Observation) -> FloatArray:
        """The summed association distance ``D_m`` of every particle, m."""
        if isinstance(obs, PoseObservation):
            dx, dy, dh = self.head_residuals(obs)
            if self.params.pose_model == "rotating-head":
                # sigma_m times the Mahalanobis distance: eq. 10 is then the pose's Gaussian
                r = np.stack([dx, dy, dh], axis=-1)
                d2 = np.einsum("ni,ij,nj->n", r, np.linalg.inv(self.pose_noise(obs)), r)
                scaled: FloatArray = self.params.sigma_m * np.sqrt(d2)
                return scaled
            out: FloatArray = np.sqrt(dx * dx + dy * dy) + self.params.pose_heading_m * np.abs(dh)
            return out
        if self.params.use_ids:
            return self._id_sums(obs)
        s = self._packed()
        return self.backend.paper_exponents(s, self._scan(obs), self.map, self._near(len(s)),
                                            None, None)

    def pose_noise(self, obs: PoseObservation) -> FloatArray:
        """Covariance (3 x 3: m^2, m rad, rad^2) of a NAV head pose under the rotating-head
        model (:func:`lgvtool.localize.pose_model.pose_covariance`)."""
        p = self.params
        return pose_covariance(obs.heading, obs.v, obs.omega, self.vehicle.nav_x,
                               self.vehicle.nav_y, p.sigma_pose_xy_m, p.sigma_pose_heading_rad,
                               p)

    def _judge_pose(self, obs: PoseObservation) -> str:
        """The robust gate's verdict on ``obs`` (rotating-head model): the squared Mahalanobis
        distance of the estimate's head residual, with the pose's covariance and the spread
        of the redistribution around the estimate (uniform: ``spread_m^2 / 3`` and
        ``heading_spread_rad^2 / 3``) added (:class:`lgvtool.localize.pose_model.PoseGate`)."""
        p = self.params
        est = self.estimate()
        if est is None:
            return "accept"
        th = est.heading
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        r = np.array([obs.x - (est.x + c * mx - s * my), obs.y - (est.y + s * mx + c * my),
                      wrap_scalar(obs.heading - th)])
        S = self.pose_noise(obs) + np.diag([p.spread_m ** 2 / 3.0, p.spread_m ** 2 / 3.0,
                                            p.heading_spread_rad ** 2 / 3.0])
        return self.pose_gate.judge(obs.t, float(r @ np.linalg.solve(S, r)))

    def _id_sums(self, obs: ScanObservation) -> FloatArray:
        """``D_m`` with ``use_ids``: a reflector with an id in the map counts its distance to
        the id's reflector, but at most ``id_gate_m`` plus its distance to its nearest
        reflector (a wrong id costs the particles near the truth about the same, so it cannot
        pull them, and still costs the particles that the ids rule out); the others their
        distance to their nearest reflector, m."""
        p = self.world_points(obs)
        j = obs.map_index(self.map)
        known = j >= 0
        if known.all() and math.isinf(self.params.id_gate_m):
            summed: FloatArray = np.abs(self.map.z[j] - p).sum(axis=1)
            return summed
        d = np.abs(self._nearest_residuals(p, obs))
        if known.any():
            by_id = np.abs(self.map.z[j[known]] - p[:, known])
            d[:, known] = np.minimum(by_id, self.params.id_gate_m + d[:, known])
        out: FloatArray = d.sum(axis=1)
        return out

    def _scan(self, obs: ScanObservation) -> PaperScan:
        """``obs`` laid out for :meth:`PaperBackend.paper_exponents`, each point's candidate
        the map reflector of its id or the nearest one seen from the reference pose."""
        j1 = self._reference_nearest(obs)
        return self.backend.paper_scan(obs.q, self.map.z[j1], self.map.half_sep[j1])

    def _near(self, m: int) -> int:
        """How many of ``m`` particles were redistributed around parents (the others, uniform
        over the work area, are compared with the whole map)."""
        plan = self._plan
        return m if plan is None or plan.m != m else plan.n_local

    def update(self, obs: Observation) -> bool:
        p = self.params
        if not self.initialized:
            pose = pose_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map,
                            use_ids=p.use_ids)
            if pose is None:
                return False
            self._start_around(pose, p.particles)
            return True
        if not isinstance(obs, PoseObservation) and (len(obs) == 0 or len(self.map) == 0):
            return False
        if isinstance(obs, PoseObservation) and p.pose_model == "rotating-head" and \
                self._start_left == 0:
            verdict = self._judge_pose(obs)
            if verdict == "refuse":
                return False
            if verdict == "reanchor":
                th = obs.heading
                c, sn = math.cos(th), math.sin(th)
                mx, my = self.vehicle.nav_x, self.vehicle.nav_y
                self._start_around((obs.x - c * mx + sn * my, obs.y - sn * mx - c * my, th),
                                   len(self.z))
        s = self._packed()
        if isinstance(obs, ScanObservation) and not p.use_ids:
            exponent = self.backend.paper_exponents(s, self._scan(obs), self.map,
                                                    self._near(len(s)), self._factor,
                                                    np.empty(len(s)))
        else:
            d = self.distances(obs)
            exponent = d * d
            exponent *= self._factor
        if self._start_left > 0:
            self._start_left -= 1
            if self._start_left == 0:
                # the start is over: the heaviest particles of the large set go on
                keep = np.argsort(exponent, kind="stable")[len(s) - p.particles:]
                s, exponent = s[keep], exponent[keep]
        new = np.empty_like(s)
        self._cov = self._correct(s, exponent, np.empty(len(s)), new)
        self._adopt(new)
        return True

    def _correct(self, s: ComplexArray, exponent: FloatArray, w: FloatArray,
                 out: ComplexArray) -> Spread:
        """Weigh the packed particles ``s`` with eq. 10, given its exponent
        ``-D_m^2 / (2 sigma^2)``, into ``w`` (unnormalised), estimate with eq. 11
        (``self._mean``) and redistribute into ``out``. Returns the weighed set's spread."""
        b = self.backend
        sums = b.paper_weigh(s, exponent, w)
        self._estimate_from(sums.tolist())
        plan, draws, k = self._redistribution(len(s))
        return b.paper_redistribute(s, w, sums, plan, draws, k, out)

    def _estimate_from(self, sums: list[float]) -> None:
        """Eq. 11 from the weighed set's sums (of x, y, cos, sin weighted, and of the
        weights): the estimate, which is the reference pose too."""
        sx, sy, sc, ss, total = sums
        self._mean = self._ref = (sx / total, sy / total, math.atan2(ss, sc))

    def _redistribution(self, m: int) -> tuple[RedistributionPlan, RedistributionDraws, int]:
        """The plan of the redistribution of ``m`` particles, its random numbers and which of
        them (drawn ahead) the next redistribution takes; sets the filter's weights uniform
        (the redistributed set's)."""
        plan, draws, b = self._plan, self._draws, self._drawn
        if plan is not None and draws is not None and plan.m == m and b < draws.count:
            # (the common case, first: numbers drawn ahead are left)
            self._drawn = b + 1
            self.w = self._uniform_w if len(self._uniform_w) == m else np.full(m, 1.0 / m)
            return plan, draws, b
        if plan is None or plan.m != m:
            p = self.params
            plan = self._plan = RedistributionPlan(
                m, self.area, top_fraction=p.top_fraction, local_fraction=p.local_fraction,
                spread_m=p.spread_m, heading_spread_rad=p.heading_spread_rad)
            self._draws = None
        draws = self._draws
        if draws is None:
            count = max(1, _DRAW_NUMBERS // (4 * m)) if self._quiet_motion else 1
            draws = self._draws = self.backend.paper_draws(plan, self.rng, count)
            self._drawn = 0
        elif self._drawn >= draws.count:
            draws.refill(self.rng)
            self._drawn = 0
        b = self._drawn
        self._drawn = b + 1
        self.w = self._uniform_w if len(self._uniform_w) == m else np.full(m, 1.0 / m)
        return plan, draws, b

    # ------------------------------------------------------------------ estimate
    def _spread(self) -> tuple[FloatArray, float]:
        """Covariance (3, 3) and effective sample size of the last estimate."""
        cov = self._cov
        if cov is None:
            return np.zeros((3, 3)), 0.0
        return cov.value()

    def estimate(self) -> Estimate | None:
        if self._mean is None:
            return None
        x, y, th = self._mean
        cov, ess = self._spread()
        self.last_ess = ess
        return Estimate(x, y, th, cov, len(self.z), ess)

    # ------------------------------------------------------------------ replay
    def run(self, times: FloatArray, observations: Sequence[Observation | None],
            steps: Deltas | None, *, progress: Callable[[int], None] | None = None,
            cloud_period_s: float = 2.0, cloud_size: int = 50) -> EstimateRows:
        """:meth:`Estimator.run` with the same results as ``predict``, ``update`` and
        ``estimate`` in turn, faster: the scans' candidate map reflectors are looked up and
        the motions laid out for all observations at once, and the particle sets of
        consecutive updates are weighed in one block of the backend
        (:class:`lgvtool.localize.particle_backend.PaperBlock`), which keeps their
        covariances and effective sample sizes."""
        n = len(observations)
        if steps is not None and n > 1:
            moves: list[tuple[float, float, float, float, float]] | None = list(zip(
                steps.dx.tolist(), steps.dy.tolist(), steps.dth.tolist(), steps.dist.tolist(),
                steps.rot.tolist(), strict=True))
            motion = self.backend.paper_motions(steps.dx, steps.dy, steps.dth) \
                if self._quiet_motion else None
        else:
            moves = motion = None
        prepared = BlockwiseMap(self._prepare_scans, observations)  # a block at a time
        ts = np.asarray(times, dtype=np.float64).tolist()
        rec = _Recorder()
        if self._mean is not None:
            rec.fixed(*self._spread())
        clouds: list[Cloud] = []
        next_cloud = -math.inf
        report = Reporter(progress)
        block = self._block(motion)
        m = len(self.z)
        rows, which = rec.rows, rec.which
        for i, o in enumerate(observations):
            scan = prepared.get(i) if o is not None else None
            # the index of the motion still to apply to the estimate and the reference pose
            # (-1: none; a scan weighed below sets both anew)
            refs_behind = -1
            # the motion the weighing below applies (-1: none)
            fused = -1
            if i > 0 and moves is not None:
                if motion is not None and block is not None:
                    if scan is not None and self._start_left == 0:
                        fused = i - 1
                    else:
                        block.move(i - 1)
                    if scan is None:
                        self._move_refs(*moves[i - 1][:3])
                    else:
                        refs_behind = i - 1
                else:
                    self._leave(block, rec)
                    self.predict(Motion(*moves[i - 1]))
                    block = self._block(motion)
                    m = len(self.z)
            if o is not None:
                if scan is not None and block is not None and self._start_left == 0:
                    # motion (when fused), transform, association, eq. 10 and eq. 11's sums;
                    # the estimate; the redistribution with the set's spread
                    sx, sy, sc, ss, total = block.weigh(scan, fused)
                    self._mean = self._ref = (sx / total, sy / total, math.atan2(ss, sc))
                    rec.count += 1
                    if not block.redistribute(*self._redistribution(m)):
                        rec.close(block)
                        block.restart()
                else:
                    if refs_behind >= 0:
                        self._move_refs(*moves[refs_behind][:3])  # type: ignore[index]
                    self._leave(block, rec)
                    before = self._cov
                    self.update(o)
                    if self._cov is not before:
                        rec.fixed(*self._spread())
                    block = self._block(motion)
                    m = len(self.z)
            if self._mean is not None and block is not None:
                t = ts[i]
                rows.append((t, *self._mean, m))
                which.append(rec.count - 1)
                if cloud_size > 0 and t >= next_cloud:
                    now = block.particles()
                    c = now[cloud_sample(len(now), cloud_size)]
                    clouds.append((t, c[:, 0].real.copy(), c[:, 0].imag.copy(),
                                   np.angle(c[:, 1])))
                    next_cloud = t + cloud_period_s
            report.at(i)
        report.at(n, last=True)
        self._leave(block, rec)
        out = rec.finish(clouds)
        cov, ess = out.poses.covariance, out.poses.ess
        if cov is not None and ess is not None and len(cov):
            self._cov = KnownSpread(cov[-1].reshape(3, 3).copy(), float(ess[-1]))
            self.last_ess = float(ess[-1])
        return out

    def _block(self, motions: PaperMotions | None) -> PaperBlock | None:
        """A block starting with the current particles, moved by the run's ``motions`` (None
        without particles)."""
        m = len(self.z)
        if not m:
            return None
        return self.backend.paper_block(self._packed(), motions, self.map, self._factor,
                                        self._near(m))

    def _leave(self, block: PaperBlock | None, rec: _Recorder) -> None:
        """Hand the particles of ``block`` back to the filter and record the covariances of
        its weighed sets."""
        if block is not None:
            self._adopt(block.particles().copy())
            rec.close(block)
            block.restart()

    def _prepare_scans(self, observations: Sequence[Observation | None]
                       ) -> dict[int, PaperScan]:
        """For the scans whose reflectors all have an id in the map (and when association is
        by nearest neighbour): per observation index, the scan for
        :meth:`PaperBackend.paper_exponents` with the reflector of each point's id as its
        candidate."""
        if self.params.use_ids or len(self.map) == 0:
            return {}
        idx = [i for i, o in enumerate(observations)
               if isinstance(o, ScanObservation) and len(o) > 0]
        if not idx:
            return {}
        scans: list[ScanObservation] = [observations[i] for i in idx]  # type: ignore[misc]
        j = self.map.index_of(np.concatenate([o.ids for o in scans]))
        known = j >= 0
        j = np.where(known, j, 0)
        q = np.concatenate([o.q for o in scans])
        bounds = np.cumsum([0] + [len(o.q) for o in scans])
        complete = np.logical_and.reduceat(known, bounds[:-1]).tolist()
        laid = self.backend.paper_scans(q, self.map.z[j], self.map.half_sep[j],
                                        bounds.tolist(), complete)
        return {i: sc for i, sc in zip(idx, laid, strict=True) if sc is not None}


class _Recorder:
    """Collects the rows of :meth:`PaperParticleFilter.run`: ``rows`` (t, x, y, heading,
    particles) and ``which``, the weighed set whose covariance and ESS each row takes (the
    last one before it); ``count`` sets have been weighed."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float, float, int]] = []
        self.which: list[int] = []
        self.covs: list[FloatArray] = []
        self.ess: list[FloatArray] = []
        self.count = 0

    def fixed(self, cov: FloatArray, ess: float) -> None:
        """A weighed set whose covariance and ESS are known."""
        self.covs.append(np.asarray(cov, dtype=np.float64).reshape(1, 9))
        self.ess.append(np.array([ess]))
        self.count += 1

    def close(self, block: PaperBlock) -> None:
        """Record the covariances and ESS of the sets weighed in ``block``."""
        cov, ess = block.spread()
        if len(cov):
            self.covs.append(cov)
            self.ess.append(ess)

    def finish(self, clouds: list[Cloud]) -> EstimateRows:
        covs = np.concatenate(self.covs) if self.covs else np.zeros((0, 9))
        ess = np.concatenate(self.ess) if self.ess else np.zeros(0)
        which = np.array(self.which, dtype=np.intp)
        if len(which) and which.min() < 0:
            raise ValueError("an estimate before any weighed particle set")
        a = np.array(self.rows, dtype=np.float64).reshape(-1, 5)
        return EstimateRows(Trajectory(a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy(),
                                       a[:, 3].copy(), covariance=covs[which],
                                       particles=a[:, 4].astype(np.int64), ess=ess[which]),
                            clouds)


def _moved(pose: tuple[float, float, float], dx: float, dy: float, dth: float, *,
           wrap: bool = True) -> tuple[float, float, float]:
    """``pose`` (m, m, rad) followed by the body-frame motion ``(dx, dy, dth)``; the heading
    wrapped to [-pi, pi] when ``wrap``."""
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    h = th + dth
    return (x + c * dx - s * dy, y + s * dx + c * dy,
            wrap_scalar(h) if wrap else h)
