"""The Gaussian estimators' backend on the compiled kernels (:mod:`lgvtool.localize.ekf_kernels`,
numba, the ``fast`` extra): :class:`CompiledGaussian`, the replay of
:class:`lgvtool.localize.gaussian_backend.NumpyGaussian` with the prediction, the reflector
update and the row of a chunk of observations in one kernel call (the same rows within the
last bits: :mod:`lgvtool.localize.ekf_kernels`).

Importing this module imports numba: :func:`lgvtool.localize.kernel_choice.gaussian_backend`
imports it when an estimator is made, never at start-up.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from lgvtool.localize import ekf_kernels as k
from lgvtool.localize.chunks import KIND_OTHER, chunks, scan_chunk
from lgvtool.localize.estimator import Reporter, RowRecorder, step_loop

if TYPE_CHECKING:
    from lgvtool.localize.ekf import GaussianParams, GaussianPoseEstimator
    from lgvtool.localize.estimator import EstimateRows, FloatArray, Observation
    from lgvtool.localize.gaussian_backend import GaussianModel
    from lgvtool.localize.motion import Deltas


def kernel_params(model: GaussianModel) -> FloatArray:
    """The parameter vector of the compiled loops (:data:`lgvtool.localize.ekf_kernels.N_PARAMS`
    entries) for ``model``."""
    m = model
    prm = np.zeros(k.N_PARAMS)
    prm[[k.P_NOISE_DIST, k.P_NOISE_LAT, k.P_NOISE_ROT, k.P_NOISE_ROT_PER_M]] = (
        m.noise_dist, m.noise_lat, m.noise_rot, m.noise_rot_per_m)
    prm[[k.P_SIGMA_RANGE, k.P_SIGMA_RANGE_PER_M, k.P_SIGMA_BEARING, k.P_GATE2, k.P_USE_IDS,
         k.P_RATIO2, k.P_RECOVER_S]] = (
        m.sigma_range_m, m.sigma_range_per_m, m.sigma_bearing_rad, m.gate2,
        1.0 if m.use_ids else 0.0, m.ambiguity_ratio * m.ambiguity_ratio, m.scan_recover_s)
    return prm


class CompiledGaussian:
    """The replay of a Gaussian estimator in compiled chunks
    (:class:`lgvtool.localize.gaussian_backend.GaussianBackend`); the state with the odometry
    scales, or an iterated reflector update (``update_iterations`` over 1), runs step by
    step."""

    def run(self, est: GaussianPoseEstimator[GaussianParams], times: FloatArray,
            observations: Sequence[Observation | None], steps: Deltas | None, *,
            progress: Callable[[int], None] | None, cloud_period_s: float,
            cloud_size: int) -> EstimateRows:
        if est.scaled or est.model().update_iterations > 1:
            return step_loop(est, times, observations, steps, progress=progress,
                             cloud_period_s=cloud_period_s, cloud_size=cloud_size)
        f64 = np.float64
        n = len(observations)
        ts = np.ascontiguousarray(times, dtype=f64)
        moving = steps is not None and est.uses_motion and n > 1
        dx, dy, dth, dist, rot = (np.ascontiguousarray(a, dtype=f64) for a in (
            (steps.dx, steps.dy, steps.dth, steps.dist, steps.rot) if steps is not None
            and moving else ((),) * 5))
        # the rows (no particles: counts and ESS 0), written by the kernels
        rec = RowRecorder(ts, cloud_period_s, 0)
        rec.particles[:] = 0
        rec.ess[:] = 0.0
        prm = kernel_params(est.model())
        counts = np.zeros(4, dtype=np.int64)
        rmap = est.map
        mx, my = np.ascontiguousarray(rmap.x), np.ascontiguousarray(rmap.y)
        mids = np.ascontiguousarray(rmap.ids, dtype=np.int64)
        rows = (rec.t, rec.x, rec.y, rec.heading, rec.covariance)
        kk = i0 = 0
        report = Reporter(progress)
        tl = ts.tolist()
        coasted = False
        for chunk in chunks(observations):
            c = scan_chunk(chunk, lambda o: o.ids)
            j = 0
            while j < len(chunk) and not coasted:
                i = i0 + j
                o = chunk[j]
                if est.mu is None:  # not started: predictions are no-ops until then
                    if o is not None:
                        est.update(o)
                    if est.mu is not None:
                        k._record(est.mu, est.P, tl[i], kk, *rows)
                        kk += 1
                    j += 1
                elif not est.corrects:
                    kk = k.coast(est.mu, est.P, i, dx, dy, dth, dist, rot, prm, ts, kk, *rows)
                    coasted = True
                elif c.kinds[j] == KIND_OTHER:
                    if moving and i > 0:
                        s = i - 1
                        k._predict(est.mu, est.P, float(dx[s]), float(dy[s]), float(dth[s]),
                                   float(dist[s]), float(rot[s]), prm)
                    assert o is not None
                    est.update(o)
                    k._record(est.mu, est.P, tl[i], kk, *rows)
                    kk += 1
                    j += 1
                else:
                    # the scans and times without an observation from here, in one call
                    j, kk, due = k.track(est.mu, est.P, j, i0, dx, dy, dth, dist, rot, c.kinds,
                                         c.offs, c.q, c.u, c.ranges, c.ints, mx, my, mids, prm,
                                         counts, ts, est.scan_lost, kk, *rows)
                    lost_at = chunk[j - 1]
                    if due and lost_at is not None and est.recover(lost_at):
                        # the row of that scan, as the step-by-step loop records it
                        k._record(est.mu, est.P, tl[i0 + j - 1], kk - 1, *rows)
            i0 += len(chunk)
            report.at(i0)
            if coasted:
                break
        est.count_reflectors(*(int(v) for v in counts))
        report.at(n, last=True)
        rec.k = kk
        return rec.rows()
