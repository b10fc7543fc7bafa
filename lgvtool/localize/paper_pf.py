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

Without reflector scans (a log with the NAV pose only) the same weight is computed from the
distance between each particle's head position and the reported one plus ``pose_heading_m``
times the heading difference, so the filter still runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_scalar
from lgvtool.localize.estimator import (
    Cloud,
    Estimate,
    EstimateRows,
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
from lgvtool.localize.particles import ParticleInitParams, ParticleSet
from lgvtool.localize.resampling import RedistributionDraws, RedistributionPlan

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

#: redistributions whose random numbers are drawn in one call (about 2^14 numbers at most:
#: larger blocks no longer fit the caches)
_DRAW_NUMBERS = 1 << 14
#: particle sets of about this many particles in all are weighed in one block by
#: :meth:`PaperParticleFilter.run`, and their covariances computed together
_COVARIANCE_BLOCK = 1 << 14

#: heading spread of the redistribution, rad. The paper gives none. A heading offset moves a
#: reflector at range r by r times the offset; this spread moves a reflector 25 m away (across
#: the paper's 25 m x 20 m hall) by at most the paper's position spread of 25 cm, so position
#: and heading spread disturb the measured reflectors alike.
DEFAULT_HEADING_SPREAD = 0.25 / 25.0


@dataclass(frozen=True)
class PaperPfParams(MotionParams, SourceParams, ParticleInitParams):
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
    pose_heading_m: float = param(1.0, "pose-only weight: metres of distance per radian of "
                                  "heading difference, m/rad", minimum=0.0)
    noise_dist: float = param(0.0, "along-track motion noise per metre, m/m (the paper adds "
                              "none: redistribution spreads the particles)", minimum=0.0)
    noise_lat: float = param(0.0, "across-track motion noise per metre, m/m", minimum=0.0)
    noise_rot: float = param(0.0, "heading noise per radian turned, rad/rad", minimum=0.0)
    noise_rot_per_m: float = param(0.0, "heading noise per metre travelled, rad/m",
                                   minimum=0.0)
    use_ids: bool = param(False, "use reflector ids for association (the paper associates "
                          "with the nearest known reflector)")
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


class PaperParticleFilter(ParticleSet):
    """The paper's particle filter (section 3.2), every constant a parameter.

    The particles are kept packed as the rows of one (M, 3) complex array: position ``z``,
    heading rotor ``rot`` and 1. Putting a scan's reflectors into the world at every particle
    and comparing them with candidate map reflectors is then one matrix product, and the
    weighted sums of eq. 11 (with the sum of the weights) another. The redistribution's random
    numbers are drawn ahead for several updates at once when the filter draws nothing else
    per update (no motion noise, the paper's default): the same numbers in the same order as
    one draw per update, so results do not depend on it.
    """

    name = "pf-paper"
    Params = PaperPfParams
    summary = "the paper's particle filter: 150 particles, eq. 9-11, 95/25 redistribution"

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        p = self.params
        #: pose of the last estimate (x, y m, heading rad), moved by the odometry since
        self._mean: tuple[float, float, float] | None = None
        #: what the covariance and ESS of the last estimate are computed from: the packed
        #: weighted particles, their (unnormalised) weights and the weighted sums of z and rot;
        #: replaced by (covariance, ESS) once computed
        self._cov: _Weighted | tuple[FloatArray, float] | None = None
        self._plan: RedistributionPlan | None = None
        self._draws: RedistributionDraws | None = None
        self._drawn = 0
        self._quiet_motion = (p.noise_dist == 0.0 and p.noise_lat == 0.0 and p.noise_rot == 0.0
                              and p.noise_rot_per_m == 0.0)
        #: exponent factor of eq. 10: w = exp(factor D^2)
        self._factor = -0.5 / (p.sigma_m * p.sigma_m)
        self._packing: tuple[ComplexArray, ComplexArray, ComplexArray] | None = None
        self._buffers: dict[tuple[int, int, int], tuple[FloatArray, ...]] = {}
        self._map_z3 = self.map.z[:, None, None]
        self._map_z = np.ascontiguousarray(self.map.z)
        #: eq. 11's sums of the last weighing with the kernels (x, y m, cos, sin, weights)
        self._sums = np.zeros(5)
        self._work = self._kern.paper_scratch() if self._kern is not None else None
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
        """The particles as one (M, 3) complex array with columns ``z``, ``rot`` and ones
        (with the kernels (M, 2), without the ones)."""
        pk = self._packing
        if pk is not None and pk[1] is self.z and pk[2] is self.rot:
            return pk[0]
        s = np.empty((len(self.z), 2 if self._kern is not None else 3), dtype=np.complex128)
        s[:, 0] = self.z
        s[:, 1] = self.rot
        if self._kern is None:
            s[:, 2] = 1.0
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
        step = _motion_matrices(np.array([motion.dx]), np.array([motion.dy]),
                                np.array([motion.dth]))[0]
        if self._kern is not None:
            s = self._packed()
            new = np.empty_like(s)
            self._kern.paper_move(s, new, complex(step[1, 0]), complex(step[1, 1]))
            self._adopt(new)
        else:
            self._adopt(self._packed() @ step)
        self._move_refs(motion.dx, motion.dy, motion.dth)

    # ------------------------------------------------------------------ correction
    def distances(self, obs: Observation) -> FloatArray:
        """The summed association distance ``D_m`` of every particle, m."""
        if isinstance(obs, PoseObservation):
            dx, dy, dh = self.head_residuals(obs)
            out: FloatArray = np.sqrt(dx * dx + dy * dy) + self.params.pose_heading_m * np.abs(dh)
            return out
        if self.params.use_ids:
            summed: FloatArray = np.abs(self.scan_residuals(obs, True)).sum(axis=1)
            return summed
        return self._nearest_sums(self._packed(), self._scan(obs))

    def _scan(self, obs: ScanObservation) -> _Scan | ComplexArray:
        """``obs`` laid out for :meth:`_nearest_sums`, each point's candidate the map reflector
        of its id or the nearest one seen from the reference pose (with the kernels as
        :func:`_kernel_scan`)."""
        j1 = self._reference_nearest(obs)
        cand = self.map.z[j1]
        if self._kern is not None:
            return _kernel_scan(obs.q, cand, self.map.half_sep[j1])
        return _Scan(np.stack((np.ones(len(obs)), obs.q, -cand)), self.map.half_sep[j1], cand)

    def _nearest_sums(self, s: ComplexArray, scan: _Scan | ComplexArray,
                      exponent: FloatArray | None = None) -> FloatArray:
        """``D_m``: the summed distances from every particle's measured points to their nearest
        map reflectors, m (``s``: the packed particles). With
        ``exponent``, writes the exponent of eq. 10, ``-D_m^2 / (2 sigma^2)``, there instead
        and returns it.

        Each point is compared with its candidate map reflector; a point within half the
        candidate's spacing to its nearest neighbour has no nearer one, the others are
        compared with the whole map. The particles spread uniformly by the last
        redistribution (the last ones) are compared with the whole map.
        """
        m = len(s)
        kern = self._kern
        if kern is not None:
            out = np.empty(m) if exponent is None else exponent
            assert not isinstance(scan, _Scan)
            kern.paper_exponents(s, s, 0j, 1 + 0j, scan, self._map_z,
                                 1.0 if exponent is None else self._factor, out, self._work)
            if exponent is None:
                np.sqrt(out, out=out)
            return out
        assert isinstance(scan, _Scan)
        plan = self._plan
        n = m if plan is None or plan.m != m else plan.n_local
        k = scan.k
        bufs = self._buffers.get((m, n, k))
        if bufs is None:
            d = np.empty((m, k))
            bufs = self._buffers[(m, n, k)] = (d, d[:n], d[n:], np.ones(k), np.empty(m))
        d, near, tail, ones, sums = bufs
        # z + rot q - candidate, for every particle and point, in one product
        np.abs(s[:n] @ scan.b, out=near)
        if n < m:
            pts = s[n:, :2] @ scan.b2
            _min(np.abs(self._map_z3 - pts), axis=0, out=tail)
        if _max(near, axis=None) >= scan.half_min:
            far = near >= scan.half
            if far.any():
                mi, ki = np.nonzero(far)
                near[mi, ki] = self.map.nearest_distance(s[mi, 0] + s[mi, 1] * scan.b[1, ki])
        np.dot(d, ones, out=sums)
        if exponent is None:
            return sums.copy()
        np.multiply(sums, sums, out=exponent)
        exponent *= self._factor
        return exponent

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
        s = self._packed()
        if isinstance(obs, ScanObservation) and not p.use_ids:
            exponent = self._nearest_sums(s, self._scan(obs), np.empty(len(s)))
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
                 out: ComplexArray) -> _Weighted | tuple[FloatArray, float]:
        """Weigh the packed particles ``s`` with eq. 10, given its exponent
        ``-D_m^2 / (2 sigma^2)``, into ``w`` (unnormalised), estimate with eq. 11
        (``self._mean``) and redistribute into ``out``. Returns what the estimate's covariance
        is computed from; with the kernels the covariance (3, 3) and the ESS themselves."""
        # eq. 10 up to its constant factor, which the normalisation removes; taken relative to
        # the best particle, so that the weights of far particles (the uniform start's) cannot
        # all underflow and the covariance's sums stay finite
        kern = self._kern
        if kern is not None:
            kern.paper_weights(s, exponent, w, self._sums)
            cov = np.empty((3, 3))
            return (cov, self._correct_weighed(s, exponent, w, out, cov))
        exponent -= exponent.max()
        np.exp(exponent, out=w)
        # the weighted sums of x, y, cos th, sin th and the sum of the weights, in one product
        sx, sy, sc, ss, total, _ = (w @ s.view(np.float64)).tolist()
        if not (total > 0.0 and math.isfinite(total)):
            # every weight underflowed: the limit of eq. 11 is the particle(s) with least D
            np.equal(exponent, exponent.max(), out=w)
            sx, sy, sc, ss, total, _ = (w @ s.view(np.float64)).tolist()
        self._mean = self._ref = (sx / total, sy / total, math.atan2(ss, sc))
        plan, draws, b = self._redistribution(len(s))
        plan.apply_packed(s, w, draws, b, out)
        return (s, w, total, complex(sx, sy), complex(sc, ss))

    def _correct_weighed(self, s: ComplexArray, exponent: FloatArray, w: FloatArray,
                         out: ComplexArray, cov: FloatArray) -> float:
        """:meth:`_correct` with the kernels, once the particles are weighed (``w`` and
        eq. 11's sums in ``self._sums``, by :func:`lgvtool.localize.pf_kernels.paper_weigh`
        or ``paper_weights``): the estimate, and the covariance (into ``cov``, 3 x 3) and
        redistribution in one kernel call. Returns the ESS."""
        kern = self._kern
        assert kern is not None
        sums = self._sums
        sx, sy, sc, ss, total = sums.tolist()
        if not (total > 0.0 and math.isfinite(total)):
            # every weight underflowed: the limit of eq. 11 is the particle(s) with least D
            np.equal(exponent, exponent.max(), out=w)
            kern.paper_sums(s, w, sums)
            sx, sy, sc, ss, total = sums.tolist()
        self._mean = self._ref = (sx / total, sy / total, math.atan2(ss, sc))
        m = len(s)
        plan, draws, b = self._plan, self._draws, self._drawn
        if plan is None or draws is None or plan.m != m or b >= draws.count:
            plan, draws, b = self._redistribution(m)
        else:
            self._drawn = b + 1
            self.w = self._uniform_w if len(self._uniform_w) == m else np.full(m, 1.0 / m)
        ess: float = kern.paper_resample(s, w, plan.top(w), draws.u[b], plan.kernel_plan, sums, out,
                                         cov, self._work)
        return ess

    def _redistribution(self, m: int) -> tuple[RedistributionPlan, RedistributionDraws, int]:
        """The plan of the redistribution of ``m`` particles, its random numbers and which of
        them (drawn ahead) the next redistribution takes; sets the filter's weights uniform
        (the redistributed set's)."""
        plan = self._plan
        if plan is None or plan.m != m:
            p = self.params
            plan = self._plan = RedistributionPlan(
                m, self.area, top_fraction=p.top_fraction, local_fraction=p.local_fraction,
                spread_m=p.spread_m, heading_spread_rad=p.heading_spread_rad)
            self._draws = None
        draws = self._draws
        if draws is None:
            count = max(1, _DRAW_NUMBERS // (4 * m)) if self._quiet_motion else 1
            draws = self._draws = plan.draw(self.rng, count, packed=True,
                                            raw=self._kern is not None)
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
        if len(cov) == 5:
            s, w, total, sum_z, sum_rot = cov
            c, e = _covariances_and_ess(s[None], w[None], np.array([total]),
                                        np.array([sum_z]), np.array([sum_rot]))
            self._cov = (c[0], float(e[0]))
            return self._cov
        return cov

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
        the motions turned into matrices for all observations at once, and the particle sets
        of consecutive updates are kept in one block whose covariances and effective sample
        sizes are computed together."""
        n = len(observations)
        if steps is not None and n > 1:
            moves: list[tuple[float, float, float, float, float]] | None = list(zip(
                steps.dx.tolist(), steps.dy.tolist(), steps.dth.tolist(), steps.dist.tolist(),
                steps.rot.tolist(), strict=True))
            motion = _motion_matrices(steps.dx, steps.dy, steps.dth) if self._quiet_motion \
                else None
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
        block = self._block()
        m = len(self.z)
        rows, which = rec.rows, rec.which
        # the particles are in ``block.current``, or in ``block.spare`` when ``pending``
        pending = False
        matmul, copyto = np.matmul, np.copyto
        kern = self._kern
        if kern is not None and motion is not None:
            # the motions as (step, turn) pairs of the kernels
            steps_z, steps_rot = motion[:, 1, 0].tolist(), motion[:, 1, 1].tolist()
        map_z, factor, sums, work = self._map_z, self._factor, self._sums, self._work
        correct = self._correct_weighed
        for i, o in enumerate(observations):
            scan = prepared.get(i) if o is not None else None
            # the index of the motion still to apply to the estimate and the reference pose
            # (-1: none; a scan weighed below sets both anew)
            refs_behind = -1
            # the motion the kernel applies while weighing the particles
            step_z, step_rot = 0j, 1 + 0j
            if i > 0 and moves is not None:
                if motion is not None and block is not None:
                    if kern is None:
                        if pending:
                            matmul(block.spare, motion[i - 1], out=block.current)
                        else:
                            matmul(block.current, motion[i - 1], out=block.spare)
                        pending = not pending
                    elif scan is not None and self._start_left == 0:
                        step_z, step_rot = steps_z[i - 1], steps_rot[i - 1]
                    else:
                        if pending:
                            kern.paper_move(block.spare, block.current, steps_z[i - 1],
                                            steps_rot[i - 1])
                        else:
                            kern.paper_move(block.current, block.spare, steps_z[i - 1],
                                            steps_rot[i - 1])
                        pending = not pending
                    if scan is None:
                        self._move_refs(*moves[i - 1][:3])
                    else:
                        refs_behind = i - 1
                else:
                    self._leave(block, rec, pending)
                    pending = False
                    self.predict(Motion(*moves[i - 1]))
                    block = self._block()
                    m = len(self.z)
            if o is not None:
                if scan is not None and block is not None and self._start_left == 0:
                    s = block.current
                    k = block.k
                    if kern is not None:
                        # motion, transform, association, eq. 10 and eq. 11's sums in one
                        # pass; then the covariance and the redistribution in another
                        kern.paper_weigh(block.spare if pending else s, s, step_z, step_rot,
                                         scan, map_z, factor, block.exponent,
                                         block.weights, sums, work)
                        block.ess[k] = correct(s, block.exponent, block.weights, block.spare,
                                               block.cov_rows[k])
                    else:
                        if pending:
                            copyto(s, block.spare)
                        exponent = self._nearest_sums(s, scan, block.exponent)
                        _, _, total, sum_z, sum_rot = self._correct(  # type: ignore[misc]
                            s, exponent, block.weights, block.spare)
                        block.totals.append(total)
                        block.sum_z.append(sum_z)
                        block.sum_rot.append(sum_rot)
                    pending = True
                    # on to the next row of the block (recording the block when it is full)
                    rec.count += 1
                    k = block.k = k + 1
                    if k < block.size:
                        if kern is None:
                            block.current = block.states[k]
                            block.weights = block.w[k]
                    else:
                        rec.close(block)
                        block.restart()
                else:
                    if refs_behind >= 0:
                        self._move_refs(*moves[refs_behind][:3])  # type: ignore[index]
                    self._leave(block, rec, pending)
                    pending = False
                    before = self._cov
                    self.update(o)
                    if self._cov is not before:
                        rec.fixed(*self._spread())
                    block = self._block()
                    m = len(self.z)
            if self._mean is not None and block is not None:
                t = ts[i]
                rows.append((t, *self._mean, m))
                which.append(rec.count - 1)
                if cloud_size > 0 and t >= next_cloud:
                    now = block.spare if pending else block.current
                    c = now[cloud_sample(len(now), cloud_size)]
                    clouds.append((t, c[:, 0].real.copy(), c[:, 0].imag.copy(),
                                   np.angle(c[:, 1])))
                    next_cloud = t + cloud_period_s
            report.at(i)
        report.at(n, last=True)
        self._leave(block, rec, pending)
        out = rec.finish(clouds)
        if len(out.covariance):
            self._cov = (out.covariance[-1].reshape(3, 3).copy(), float(out.ess[-1]))
            self.last_ess = float(out.ess[-1])
        return out

    def _block(self) -> _Block | None:
        """A block starting with the current particles (None without particles)."""
        return _Block(self._packed(), self._kern) if len(self.z) else None

    def _leave(self, block: _Block | None, rec: _Recorder, pending: bool) -> None:
        """Hand the particles of ``block`` (in its spare row when ``pending``) back to the
        filter and record the covariances of its weighed sets."""
        if block is not None:
            self._adopt((block.spare if pending else block.current).copy())
            rec.close(block)
            block.restart()

    def _prepare_scans(self, observations: Sequence[Observation | None]
                       ) -> dict[int, _Scan] | dict[int, ComplexArray]:
        """For the scans whose reflectors all have an id in the map (and when association is
        by nearest neighbour): per observation index, the scan for :meth:`_nearest_sums` with
        the reflector of each point's id as its candidate (with the kernels as
        :func:`_kernel_scan`)."""
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
        cand = self.map.z[j]
        q = np.concatenate([o.q for o in scans])
        half = self.map.half_sep[j]
        bounds = np.cumsum([0] + [len(o.q) for o in scans])
        starts = bounds[:-1]
        complete = np.logical_and.reduceat(known, starts).tolist()
        bounds_list = bounds.tolist()
        if self._kern is not None:
            pack = _kernel_scan(q, cand, half)
            return {i: pack[a:e] for i, a, e, ok in zip(idx, bounds_list[:-1], bounds_list[1:],
                                                        complete, strict=True) if ok}
        b = np.stack((np.ones(len(j)), q, -cand))
        least = np.minimum.reduceat(half, starts).tolist()
        out: dict[int, _Scan] = {}
        for i, a, e, ok, h in zip(idx, bounds_list[:-1], bounds_list[1:], complete, least,
                                  strict=True):
            if ok:
                out[i] = _Scan(b[:, a:e], half[a:e], cand[a:e], h)
        return out


def _kernel_scan(q: ComplexArray, cand: ComplexArray, half: FloatArray) -> ComplexArray:
    """A scan laid out for :func:`lgvtool.localize.pf_kernels.paper_exponents`, (K, 3): per
    point its position in the body frame (m), its candidate map reflector (m) and, as the
    real part, half the candidate's distance to its nearest neighbour (m)."""
    return np.stack((q, cand, half), axis=1)


