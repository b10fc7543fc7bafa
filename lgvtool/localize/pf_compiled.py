"""The particle filters' backend on the compiled kernels (:mod:`lgvtool.localize.pf_kernels`,
numba, the ``fast`` extra): :class:`CompiledParticles`, the same operations as the numpy
reference :class:`lgvtool.localize.particle_backend.NumpyParticles` (the same random numbers
in the same order; the results within the last bits, ``docs/performance.md``).

Importing this module imports numba: :func:`lgvtool.localize.kernel_choice.particle_backend`
imports it when a filter is made, never at start-up. ``pf-paper``'s particles are packed as
rows ``(z, rot)``, without the numpy path's column of ones.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, cast

import numpy as np

from lgvtool.localize import particle_backend as pb
from lgvtool.localize import pf_kernels as k
from lgvtool.localize.particle_backend import (
    PAPER_BLOCK_PARTICLES,
    ComplexArray,
    FloatArray,
    IndexArray,
    KnownSpread,
    PaperBlock,
    PaperMotions,
    PaperScan,
    ParticleArrays,
    Pose,
    ScanTracker,
    Spread,
    Survivors,
    TrackSettings,
    TrackState,
    Weighed,
    motion_matrices,
    predict_particles,
)

if TYPE_CHECKING:
    from lgvtool.localize.chunks import ScanChunk
    from lgvtool.localize.estimator import Motion, RowRecorder
    from lgvtool.localize.kld import KldSizing
    from lgvtool.localize.observations import ReflectorMap, ScanObservation
    from lgvtool.localize.pf_likelihood import ScanModel
    from lgvtool.localize.resampling import RedistributionDraws, RedistributionPlan

# the replay's statuses are the kernel's
assert (k.TRACK_DONE, k.TRACK_STEP, k.TRACK_RESAMPLE, k.TRACK_CLOUD) == (
    pb.TRACK_DONE, pb.TRACK_STEP, pb.TRACK_RESAMPLE, pb.TRACK_CLOUD)


def kernel_scan(q: ComplexArray, cand: ComplexArray, half: FloatArray) -> ComplexArray:
    """A scan laid out for :func:`lgvtool.localize.pf_kernels.paper_exponents`, (K, 3): per
    point its position in the body frame (m), its candidate map reflector (m) and, as the
    real part, half the candidate's distance to its nearest neighbour (m)."""
    return np.stack((q, cand, half), axis=1)


