"""``pf``'s replay loop with its reflector scans tracked by the backend's fused replay
(:meth:`ParticleFilter.run`; :meth:`lgvtool.localize.particle_backend.PfBackend.scan_tracker`).

The filter's ``predict``, ``update`` and ``estimate`` cost about 40 us of Python per
observation around kernels of about 10 us. Here the observations go a chunk at a time
(:mod:`lgvtool.localize.chunks`) to the tracker (the compiled backend's: one call of
:func:`lgvtool.localize.pf_kernels.pf_track`) that moves, weighs, resamples and records the
estimate of each in turn, drawing the same random numbers in the same order. The tracker hands
an observation back to the filter's own step when that step needs what only the filter does:
an observation other than a reflector scan, the start, a uniform start set still shrinking,
or a resampling that recovery may use to re-draw particles (about 1 in 500 resamplings on the
paper's drive). It returns too whenever a particle cloud is due. The rows, clouds and random
stream are those of the step-by-step loop (``tests/localize/test_pf_kernels.py``). A backend
without a fused replay (the numpy reference) runs the step-by-step loop.
"""

from __future__ import annotations

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
from lgvtool.localize.particle_backend import TRACK_CLOUD, TRACK_RESAMPLE, ScanTracker

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas
    from lgvtool.localize.particle_filter import ParticleFilter

FloatArray = NDArray[np.float64]


def trackable(pf: ParticleFilter) -> bool:
    """Whether ``pf``'s settings are those a fused replay follows: the prior proposal without
    odometry scales, log weights, low-variance resampling, no fix-disagreement reset, and a
    reflector map."""
    p = pf.params
    return (p.proposal == "prior" and not p.odometry_scales and p.log_weights
            and p.resampler == "low-variance"
            and not (p.recovery and p.fix_reset_probability > 0.0) and len(pf.map) > 0)


def tracker(pf: ParticleFilter, steps: Deltas | None, n: int) -> ScanTracker | None:
    """The fused replay of ``pf``'s backend for a run of ``n`` observations with the motions
    ``steps``, or None (the settings or the backend have none: the filter's own steps)."""
    if not trackable(pf):
        return None
    moving = steps is not None and n > 1
    f64 = np.float64
    if moving and steps is not None:
        motion = tuple(np.ascontiguousarray(a, dtype=f64) for a in (steps.dx, steps.dy, steps.dth))
        noise = tuple(np.broadcast_to(a, steps.dist.shape).astype(f64)
                      for a in pf.params.noise_sigmas(steps.dist, steps.rot))
    else:
        motion = noise = (np.zeros(0),) * 3
    return pf.backend.scan_tracker(pf.track_settings(), pf.map, moving,
                                   (motion[0], motion[1], motion[2]),
                                   (noise[0], noise[1], noise[2]))


def track(pf: ParticleFilter, scans: ScanTracker, times: FloatArray,
          observations: Sequence[Observation | None], steps: Deltas | None, *,
          progress: Callable[[int], None] | None, cloud_period_s: float,
          cloud_size: int) -> EstimateRows:
    """:meth:`lgvtool.localize.estimator.Estimator.run` of ``pf``, its observations a chunk at
    a time through ``scans`` (:func:`tracker`)."""
    n = len(observations)
    moves = Moves(steps) if steps is not None and n > 1 else None
    rec = RowRecorder(times, cloud_period_s, cloud_size)
    i0 = 0
    report = Reporter(progress)
    for chunk in chunks(observations):
        c = scan_chunk(chunk, lambda o: o.map_index(pf.map))
        j = 0
        while j < len(chunk):
            o = chunk[j]
            if c.kinds[j] == KIND_OTHER or not pf.tracking:
                pf.step(i0 + j, o, moves, rec)
                j += 1
                continue
            state = pf.tracking_state()
            status, j, particles = scans.track(pf.rng, pf.particle_arrays(), state, c, j, i0,
                                               rec)
            pf.resume(particles, state)
            if status == TRACK_RESAMPLE:
                # moved and weighed: the filter resamples (recovery may re-draw particles),
                # then the row as the step records it
                o = chunk[j]
                assert isinstance(o, ScanObservation)
                pf.after_weighing("scan", o, state.per_obs)
                e = pf.estimate()
                assert e is not None
                rec.add(i0 + j, e)
                rec.maybe_cloud(i0 + j, pf)
                j += 1
            elif status == TRACK_CLOUD:
                rec.maybe_cloud(i0 + j - 1, pf)
        i0 += len(chunk)
        report.at(i0)
    report.at(n, last=True)
    return rec.rows()
