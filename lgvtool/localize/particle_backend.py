"""The particle filters' backend seam: the array operations of ``pf`` and ``pf-paper`` behind
one small interface per filter, with the numpy implementation (the reference).

A filter holds one backend (``filter.backend``), chosen once when it is made
(:func:`lgvtool.localize.kernel_choice.particle_backend`: :class:`NumpyParticles`, or the
compiled kernels' :class:`lgvtool.localize.pf_compiled.CompiledParticles`) or handed in
(``backend=``); the filters call only the interface, never a kernel. The two implementations
take the same inputs and give the same results (the kernels to the last bits, see
``docs/performance.md``), and draw nothing from the random generator themselves except where
an operation takes it.

- :class:`PfBackend` (``pf``): predict (the motion model; the Gaussians' covariance), weigh
  (the scan likelihood, the EKF proposal, the log weights with the ESS and the weighted pose),
  resample (systematic, with KLD-sizing), estimate (the weighted pose), and optionally a fused
  replay of reflector scans (:meth:`PfBackend.scan_tracker`).
- :class:`PaperBackend` (``pf-paper``): the packed particles (pack, move), the weighing (the
  scans' layout, eq. 10's exponents, the weights with eq. 11's sums), the redistribution with
  the weighed set's spread, and a block of consecutive sets for the replay
  (:class:`PaperBlock`).

Units: positions m (complex ``x + iy``), headings rad (rotors ``exp(i th)``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple, Protocol, cast

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.localize.noise import perturbed_motion
from lgvtool.localize.pf_likelihood import ScanModel, scan_loglik
from lgvtool.localize.pf_proposal import (
    draw,
    kalman_proposal,
    log_weight_correction,
    predict_covariance,
    ray_residuals,
)
from lgvtool.localize.resampling import effective_sample_size, systematic_resample

if TYPE_CHECKING:
    from lgvtool.localize.chunks import ScanChunk
    from lgvtool.localize.estimator import Motion, RowRecorder
    from lgvtool.localize.kld import KldSizing
    from lgvtool.localize.observations import ReflectorMap, ScanObservation
    from lgvtool.localize.resampling import RedistributionDraws, RedistributionPlan

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IndexArray = NDArray[np.intp]
#: a weighted pose: x, y (m), heading (rad) and the 3 x 3 covariance
Pose = tuple[float, float, float, FloatArray]
#: a scan laid out for a backend's :meth:`PaperBackend.paper_exponents` (its own layout)
PaperScan = object
#: eq. 9's motions laid out for a backend's :meth:`PaperBackend.paper_move` (its own layout)
PaperMotions = object

#: particle sets of about this many particles in all make one :class:`PaperBlock`, whose
#: covariances the numpy path computes together
PAPER_BLOCK_PARTICLES = 1 << 14


# ---------------------------------------------------------------------------- values
class Survivors(NamedTuple):
    """What a resampling keeps: the indexes drawn and the particles they select (positions
    ``z``, headings ``th``; with the rotors ``rot`` the headings are wrapped, without (None)
    they are the parents' as they were and the filter makes the rotors)."""

    idx: IndexArray
    z: ComplexArray
    th: FloatArray
    rot: ComplexArray | None


class Weighed(NamedTuple):
    """Log weights after a measurement: the normalised weights ``w`` and their logarithms,
    the log of the weighted mean likelihood ``log_avg``, the effective sample size and the
    weighted pose (:meth:`PfBackend.weighted_pose`)."""

    w: FloatArray
    logw: FloatArray
    log_avg: float
    ess: float
    pose: Pose


class ParticleArrays(NamedTuple):
    """``pf``'s particles: positions ``z``, headings ``th`` (rad), rotors ``rot``, normalised
    weights ``w`` and their logarithms ``logw``."""

    z: ComplexArray
    th: FloatArray
    rot: ComplexArray
    w: FloatArray
    logw: FloatArray


@dataclass
class TrackState:
    """The scalars of ``pf`` a fused replay of scans carries (:meth:`ScanTracker.track`): the
    slow and fast averages of the scans' likelihood and whether they moved (``tracked``), the
    last ESS, the reference pose of the association and the cached estimate (None: none), the
    resamplings done, and the log-likelihood per measurement of the last scan weighed."""

    slow: float
    fast: float
    ess: float
    ref: tuple[float, float, float] | None
    cached: Pose | None
    resamplings: int
    tracked: bool = False
    per_obs: float = 0.0


@dataclass(frozen=True)
class TrackSettings:
    """What a fused replay of scans needs of ``pf``'s parameters: the likelihood, recovery's
    averaging rates and reset threshold, when to resample (``ess_threshold``, ``always``),
    KLD-sampling (``kld``, ``sizing``) or the fixed count (``particles``)."""

    model: ScanModel
    alpha_slow: float
    alpha_fast: float
    reset_likelihood: float
    recovery: bool
    ess_threshold: float
    always: bool
    kld: bool
    sizing: KldSizing
    particles: int


#: why :meth:`ScanTracker.track` returned: every entry of the chunk done
TRACK_DONE = 0
#: entry ``j`` needs the filter's own step (not a reflector scan)
TRACK_STEP = 1
#: entry ``j`` is moved and weighed; its resampling, which recovery may use to re-draw
#: particles, is the filter's (its row not recorded yet)
TRACK_RESAMPLE = 2
#: the row of entry ``j - 1`` is recorded and a particle cloud is due
TRACK_CLOUD = 3


class Spread(Protocol):
    """The covariance (3 x 3: m^2, m rad, rad^2) and effective sample size of a weighed
    ``pf-paper`` set (made when first asked for, by some backends)."""

    def value(self) -> tuple[FloatArray, float]:
        """``(covariance, ESS)``."""
        ...


@dataclass(frozen=True)
class KnownSpread:
    """A :class:`Spread` already computed."""

    cov: FloatArray
    ess: float

    def value(self) -> tuple[FloatArray, float]:
        return self.cov, self.ess


# ---------------------------------------------------------------------------- interfaces
class ScanTracker(Protocol):
    """A fused replay of ``pf``'s reflector scans (:mod:`lgvtool.localize.pf_run`)."""

    def track(self, rng: np.random.Generator, particles: ParticleArrays, state: TrackState,
              chunk: ScanChunk, j: int, i0: int, rec: RowRecorder
              ) -> tuple[int, int, ParticleArrays]:
        """Move, weigh, resample and record the entries of ``chunk`` from ``j`` on (entry
        ``j`` is observation ``i0 + j``), with the random numbers of the filter's own steps
        in their order, until one needs the filter (``TRACK_STEP``, ``TRACK_RESAMPLE``), a
        cloud is due (``TRACK_CLOUD``) or the chunk ends (``TRACK_DONE``); rows from
        ``rec.k`` on (``rec.k`` advanced). ``state`` is read and updated. Returns the status,
        the entry to go on with and the particles."""
        ...


class PfBackend(Protocol):
    """The array operations of ``pf`` (:class:`lgvtool.localize.particle_filter.ParticleFilter`)."""

    def predict(self, rng: np.random.Generator, z: ComplexArray, th: FloatArray,
                rot: ComplexArray, motion: Motion, sigmas: tuple[float, float, float]
                ) -> tuple[ComplexArray, FloatArray, ComplexArray]:
        """Eq. 9 for every particle: the body-frame ``motion`` with Gaussian noise of
        standard deviations ``sigmas`` (along m, across m, heading rad; drawn from ``rng``
        as ``standard_normal((3, M))`` unless all are 0) composed onto each pose. Returns the
        new positions, headings (wrapped when noisy) and rotors."""
        ...

    def predict_covariance(self, cov: FloatArray, rot: ComplexArray, step: ComplexArray,
                           sigmas: tuple[float, float, float]) -> FloatArray:
        """Each particle's Gaussian (M, 3, 3) carried by its world step ``step`` (complex, m)
        with the body-frame motion noise ``sigmas`` added
        (:func:`lgvtool.localize.pf_proposal.predict_covariance`)."""
        ...

    def scan_loglik(self, z: ComplexArray, rot: ComplexArray, obs: ScanObservation,
                    rmap: ReflectorMap, ref: tuple[float, float, float], model: ScanModel
                    ) -> FloatArray:
        """The log-likelihood of each particle for the scan ``obs``
        (:func:`lgvtool.localize.pf_likelihood.scan_loglik`; association candidates seen from
        the reference pose ``ref``)."""
        ...

    def gaussian_proposal(self, z: ComplexArray, rot: ComplexArray, cov: FloatArray,
                          landmarks: ComplexArray, obs: ScanObservation, sr: FloatArray,
                          st: FloatArray, gate: float, g: FloatArray | None
                          ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The EKF proposal (:mod:`lgvtool.localize.pf_proposal`): each particle's Gaussian
        (covariance ``cov``) updated by the scan's ``landmarks`` (M, K), noise ``sr`` along
        and ``st`` across the rays (m), landmarks beyond the chi-square ``gate`` left out;
        drawn from with the standard normal numbers ``g`` (M, 3), or its mean with None.
        Returns the offsets (M, 3), the log weight corrections (M,) and the posterior
        covariances (M, 3, 3)."""
        ...

    def weigh(self, logw: FloatArray, ll: FloatArray, z: ComplexArray, rot: ComplexArray
              ) -> Weighed | None:
        """The log weights ``logw`` times the likelihoods ``exp(ll)``, normalised (log-sum-exp),
        with the ESS and the weighted pose; None when every weight is 0 (the measurement is
        not used)."""
        ...

    def weighted_pose(self, z: ComplexArray, rot: ComplexArray, w: FloatArray) -> Pose:
        """Eq. 11: the weighted mean (the heading as the circular mean) and covariance."""
        ...

    def systematic(self, w: FloatArray, n: int, u0: float, z: ComplexArray, th: FloatArray,
                   rot: ComplexArray) -> Survivors:
        """:func:`lgvtool.localize.resampling.systematic_resample` of ``n`` from the offset
        ``u0`` (one uniform number), with the particles kept."""
        ...

    def kld_systematic(self, w: FloatArray, u0: float, perm: IndexArray, sizing: KldSizing,
                       z: ComplexArray, th: FloatArray, rot: ComplexArray) -> Survivors:
        """KLD-sampling: ``sizing.cap`` systematic draws from ``u0``, taken in the order of
        the permutation ``perm`` until their bins need no more (:class:`KldSizing`), with
        the particles kept."""
        ...

    def scan_tracker(self, settings: TrackSettings, rmap: ReflectorMap, moving: bool,
                     motion: tuple[FloatArray, FloatArray, FloatArray],
                     noise: tuple[FloatArray, FloatArray, FloatArray]) -> ScanTracker | None:
        """A fused replay of reflector scans for these settings, map and per-step ``motion``
        (dx, dy m, dth rad into observation ``i`` at ``i - 1``) and its ``noise`` (the
        standard deviations), or None: the filter runs its own steps."""
        ...


class PaperBlock(Protocol):
    """Consecutive particle sets of ``pf-paper``'s replay (:meth:`PaperParticleFilter.run`):
    the particles move (:meth:`move`), are weighed (:meth:`weigh`) and redistributed
    (:meth:`redistribute`) in the block's arrays; the spread of each weighed set is kept
    until :meth:`spread` is asked (at most a block's worth of sets, then :meth:`restart`)."""

    def move(self, i: int) -> None:
        """Apply motion ``i`` of the run's motions."""
        ...

    def weigh(self, scan: PaperScan, i: int) -> list[float]:
        """Apply motion ``i`` of the run's motions (none when negative; a backend may do it
        in the weighing), then weigh the particles with ``scan``
        (:meth:`PaperBackend.paper_exponents` and :meth:`PaperBackend.paper_weigh`); returns
        eq. 11's sums (of x, y, cos, sin weighted, and of the weights)."""
        ...

    def redistribute(self, plan: RedistributionPlan, draws: RedistributionDraws,
                     b: int) -> bool:
        """Redistribute the set just weighed with redistribution ``b`` of ``draws``, keeping
        its spread; False when the block is full (record it, then :meth:`restart`)."""
        ...

    def particles(self) -> ComplexArray:
        """The current particles, packed (a view into the block)."""
        ...

    def spread(self) -> tuple[FloatArray, FloatArray]:
        """Covariances (k, 9) and ESS (k,) of the sets weighed since the last restart."""
        ...

    def restart(self) -> None:
        """Start over (the weighed sets recorded)."""
        ...


class PaperBackend(Protocol):
    """The array operations of ``pf-paper``
    (:class:`lgvtool.localize.paper_pf.PaperParticleFilter`) on particles packed as the
    rows of one complex array (``z``, ``rot`` and whatever else the backend keeps)."""

    def pack(self, z: ComplexArray, rot: ComplexArray) -> ComplexArray:
        """The particles packed (M, C): column 0 the positions, column 1 the rotors."""
        ...

    def paper_motions(self, dx: FloatArray, dy: FloatArray, dth: FloatArray) -> PaperMotions:
        """Eq. 9's body-frame motions (m, m, rad) laid out for :meth:`paper_move`."""
        ...

    def paper_move(self, src: ComplexArray, dst: ComplexArray, motions: PaperMotions,
                   i: int) -> None:
        """The packed particles ``src`` moved by motion ``i`` into ``dst``."""
        ...

    def paper_scan(self, q: ComplexArray, cand: ComplexArray, half: FloatArray) -> PaperScan:
        """A scan's points ``q`` (body frame, m), a candidate map reflector per point
        ``cand`` (m) and half each candidate's distance to its nearest neighbour (m), laid out
        for :meth:`paper_exponents`."""
        ...

    def paper_scans(self, q: ComplexArray, cand: ComplexArray, half: FloatArray,
                    bounds: Sequence[int], keep: Sequence[bool]) -> list[PaperScan | None]:
        """:meth:`paper_scan` of consecutive scans (points ``bounds[i]:bounds[i + 1]``),
        those with ``keep``."""
        ...

    def paper_exponents(self, s: ComplexArray, scan: PaperScan, rmap: ReflectorMap,
                        n_near: int, factor: float | None, out: FloatArray | None
                        ) -> FloatArray:
        """The summed distances ``D_m`` from each particle's measured points to their nearest
        map reflectors (m), or with ``factor`` eq. 10's exponent ``factor D_m^2`` into
        ``out``; particles from ``n_near`` on (uniform ones) are compared with the whole
        map."""
        ...

    def paper_weigh(self, s: ComplexArray, exponent: FloatArray, w: FloatArray) -> FloatArray:
        """Eq. 10's weights into ``w`` (relative to the best, ``exponent`` shifted to 0 at it;
        when all underflow, 1 for the particles of least ``D``, the limit of eq. 11) and
        eq. 11's sums: of x, y, cos, sin weighted, and of the weights (5,)."""
        ...

    def paper_draws(self, plan: RedistributionPlan, rng: np.random.Generator,
                    count: int) -> RedistributionDraws:
        """The random numbers of the next ``count`` redistributions, laid out for
        :meth:`paper_redistribute`."""
        ...

    def paper_redistribute(self, s: ComplexArray, w: FloatArray, sums: FloatArray,
                           plan: RedistributionPlan, draws: RedistributionDraws, b: int,
                           out: ComplexArray) -> Spread:
        """The paper's redistribution ``b`` of ``draws`` of the weighed set ``s`` (weights
        ``w``, sums ``sums``) into ``out``; returns the weighed set's spread."""
        ...

    def paper_block(self, first: ComplexArray, motions: PaperMotions | None,
                    rmap: ReflectorMap, factor: float, n_near: int) -> PaperBlock:
        """A :class:`PaperBlock` starting with the packed particles ``first``, moved by
        ``motions`` (:meth:`paper_motions` of the run's), weighing with eq. 10's ``factor`` on
        ``rmap`` (the particles from ``n_near`` on, then the uniform ones of each
        redistribution, compared with the whole map)."""
        ...


class ParticleBackend(PfBackend, PaperBackend, Protocol):
    """What a particle filter holds: both filters' operations
    (:func:`lgvtool.localize.kernel_choice.particle_backend`)."""


# ---------------------------------------------------------------------------- numpy
def predict_particles(rng: np.random.Generator, z: ComplexArray, th: FloatArray,
                      rot: ComplexArray, motion: Motion, sigmas: tuple[float, float, float]
                      ) -> tuple[ComplexArray, FloatArray, ComplexArray]:
    """:meth:`PfBackend.predict` with numpy (the reference): the noise-free motion keeps the
    headings as they were plus the turn (not wrapped) and turns the rotors; with noise the
    headings are wrapped and the rotors made from them."""
    dx, dy, dth = perturbed_motion(rng, len(z), motion.dx, motion.dy, motion.dth, sigmas)
    if isinstance(dth, float):
        return (z + rot * complex(dx, dy), th + dth,
                rot * complex(math.cos(dth), math.sin(dth)))
    th = wrap_angle(th + dth)
    return z + rot * (dx + 1j * dy), th, np.exp(1j * th)


def motion_matrices(dx: FloatArray, dy: FloatArray, dth: FloatArray) -> ComplexArray:
    """Eq. 9 for packed particles as matrices, (n, 3, 3): the packed particles (rows ``z``,
    ``rot``, 1) times matrix ``k`` are the particles moved by the body-frame motion
    ``(dx[k], dy[k])`` (m) and turned by ``dth[k]`` (rad): ``z + rot (dx + i dy)``,
    ``rot exp(i dth)``, 1."""
    out = np.zeros((len(dx), 3, 3), dtype=np.complex128)
    out[:, 0, 0] = 1.0
    out[:, 1, 0].real = dx
    out[:, 1, 0].imag = dy
    out[:, 1, 1].real = np.cos(dth)
    out[:, 1, 1].imag = np.sin(dth)
    out[:, 2, 2] = 1.0
    return out


class NumpyParticles:
    """The particle filters' operations as numpy array operations: the reference
    (:class:`ParticleBackend`). Packs ``pf-paper``'s particles as rows ``(z, rot, 1)`` so that
    eq. 9 and eq. 11's sums are matrix products."""

    def __init__(self) -> None:
        #: scratch of :meth:`paper_exponents` by (particles, near ones, points)
        self._buffers: dict[tuple[int, int, int], tuple[FloatArray, ...]] = {}
        self._map: ReflectorMap | None = None
        self._map_z3: ComplexArray = np.zeros((0, 1, 1), dtype=np.complex128)

    # ------------------------------------------------------------------ pf
    def predict(self, rng: np.random.Generator, z: ComplexArray, th: FloatArray,
                rot: ComplexArray, motion: Motion, sigmas: tuple[float, float, float]
                ) -> tuple[ComplexArray, FloatArray, ComplexArray]:
        return predict_particles(rng, z, th, rot, motion, sigmas)

    def predict_covariance(self, cov: FloatArray, rot: ComplexArray, step: ComplexArray,
                           sigmas: tuple[float, float, float]) -> FloatArray:
        return predict_covariance(cov, rot, step, sigmas)

    def scan_loglik(self, z: ComplexArray, rot: ComplexArray, obs: ScanObservation,
                    rmap: ReflectorMap, ref: tuple[float, float, float], model: ScanModel
                    ) -> FloatArray:
        return scan_loglik(z, rot, obs, rmap, ref, model)

    def gaussian_proposal(self, z: ComplexArray, rot: ComplexArray, cov: FloatArray,
                          landmarks: ComplexArray, obs: ScanObservation, sr: FloatArray,
                          st: FloatArray, gate: float, g: FloatArray | None
                          ) -> tuple[FloatArray, FloatArray, FloatArray]:
        r, jac = ray_residuals(z, rot, landmarks, obs.q, obs.u)
        prop = kalman_proposal(cov, r, jac, sr, st, gate)
        dx = prop.d if g is None else draw(prop, g)
        return dx, log_weight_correction(prop, dx), prop.cov

    def weigh(self, logw: FloatArray, ll: FloatArray, z: ComplexArray, rot: ComplexArray
              ) -> Weighed | None:
        lw = logw + ll
        top = float(lw.max())
        if not math.isfinite(top):
            return None
        e = np.exp(lw - top)
        total = float(e.sum())
        log_avg = top + math.log(total)  # log sum_m w_m p_m: the weighted mean likelihood
        w = e / total
        return Weighed(w, lw - log_avg, log_avg, effective_sample_size(w),
                       self.weighted_pose(z, rot, w))

    def weighted_pose(self, z: ComplexArray, rot: ComplexArray, w: FloatArray) -> Pose:
        # all weighted sums from one product with the weights: with d = z - mean and h the
        # heading deviations, sum w d^2 = Sxx - Syy + 2i Sxy, sum w |d|^2 = Sxx + Syy,
        # sum w d h = Sxh + i Syh
        mz = complex(w @ z)
        mr = complex(w @ rot)
        mt = math.atan2(mr.imag, mr.real)
        d = z - mz
        h = np.angle(rot * complex(mr.real, -mr.imag))
        s1, s2, sh, shh = np.stack((d * d, d * d.conj(), d * h, h * h + 0j)) @ w
        sxx, syy, sxy = 0.5 * (s2.real + s1.real), 0.5 * (s2.real - s1.real), 0.5 * s1.imag
        cov = np.array([[sxx, sxy, sh.real], [sxy, syy, sh.imag],
                        [sh.real, sh.imag, shh.real]])
        return mz.real, mz.imag, mt, cov

    def systematic(self, w: FloatArray, n: int, u0: float, z: ComplexArray, th: FloatArray,
                   rot: ComplexArray) -> Survivors:
        idx = systematic_resample(w, n, u0)
        return Survivors(idx, z[idx], th[idx], None)

    def kld_systematic(self, w: FloatArray, u0: float, perm: IndexArray, sizing: KldSizing,
                       z: ComplexArray, th: FloatArray, rot: ComplexArray) -> Survivors:
        idx = systematic_resample(w, sizing.cap, u0)[perm]
        idx = idx[:sizing.count(z.real[idx], z.imag[idx], th[idx])]
        return Survivors(idx, z[idx], th[idx], None)

    def scan_tracker(self, settings: TrackSettings, rmap: ReflectorMap, moving: bool,
                     motion: tuple[FloatArray, FloatArray, FloatArray],
                     noise: tuple[FloatArray, FloatArray, FloatArray]) -> ScanTracker | None:
        return None  # the filter's own steps are the reference

    # ------------------------------------------------------------------ pf-paper
    def pack(self, z: ComplexArray, rot: ComplexArray) -> ComplexArray:
        s = np.empty((len(z), 3), dtype=np.complex128)
        s[:, 0] = z
        s[:, 1] = rot
        s[:, 2] = 1.0
        return s

    def paper_motions(self, dx: FloatArray, dy: FloatArray, dth: FloatArray) -> PaperMotions:
        return motion_matrices(dx, dy, dth)

    def paper_move(self, src: ComplexArray, dst: ComplexArray, motions: PaperMotions,
                   i: int) -> None:
        np.matmul(src, cast(ComplexArray, motions)[i], out=dst)

    def paper_scan(self, q: ComplexArray, cand: ComplexArray, half: FloatArray) -> PaperScan:
        return _Scan(cast(ComplexArray, np.stack((np.ones(len(q)), q, -cand))), half, cand)

    def paper_scans(self, q: ComplexArray, cand: ComplexArray, half: FloatArray,
                    bounds: Sequence[int], keep: Sequence[bool]) -> list[PaperScan | None]:
        b = cast(ComplexArray, np.stack((np.ones(len(q)), q, -cand)))
        least = np.minimum.reduceat(half, np.asarray(bounds[:-1], dtype=np.intp)).tolist()
        return [_Scan(b[:, a:e], half[a:e], cand[a:e], h) if ok else None
                for a, e, ok, h in zip(bounds[:-1], bounds[1:], keep, least, strict=True)]

    def paper_exponents(self, s: ComplexArray, scan: PaperScan, rmap: ReflectorMap,
                        n_near: int, factor: float | None, out: FloatArray | None
                        ) -> FloatArray:
        sc = cast(_Scan, scan)
        m, n, k = len(s), n_near, sc.k
        bufs = self._buffers.get((m, n, k))
        if bufs is None:
            d = np.empty((m, k))
            bufs = self._buffers[(m, n, k)] = (d, d[:n], d[n:], np.ones(k), np.empty(m))
        d, near, tail, ones, sums = bufs
        # z + rot q - candidate, for every particle and point, in one product
        np.abs(s[:n] @ sc.b, out=near)
        if n < m:
            if rmap is not self._map:
                self._map, self._map_z3 = rmap, rmap.z[:, None, None]
            pts = s[n:, :2] @ sc.b2
            _min(np.abs(self._map_z3 - pts), axis=0, out=tail)
        if _max(near, axis=None) >= sc.half_min:
            far = near >= sc.half
            if far.any():
                mi, ki = np.nonzero(far)
                near[mi, ki] = rmap.nearest_distance(s[mi, 0] + s[mi, 1] * sc.b[1, ki])
        np.dot(d, ones, out=sums)
        if factor is None:
            return sums.copy()
        assert out is not None
        np.multiply(sums, sums, out=out)
        out *= factor
        return out

    def paper_weigh(self, s: ComplexArray, exponent: FloatArray, w: FloatArray) -> FloatArray:
        out: FloatArray = _weigh(s, exponent, w)[:5]
        return out

    def paper_draws(self, plan: RedistributionPlan, rng: np.random.Generator,
                    count: int) -> RedistributionDraws:
        return plan.draw(rng, count, packed=True)

    def paper_redistribute(self, s: ComplexArray, w: FloatArray, sums: FloatArray,
                           plan: RedistributionPlan, draws: RedistributionDraws, b: int,
                           out: ComplexArray) -> Spread:
        plan.apply_packed(s, w, draws, b, out)
        sx, sy, sc, ss, total = sums.tolist()
        return _WeighedSet(s, w, total, complex(sx, sy), complex(sc, ss))

    def paper_block(self, first: ComplexArray, motions: PaperMotions | None,
                    rmap: ReflectorMap, factor: float, n_near: int) -> PaperBlock:
        return _NumpyBlock(self, first, cast(ComplexArray | None, motions), rmap, factor,
                           n_near)


_max = np.maximum.reduce
_min = np.minimum.reduce


def _weigh(s: ComplexArray, exponent: FloatArray, w: FloatArray) -> FloatArray:
    """:meth:`NumpyParticles.paper_weigh` of particles packed as rows ``(z, rot, 1)``: eq. 11's
    sums, and a 0 after them (the product's sixth column)."""
    # eq. 10 up to its constant factor, which the normalisation removes; taken relative to
    # the best particle, so that the weights of far particles (the uniform start's) cannot
    # all underflow and the covariance's sums stay finite
    exponent -= exponent.max()
    np.exp(exponent, out=w)
    # the weighted sums of x, y, cos th, sin th and the sum of the weights, in one product
    sums: FloatArray = w @ s.view(np.float64)
    total = float(sums[4])
    if not (total > 0.0 and math.isfinite(total)):
        # every weight underflowed: the limit of eq. 11 is the particle(s) with least D
        np.equal(exponent, exponent.max(), out=w)
        sums = w @ s.view(np.float64)
    return sums


class _Scan:
    """A scan laid out for :meth:`NumpyParticles.paper_exponents`: ``b`` (3, K) rows ones,
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


class _WeighedSet:
    """The :class:`Spread` of a weighed set packed as rows ``(z, rot, 1)``: from its
    particles ``s``, unnormalised weights ``w``, their sum and the weighted sums of z and rot,
    computed when first asked for."""

    __slots__ = ("_made", "s", "sum_rot", "sum_z", "total", "w")

    def __init__(self, s: ComplexArray, w: FloatArray, total: float, sum_z: complex,
                 sum_rot: complex) -> None:
        self.s, self.w, self.total, self.sum_z, self.sum_rot = s, w, total, sum_z, sum_rot
        self._made: tuple[FloatArray, float] | None = None

    def value(self) -> tuple[FloatArray, float]:
        if self._made is None:
            c, e = covariances_and_ess(self.s[None], self.w[None], np.array([self.total]),
                                       np.array([self.sum_z]), np.array([self.sum_rot]))
            self._made = (c[0], float(e[0]))
        return self._made


def covariances_and_ess(s: ComplexArray, w: FloatArray, total: FloatArray,
                        sum_z: ComplexArray, sum_rot: ComplexArray, work: _Work | None = None
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
    """Scratch arrays of :func:`covariances_and_ess` for ``b`` sets of ``m`` particles."""

    __slots__ = ("a", "aw", "d", "r", "wn")

    def __init__(self, b: int, m: int) -> None:
        self.wn = np.empty((b, m))
        self.a = np.empty((3, b, m))
        self.aw = np.empty((3, b, m))
        self.d = np.empty((b, m), dtype=np.complex128)
        self.r = np.empty((b, m), dtype=np.complex128)


class _NumpyBlock:
    """The numpy :class:`PaperBlock`: row ``k`` of ``states`` holds the particles of the
    ``k``-th weighing, so the weighed sets stay for the covariances, computed together for
    the block (:func:`covariances_and_ess`), without copies; a redistribution writes
    ``spare``, from which the next motion moves the particles into the next row."""

    def __init__(self, backend: NumpyParticles, first: ComplexArray,
                 motions: ComplexArray | None, rmap: ReflectorMap, factor: float,
                 n_near: int) -> None:
        m, cols = first.shape
        self._exponents = backend.paper_exponents
        self._map, self._factor = rmap, factor
        self._motions, self._n_near = motions, n_near
        self.size: int = max(1, PAPER_BLOCK_PARTICLES // max(1, m))
        self.states = np.empty((self.size, m, cols), dtype=np.complex128)
        self.states[0] = first
        #: where a redistribution or a motion writes the particles before they are weighed
        self.spare = np.empty((m, cols), dtype=np.complex128)
        self.w = np.empty((self.size, m))
        #: the exponent of eq. 10 of the set being weighed
        self.exponent = np.empty(m)
        self.work = _Work(self.size, m)
        #: the particles are in ``spare`` (else in ``current``)
        self.pending = False
        #: the row of the set being weighed, its particles and weights
        self.k = 0
        self.current: ComplexArray = self.states[0]
        self.weights: FloatArray = self.w[0]
        #: the weighed sets' sums of the weights, and the weighted sums of z and rot
        self.totals: list[float] = []
        self.sum_z: list[complex] = []
        self.sum_rot: list[complex] = []

    def move(self, i: int) -> None:
        assert self._motions is not None
        step = self._motions[i]
        if self.pending:
            np.matmul(self.spare, step, out=self.current)
        else:
            np.matmul(self.current, step, out=self.spare)
        self.pending = not self.pending

    def weigh(self, scan: PaperScan, i: int) -> list[float]:
        s = self.current
        if i >= 0:
            # (the motion into the spare row, then back: as :meth:`move` and the copy below)
            assert self._motions is not None
            if self.pending:
                np.matmul(self.spare, self._motions[i], out=s)
                self.pending = False
            else:
                np.matmul(s, self._motions[i], out=self.spare)
                self.pending = True
        if self.pending:
            np.copyto(s, self.spare)
        exponent = self._exponents(s, scan, self._map, self._n_near, self._factor,
                                   self.exponent)
        sx, sy, sc, ss, total, _ = _weigh(s, exponent, self.weights).tolist()
        self.totals.append(total)
        self.sum_z.append(complex(sx, sy))
        self.sum_rot.append(complex(sc, ss))
        return [sx, sy, sc, ss, total]

    def redistribute(self, plan: RedistributionPlan, draws: RedistributionDraws,
                     b: int) -> bool:
        plan.apply_packed(self.current, self.weights, draws, b, self.spare)
        self._n_near = plan.n_local
        self.pending = True
        k = self.k = self.k + 1
        if k >= self.size:
            return False
        self.current = self.states[k]
        self.weights = self.w[k]
        return True

    def particles(self) -> ComplexArray:
        return self.spare if self.pending else self.current

    def spread(self) -> tuple[FloatArray, FloatArray]:
        k = self.k
        if k == 0:
            return np.zeros((0, 9)), np.zeros(0)
        cov, ess = covariances_and_ess(self.states[:k], self.w[:k], np.array(self.totals),
                                       np.array(self.sum_z), np.array(self.sum_rot),
                                       self.work)
        return cov.reshape(k, 9), ess

    def restart(self) -> None:
        self.k = 0
        self.current = self.states[0]
        self.weights = self.w[0]
        self.totals, self.sum_z, self.sum_rot = [], [], []