class CompiledParticles:
    """The particle filters' operations on the compiled kernels
    (:class:`lgvtool.localize.particle_backend.ParticleBackend`); one per filter (it holds
    the kernels' scratch)."""

    #: from this many particles on, ``pf``'s prediction draws its normal numbers inside the
    #: kernel (the same numbers; cheaper per number, but a fixed cost per call)
    DRAW_IN_KERNEL = 2048

    def __init__(self) -> None:
        #: eq. 11's sums of the last weighing (x, y m, cos, sin, weights)
        self._sums = np.zeros(5)
        self._work = k.paper_scratch()
        self._map: ReflectorMap | None = None
        self._map_z = np.zeros(0, dtype=np.complex128)

    def _map_points(self, rmap: ReflectorMap) -> ComplexArray:
        """The map's reflectors as one contiguous complex array (m)."""
        if rmap is not self._map:
            self._map, self._map_z = rmap, np.ascontiguousarray(rmap.z)
        return self._map_z

    # ------------------------------------------------------------------ pf
    def predict(self, rng: np.random.Generator, z: ComplexArray, th: FloatArray,
                rot: ComplexArray, motion: Motion, sigmas: tuple[float, float, float]
                ) -> tuple[ComplexArray, FloatArray, ComplexArray]:
        n = len(z)
        if sigmas == (0.0, 0.0, 0.0):
            return predict_particles(rng, z, th, rot, motion, sigmas)
        # eq. 9 with the numpy path's draw, in one pass
        z_out, th_out = np.empty(n, dtype=np.complex128), np.empty(n)
        rot_out = np.empty(n, dtype=np.complex128)
        if n >= self.DRAW_IN_KERNEL:
            k.pf_predict_drawn(rng, z, th, rot, motion.dx, motion.dy, motion.dth, *sigmas,
                               z_out, th_out, rot_out)
        else:
            g = rng.standard_normal((3, n))
            k.pf_predict(z, th, rot, g, motion.dx, motion.dy, motion.dth, *sigmas, z_out,
                         th_out, rot_out)
        return z_out, th_out, rot_out

    def predict_covariance(self, cov: FloatArray, rot: ComplexArray, step: ComplexArray,
                           sigmas: tuple[float, float, float]) -> FloatArray:
        out = np.empty_like(cov)
        k.pf_predict_covariance(cov, rot, np.ascontiguousarray(step), *sigmas, out)
        return out

    def scan_loglik(self, z: ComplexArray, rot: ComplexArray, obs: ScanObservation,
                    rmap: ReflectorMap, ref: tuple[float, float, float], model: ScanModel
                    ) -> FloatArray:
        # the per-point inputs (association candidates, noise, constants) made in the kernel
        ll = np.empty(len(z))
        m = model
        k.pf_scan(z, rot, np.ascontiguousarray(obs.q), np.ascontiguousarray(obs.u),
                  np.ascontiguousarray(obs.ranges), obs.map_index(rmap),
                  complex(ref[0], ref[1]), complex(math.cos(ref[2]), math.sin(ref[2])),
                  rmap.z, rmap.half_sep, m.sigma_range_m, m.sigma_range_m ** 2,
                  m.sigma_range_per_m, m.sigma_bearing_rad, m.use_ids, m.outlier,
                  m.log_inlier, m.log_outlier, ll, m.gate_root, m.ambiguity_ratio,
                  m.log_mismatch)
        return ll

    def gaussian_proposal(self, z: ComplexArray, rot: ComplexArray, cov: FloatArray,
                          landmarks: ComplexArray, obs: ScanObservation, sr: FloatArray,
                          st: FloatArray, gate: float, g: FloatArray | None
                          ) -> tuple[FloatArray, FloatArray, FloatArray]:
        # the Kalman step, the draw and the correction in one pass
        n = len(z)
        dx, corr, post = np.empty((n, 3)), np.empty(n), np.empty((n, 3, 3))
        k.pf_ekf_proposal(z, rot, np.ascontiguousarray(cov), np.ascontiguousarray(landmarks),
                          np.ascontiguousarray(obs.q), np.ascontiguousarray(obs.u.conj()),
                          sr, st, gate, np.zeros((n, 3)) if g is None else g, dx, corr, post)
        return dx, corr, post

    def weigh(self, logw: FloatArray, ll: FloatArray, z: ComplexArray, rot: ComplexArray
              ) -> Weighed | None:
        # the weights and the weighted pose in one call
        w, logw_out = np.empty(len(ll)), np.empty(len(ll))
        cov = np.empty((3, 3))
        log_avg, ess, x, y, t = k.pf_weigh(logw, ll, z, rot, w, logw_out, cov)
        if not math.isfinite(log_avg):
            return None
        return Weighed(w, logw_out, log_avg, ess, (x, y, t, cov))

    def weighted_pose(self, z: ComplexArray, rot: ComplexArray, w: FloatArray) -> Pose:
        c = np.empty((3, 3))
        x, y, t = k.weighted_pose(z, rot, np.ascontiguousarray(w), c)
        return x, y, t, c

    def systematic(self, w: FloatArray, n: int, u0: float, z: ComplexArray, th: FloatArray,
                   rot: ComplexArray) -> Survivors:
        # the indexes and the copy in one pass (the headings wrapped there)
        idx = np.empty(n, dtype=np.intp)
        z_out, th_out = np.empty(n, dtype=np.complex128), np.empty(n)
        rot_out = np.empty(n, dtype=np.complex128)
        k.low_variance_gather(w, u0, n, z, th, rot, z_out, th_out, rot_out, idx, True)
        return Survivors(idx, z_out, th_out, rot_out)

    def kld_systematic(self, w: FloatArray, u0: float, perm: IndexArray, sizing: KldSizing,
                       z: ComplexArray, th: FloatArray, rot: ComplexArray) -> Survivors:
        # the draws, the bins, the count and the copy in one pass
        cap = sizing.cap
        z_out, th_out = np.empty(cap, dtype=np.complex128), np.empty(cap)
        rot_out, idx = np.empty(cap, dtype=np.complex128), np.empty(cap, dtype=np.intp)
        n = k.pf_kld_resample(w, u0, perm, sizing.need, sizing.n_min, sizing.bin_m,
                              sizing.bin_rad, z, th, rot, z_out, th_out, rot_out, idx)
        return Survivors(idx[:n], z_out[:n], th_out[:n], rot_out[:n])

    def scan_tracker(self, settings: TrackSettings, rmap: ReflectorMap, moving: bool,
                     motion: tuple[FloatArray, FloatArray, FloatArray],
                     noise: tuple[FloatArray, FloatArray, FloatArray]) -> ScanTracker | None:
        return _Tracker(settings, rmap, moving, motion, noise)

    # ------------------------------------------------------------------ pf-paper
    def pack(self, z: ComplexArray, rot: ComplexArray) -> ComplexArray:
        s = np.empty((len(z), 2), dtype=np.complex128)
        s[:, 0] = z
        s[:, 1] = rot
        return s

    def paper_motions(self, dx: FloatArray, dy: FloatArray, dth: FloatArray) -> PaperMotions:
        m = motion_matrices(dx, dy, dth)
        # the motions as (step, turn) pairs of the kernels
        return m[:, 1, 0].tolist(), m[:, 1, 1].tolist()

    def paper_move(self, src: ComplexArray, dst: ComplexArray, motions: PaperMotions,
                   i: int) -> None:
        steps_z, steps_rot = cast(tuple[list[complex], list[complex]], motions)
        k.paper_move(src, dst, steps_z[i], steps_rot[i])

    def paper_scan(self, q: ComplexArray, cand: ComplexArray, half: FloatArray) -> PaperScan:
        return kernel_scan(q, cand, half)

    def paper_scans(self, q: ComplexArray, cand: ComplexArray, half: FloatArray,
                    bounds: Sequence[int], keep: Sequence[bool]) -> list[PaperScan | None]:
        pack = kernel_scan(q, cand, half)
        return [pack[a:e] if ok else None
                for a, e, ok in zip(bounds[:-1], bounds[1:], keep, strict=True)]

    def paper_exponents(self, s: ComplexArray, scan: PaperScan, rmap: ReflectorMap,
                        n_near: int, factor: float | None, out: FloatArray | None
                        ) -> FloatArray:
        # (the kernel finds the particles far from their candidates itself: n_near unused)
        res = np.empty(len(s)) if out is None or factor is None else out
        k.paper_exponents(s, s, 0j, 1 + 0j, cast(ComplexArray, scan), self._map_points(rmap),
                          1.0 if factor is None else factor, res, self._work)
        if factor is None:
            np.sqrt(res, out=res)
        return res

    def paper_weigh(self, s: ComplexArray, exponent: FloatArray, w: FloatArray) -> FloatArray:
        sums = self._sums
        total = k.paper_weights(s, exponent, w, sums)
        if not (total > 0.0 and math.isfinite(total)):
            _least_d(s, exponent, w, sums)
        return sums

    def paper_draws(self, plan: RedistributionPlan, rng: np.random.Generator,
                    count: int) -> RedistributionDraws:
        return plan.draw(rng, count, packed=True, raw=True)

    def paper_redistribute(self, s: ComplexArray, w: FloatArray, sums: FloatArray,
                           plan: RedistributionPlan, draws: RedistributionDraws, b: int,
                           out: ComplexArray) -> Spread:
        # the weighed set's covariance and ESS, and the redistribution, in one call
        cov = np.empty((3, 3))
        ess: float = k.paper_resample(s, w, plan.top(w), draws.u[b], plan.kernel_plan, sums,
                                      out, cov, self._work)
        return KnownSpread(cov, ess)

    def paper_block(self, first: ComplexArray, motions: PaperMotions | None,
                    rmap: ReflectorMap, factor: float, n_near: int) -> PaperBlock:
        # (the kernel finds the particles far from their candidates itself: n_near unused)
        steps = cast(tuple[list[complex], list[complex]], motions or ([], []))
        return _CompiledBlock(first, steps, self._map_points(rmap), factor, self._sums,
                              self._work)