_max = np.maximum.reduce
_min = np.minimum.reduce


class _Scan:
    """A scan laid out for :meth:`PaperParticleFilter._nearest_sums`: ``b`` (3, K) rows ones,
    the measured points ``q`` (body frame, m) and minus a candidate map reflector per point
    (m); ``b2`` its first two rows; ``q`` the points and ``cand`` the candidates (m);
    ``half``: half each candidate's distance to its nearest neighbour (m), and the least of
    those."""

    __slots__ = ("b", "b2", "cand", "half", "half_min", "k", "q")

    def __init__(self, b: ComplexArray, half: FloatArray, cand: ComplexArray,
                 half_min: float | None = None) -> None:
        self.b = b
        self.b2 = b[:2]
        self.q = b[1]
        self.cand = cand
        self.half = half
        if half_min is None:
            half_min = float(half.min()) if len(half) else math.inf
        self.half_min = half_min
        self.k = b.shape[1]


#: a weighted particle set: packed particles (M, 3), unnormalised weights, their sum and the
#: weighted sums of z and rot
_Weighted = tuple[ComplexArray, FloatArray, float, complex, complex]


def _motion_matrices(dx: FloatArray, dy: FloatArray, dth: FloatArray) -> ComplexArray:
    """Eq. 9 for packed particles as matrices, (n, 3, 3): the packed particles times matrix
    ``k`` are the particles moved by the body-frame motion ``(dx[k], dy[k])`` (m) and turned by
    ``dth[k]`` (rad): ``z + rot (dx + i dy)``, ``rot exp(i dth)``, 1."""
    out = np.zeros((len(dx), 3, 3), dtype=np.complex128)
    out[:, 0, 0] = 1.0
    out[:, 1, 0].real = dx
    out[:, 1, 0].imag = dy
    out[:, 1, 1].real = np.cos(dth)
    out[:, 1, 1].imag = np.sin(dth)
    out[:, 2, 2] = 1.0
    return out


