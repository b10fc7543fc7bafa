"""``pf``'s replay loop with its tracking in compiled chunks (:meth:`ParticleFilter.run`).

The filter's ``predict``, ``update`` and ``estimate`` cost about 40 us of Python per
observation around kernels of about 10 us. Here the observations go a chunk at a time
(:mod:`lgvtool.localize.chunks`) to one kernel call
(:func:`lgvtool.localize.pf_kernels.pf_track`) that moves, weighs, resamples and records the
estimate of each in turn, drawing the same random numbers in the same order. The kernel hands
an observation back to the filter's own step when that step needs what only the Python side
does: an observation other than a reflector scan, the start, a uniform start set still
shrinking, or a resampling that recovery may use to re-draw particles (about 1 in 500
resamplings on the paper's drive). It returns too whenever a particle cloud is due. The rows,
clouds and random stream are those of the step-by-step loop
(``tests/localize/test_pf_kernels.py``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.chunks import KIND_OTHER, chunks, scan_chunk
from lgvtool.localize.estimator import (
    EstimateRows,
    Moves,
    Observation,
    Reporter,
    RowRecorder,
)
from lgvtool.localize.observations import ScanObservation

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas
    from lgvtool.localize.particle_filter import ParticleFilter

FloatArray = NDArray[np.float64]


def tracks_in_kernel(pf: ParticleFilter) -> bool:
    """Whether ``pf``'s settings are those :func:`track` runs in the kernel: the compiled
    kernels, the prior proposal without odometry scales, log weights, low-variance
    resampling, no fix-disagreement reset, and a reflector map."""
    p = pf.params
    return (pf._kern is not None and p.proposal == "prior" and not p.odometry_scales
            and p.log_weights and p.resampler == "low-variance"
            and not (p.recovery and p.fix_reset_probability > 0.0) and len(pf.map) > 0)


def track(pf: ParticleFilter, times: FloatArray,
          observations: Sequence[Observation | None], steps: Deltas | None, *,
          progress: Callable[[int], None] | None, cloud_period_s: float,
          cloud_size: int) -> EstimateRows:
    """:meth:`lgvtool.localize.estimator.Estimator.run` of ``pf`` (see
    :func:`tracks_in_kernel`), its observations a chunk at a time through the kernel."""
    kern = pf._kern
    assert kern is not None
    p = pf.params
    n = len(observations)
    moving = steps is not None and n > 1
    moves = Moves(steps) if moving and steps is not None else None
    rec = RowRecorder(times, cloud_period_s, cloud_size)
    f64 = np.float64
    if moving and steps is not None:
        motion = tuple(np.ascontiguousarray(a, dtype=f64) for a in (steps.dx, steps.dy, steps.dth))
        noise = tuple(np.broadcast_to(a, steps.dist.shape).astype(f64)
                      for a in p.noise_sigmas(steps.dist, steps.rot))
    else:
        motion = noise = (np.zeros(0),) * 3
    cap = max(p.particles, p.min_particles)
    eps = p.outlier_prob
    prm = np.array([p.sigma_range_m, p.sigma_range_m ** 2, p.sigma_range_per_m,
                    p.sigma_bearing_rad, math.log1p(-eps), math.log(eps) + pf._log_outlier(2),
                    p.alpha_slow, p.alpha_fast, p.reset_likelihood, p.ess_threshold,
                    p.kld_bin_m, p.kld_bin_rad], dtype=f64)
    flags = np.array([p.use_ids, p.outlier, p.recovery, p.resample == "always", p.kld,
                      p.min_particles, p.particles], dtype=np.intp)
    need = pf._kld_need(cap)
    state = np.zeros(kern.ST_SIZE)
    i0 = 0
    report = Reporter(progress)
    for chunk in chunks(observations):
        c = scan_chunk(chunk, lambda o: o.map_index(pf.map))
        j = 0
        while j < len(chunk):
            o = chunk[j]
            if c.kinds[j] == KIND_OTHER or not pf.initialized or pf._start_left > 0:
                pf.step(i0 + j, o, moves, rec)
                j += 1
                continue
            _to_state(pf, state)
            status, j, rec.k, z, th, rot, w, logw = kern.pf_track(
                pf.rng, pf.z, pf.th, pf.rot, pf.w, pf.logw, cap, state, c.kinds, c.offs, c.q,
                c.u, c.ranges, c.ints, j, i0, moving, rec.times, *motion, *noise, pf.map.z,
                pf.map.half_sep, prm, flags, need, rec.next_cloud, rec.t, rec.x, rec.y,
                rec.heading, rec.covariance, rec.particles, rec.ess, rec.k)
            pf.z, pf.th, pf.rot, pf.w, pf.logw = z, th, rot, w, logw
            _from_state(pf, state)
            if status == kern.TRACK_RESAMPLE:
                # moved and weighed: the filter resamples (recovery may re-draw particles),
                # then the row as the step records it
                o = chunk[j]
                assert isinstance(o, ScanObservation)
                pf._after_weigh("scan", o, float(state[kern.ST_PER_OBS]))
                e = pf.estimate()
                assert e is not None
                rec.add(i0 + j, e)
                rec.maybe_cloud(i0 + j, pf)
                j += 1
            elif status == kern.TRACK_CLOUD:
                rec.maybe_cloud(i0 + j - 1, pf)
        i0 += len(chunk)
        report.at(i0)
    report.at(n, last=True)
    return rec.rows()


def _to_state(pf: ParticleFilter, state: FloatArray) -> None:
    """The filter's scalars into the kernel's ``state``
    (:data:`lgvtool.localize.pf_kernels.ST_SIZE` entries)."""
    kern = pf._kern
    assert kern is not None
    state[:] = 0.0
    state[kern.ST_SLOW] = pf.w_slow.get("scan", 0.0)
    state[kern.ST_FAST] = pf.w_fast.get("scan", 0.0)
    state[kern.ST_ESS] = pf.last_ess
    if pf._ref is not None:
        state[kern.ST_REF] = 1.0
        state[kern.ST_REF + 1:kern.ST_REF + 4] = pf._ref
    if pf._cached is not None:
        x, y, t, cov = pf._cached
        state[kern.ST_CACHED:kern.ST_CACHED + 4] = (1.0, x, y, t)
        state[kern.ST_CACHED + 4:kern.ST_CACHED + 13] = np.asarray(cov).reshape(9)
    state[kern.ST_RESAMPLINGS] = pf.resamplings


def _from_state(pf: ParticleFilter, state: FloatArray) -> None:
    """The kernel's ``state`` back into the filter."""
    kern = pf._kern
    assert kern is not None
    v = state.tolist()
    if v[kern.ST_TRACKED]:
        pf.w_slow["scan"] = v[kern.ST_SLOW]
        pf.w_fast["scan"] = v[kern.ST_FAST]
    pf.last_ess = v[kern.ST_ESS]
    if v[kern.ST_REF]:
        pf._ref = (v[kern.ST_REF + 1], v[kern.ST_REF + 2], v[kern.ST_REF + 3])
    if v[kern.ST_CACHED]:
        c = kern.ST_CACHED
        pf._cached = (v[c + 1], v[c + 2], v[c + 3], state[c + 4:c + 13].reshape(3, 3).copy())
    else:
        pf._cached = None
    pf.resamplings = int(v[kern.ST_RESAMPLINGS])