def _least_d(s: ComplexArray, exponent: FloatArray, w: FloatArray, sums: FloatArray) -> None:
    """Every weight underflowed: the limit of eq. 11, weight 1 for the particle(s) with least
    D, and their sums."""
    np.equal(exponent, exponent.max(), out=w)
    k.paper_sums(s, w, sums)


class _CompiledBlock:
    """The compiled :class:`~lgvtool.localize.particle_backend.PaperBlock`: the particles
    stay in ``current`` and ``spare``; a motion due just before a weighing is applied by the
    weighing's kernel (:func:`lgvtool.localize.pf_kernels.paper_weigh`), and each set's
    covariance and ESS are computed as it is redistributed (into ``cov_rows[k]``,
    ``ess[k]``)."""

    def __init__(self, first: ComplexArray, steps: tuple[list[complex], list[complex]],
                 map_z: ComplexArray, factor: float, sums: FloatArray, work: FloatArray
                 ) -> None:
        m, cols = first.shape
        self._steps_z, self._steps_rot = steps
        self._map_z, self._factor, self._sums, self._work = map_z, factor, sums, work
        self.size: int = max(1, PAPER_BLOCK_PARTICLES // max(1, m))
        self.current = first.copy()
        self.spare = np.empty((m, cols), dtype=np.complex128)
        self.weights = np.empty(m)
        self.exponent = np.empty(m)
        self.cov = np.empty((self.size, 3, 3))
        self.cov_rows = list(self.cov)
        self.ess = np.empty(self.size)
        #: the particles are in ``spare`` (else in ``current``)
        self.pending = False
        self.k = 0

    def move(self, i: int) -> None:
        if self.pending:
            k.paper_move(self.spare, self.current, self._steps_z[i], self._steps_rot[i])
        else:
            k.paper_move(self.current, self.spare, self._steps_z[i], self._steps_rot[i])
        self.pending = not self.pending

    def weigh(self, scan: PaperScan, i: int) -> list[float]:
        # motion, transform, association, eq. 10 and eq. 11's sums in one pass
        s, sums = self.current, self._sums
        step_z, step_rot = (self._steps_z[i], self._steps_rot[i]) if i >= 0 else (0j, 1 + 0j)
        total = k.paper_weigh(self.spare if self.pending else s, s, step_z, step_rot,
                              cast(ComplexArray, scan), self._map_z, self._factor,
                              self.exponent, self.weights, sums, self._work)
        if not (total > 0.0 and math.isfinite(total)):
            _least_d(s, self.exponent, self.weights, sums)
        out: list[float] = sums.tolist()
        return out

    def redistribute(self, plan: RedistributionPlan, draws: RedistributionDraws,
                     b: int) -> bool:
        j = self.k
        w = self.weights
        self.ess[j] = k.paper_resample(self.current, w, plan.top(w), draws.u[b],
                                       plan.kernel_plan, self._sums, self.spare,
                                       self.cov_rows[j], self._work)
        self.pending = True
        self.k = j + 1
        return self.k < self.size

    def particles(self) -> ComplexArray:
        return self.spare if self.pending else self.current

    def spread(self) -> tuple[FloatArray, FloatArray]:
        j = self.k
        if j == 0:
            return np.zeros((0, 9)), np.zeros(0)
        return self.cov[:j].reshape(j, 9).copy(), self.ess[:j].copy()

    def restart(self) -> None:
        self.k = 0


class _Tracker:
    """``pf``'s replay of reflector scans in compiled chunks
    (:func:`lgvtool.localize.pf_kernels.pf_track`)."""

    def __init__(self, settings: TrackSettings, rmap: ReflectorMap, moving: bool,
                 motion: tuple[FloatArray, FloatArray, FloatArray],
                 noise: tuple[FloatArray, FloatArray, FloatArray]) -> None:
        m, sz = settings.model, settings.sizing
        self._prm = np.array([m.sigma_range_m, m.sigma_range_m ** 2, m.sigma_range_per_m,
                              m.sigma_bearing_rad, m.log_inlier, m.log_outlier,
                              settings.alpha_slow, settings.alpha_fast,
                              settings.reset_likelihood, settings.ess_threshold, sz.bin_m,
                              sz.bin_rad, m.gate_root, m.ambiguity_ratio, m.log_mismatch],
                             dtype=np.float64)
        self._flags = np.array([m.use_ids, m.outlier, settings.recovery, settings.always,
                                settings.kld, sz.n_min, settings.particles], dtype=np.intp)
        self._cap = sz.cap
        self._need = sz.need
        self._map = rmap
        self._moving = moving
        self._motion = motion
        self._noise = noise
        self._state = np.zeros(k.ST_SIZE)

    def track(self, rng: np.random.Generator, particles: ParticleArrays, state: TrackState,
              chunk: ScanChunk, j: int, i0: int, rec: RowRecorder
              ) -> tuple[int, int, ParticleArrays]:
        st = self._state
        _to_array(state, st)
        c = chunk
        status, j, rec.k, z, th, rot, w, logw = k.pf_track(
            rng, *particles, self._cap, st, c.kinds, c.offs, c.q, c.u, c.ranges, c.ints, j,
            i0, self._moving, rec.times, *self._motion, *self._noise, self._map.z,
            self._map.half_sep, self._prm, self._flags, self._need, rec.next_cloud, rec.t,
            rec.x, rec.y, rec.heading, rec.covariance, rec.particles, rec.ess, rec.k)
        _from_array(st, state)
        return status, j, ParticleArrays(z, th, rot, w, logw)


def _to_array(state: TrackState, st: FloatArray) -> None:
    """``state`` into the kernel's array (:data:`lgvtool.localize.pf_kernels.ST_SIZE`
    entries)."""
    st[:] = 0.0
    st[k.ST_SLOW] = state.slow
    st[k.ST_FAST] = state.fast
    st[k.ST_ESS] = state.ess
    if state.ref is not None:
        st[k.ST_REF] = 1.0
        st[k.ST_REF + 1:k.ST_REF + 4] = state.ref
    if state.cached is not None:
        x, y, t, cov = state.cached
        st[k.ST_CACHED:k.ST_CACHED + 4] = (1.0, x, y, t)
        st[k.ST_CACHED + 4:k.ST_CACHED + 13] = np.asarray(cov).reshape(9)
    st[k.ST_RESAMPLINGS] = state.resamplings


def _from_array(st: FloatArray, state: TrackState) -> None:
    """The kernel's array back into ``state``."""
    v = st.tolist()
    state.tracked = bool(v[k.ST_TRACKED])
    state.slow, state.fast = v[k.ST_SLOW], v[k.ST_FAST]
    state.ess = v[k.ST_ESS]
    if v[k.ST_REF]:
        state.ref = (v[k.ST_REF + 1], v[k.ST_REF + 2], v[k.ST_REF + 3])
    if v[k.ST_CACHED]:
        c = k.ST_CACHED
        state.cached = (v[c + 1], v[c + 2], v[c + 3], st[c + 4:c + 13].reshape(3, 3).copy())
    else:
        state.cached = None
    state.resamplings = int(v[k.ST_RESAMPLINGS])
    state.per_obs = v[k.ST_PER_OBS]