def _covariances_and_ess(s: ComplexArray, w: FloatArray, total: FloatArray, sum_z: ComplexArray,
                         sum_rot: ComplexArray, work: _Work | None = None
                         ) -> tuple[FloatArray, FloatArray]:
    """Covariances (B, 3, 3) and effective sample sizes (B,) of ``B`` weighted particle sets:
    packed particles ``s`` (B, M, 3), unnormalised weights ``w`` (B, M), their sums ``total``
    (B,) and the weighted sums of z and rot (B,). ``work``: scratch for at least B sets.

    With ``d = z - mean`` and ``h`` the heading deviations from the circular mean (rad), the
    covariance entries are the weighted sums of the products of ``(Re d, Im d, h)``.
    """
    b, m = w.shape
    if work is None or len(work.wn) < b or work.wn.shape[1] != m:
        work = _Work(b, m)
    wn, a, aw = work.wn[:b], work.a[:, :b], work.aw[:, :b]
    d, r = work.d[:b], work.r[:b]
    np.divide(w, total[:, None], out=wn)
    np.subtract(s[:, :, 0], (sum_z / total)[:, None], out=d)
    a[0] = d.real
    a[1] = d.imag
    np.multiply(s[:, :, 1], sum_rot.conj()[:, None], out=r)
    np.arctan2(r.imag, r.real, out=a[2])
    np.multiply(a, wn, out=aw)
    cov = np.einsum("ibm,jbm->bij", aw, a)
    ess = 1.0 / np.einsum("bm,bm->b", wn, wn)
    return cov, ess


class _Work:
    """Scratch arrays of :func:`_covariances_and_ess` for ``b`` sets of ``m`` particles."""

    __slots__ = ("a", "aw", "d", "r", "wn")

    def __init__(self, b: int, m: int) -> None:
        self.wn = np.empty((b, m))
        self.a = np.empty((3, b, m))
        self.aw = np.empty((3, b, m))
        self.d = np.empty((b, m), dtype=np.complex128)
        self.r = np.empty((b, m), dtype=np.complex128)


class _Block:
    """Consecutive particle sets of :meth:`PaperParticleFilter.run`: row ``k`` holds the
    particles of the ``k``-th weighing, so the weighed sets stay for the covariances without
    copies; a redistribution writes ``spare``, from which the next motion moves the particles
    into the next row. A full block starts over at row 0. With the kernels, which compute
    each set's covariance and ESS as they redistribute it (into ``cov_rows[k]`` and
    ``ess[k]``), the particles stay in row 0 and ``spare``."""

    def __init__(self, first: ComplexArray, kernels: ModuleType | None = None) -> None:
        m, cols = first.shape
        self.kernels = kernels
        self.size = max(1, _COVARIANCE_BLOCK // max(1, m))
        rows = 1 if kernels is not None else self.size
        self.states = np.empty((rows, m, cols), dtype=np.complex128)
        self.states[0] = first
        #: where a redistribution or a motion writes the particles before they are weighed
        self.spare = np.empty((m, cols), dtype=np.complex128)
        self.w = np.empty((rows, m))
        #: the exponent of eq. 10 of the set being weighed
        self.exponent = np.empty(m)
        if kernels is not None:
            self.cov = np.empty((self.size, 3, 3))
            self.cov_rows = list(self.cov)
            self.ess = np.empty(self.size)
        else:
            self.work = _Work(self.size, m)
        self.k = 0
        self.current = self.states[0]
        self.weights = self.w[0]
        self.totals: list[float] = []
        self.sum_z: list[complex] = []
        self.sum_rot: list[complex] = []

    def spread(self) -> tuple[FloatArray, FloatArray]:
        """Covariances (k, 9) and ESS (k,) of the sets weighed so far."""
        k = self.k
        if k == 0:
            return np.zeros((0, 9)), np.zeros(0)
        if self.kernels is not None:
            return self.cov[:k].reshape(k, 9).copy(), self.ess[:k].copy()
        cov, ess = _covariances_and_ess(self.states[:k], self.w[:k], np.array(self.totals),
                                        np.array(self.sum_z), np.array(self.sum_rot),
                                        self.work)
        return cov.reshape(k, 9), ess

    def restart(self) -> None:
        """Start over at row 0 (the weighed sets are recorded)."""
        self.k = 0
        self.current = self.states[0]
        self.weights = self.w[0]
        self.totals, self.sum_z, self.sum_rot = [], [], []


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

    def close(self, block: _Block) -> None:
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
        return EstimateRows(a[:, 0].copy(), a[:, 1].copy(), a[:, 2].copy(), a[:, 3].copy(),
                            covs[which], a[:, 4].astype(np.int64), ess[which], clouds)


def _moved(pose: tuple[float, float, float], dx: float, dy: float, dth: float, *,
           wrap: bool = True) -> tuple[float, float, float]:
    """``pose`` (m, m, rad) followed by the body-frame motion ``(dx, dy, dth)``; the heading
    wrapped to [-pi, pi] when ``wrap``."""
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    h = th + dth
    return (x + c * dx - s * dy, y + s * dx + c * dy,
            wrap_scalar(h) if wrap else h)
