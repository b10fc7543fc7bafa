"""The Gaussian estimators' backend seam (``ekf``, ``deadreckoning``): how a replay runs them,
behind one small interface, with the numpy implementation (the reference).

An estimator holds one backend (``estimator.backend``), chosen once when it is made
(:func:`lgvtool.localize.kernel_choice.gaussian_backend`: :class:`NumpyGaussian`, or the
compiled kernels' :class:`lgvtool.localize.ekf_compiled.CompiledGaussian`) or handed in
(``backend=``). The per-observation arithmetic of the numpy path is the estimator's own
(``predict``, ``update``, ``estimate`` in :mod:`lgvtool.localize.ekf`); a backend runs the
replay loop over them (:meth:`GaussianBackend.run`): the numpy one step by step, the compiled
one with the prediction, the reflector update and the row of a chunk of observations in one
kernel call, handing back what only the estimator does (its start, NAV pose updates, the
state with odometry scales). Both give the same rows (the kernels within the last bits).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from lgvtool.localize.estimator import step_loop

if TYPE_CHECKING:
    from lgvtool.localize.ekf import GaussianParams, GaussianPoseEstimator
    from lgvtool.localize.estimator import EstimateRows, FloatArray, Observation
    from lgvtool.localize.motion import Deltas


@dataclass(frozen=True)
class GaussianModel:
    """What a Gaussian estimator's replay computes with: the motion noise (``noise_dist``,
    ``noise_lat`` m/m, ``noise_rot`` rad/rad, ``noise_rot_per_m`` rad/m) and, for one that
    corrects with reflectors, the reflector noise (``sigma_range_m`` plus
    ``sigma_range_per_m`` times the range in quadrature, ``sigma_bearing_rad``), the
    chi-square gate ``gate2`` (2 dof), whether ids associate, the ambiguity ratio, how long
    scans may find nothing before a recovery is tried (``scan_recover_s``, s; 0: never) and
    how many times a reflector update may be relinearised (``update_iterations``)."""

    noise_dist: float
    noise_lat: float
    noise_rot: float
    noise_rot_per_m: float
    sigma_range_m: float = 0.0
    sigma_range_per_m: float = 0.0
    sigma_bearing_rad: float = 0.0
    gate2: float = 0.0
    use_ids: bool = False
    ambiguity_ratio: float = 1.0
    scan_recover_s: float = 0.0
    update_iterations: int = 1


class GaussianBackend(Protocol):
    """How a Gaussian estimator's replay runs."""

    def run(self, est: GaussianPoseEstimator[GaussianParams], times: FloatArray,
            observations: Sequence[Observation | None], steps: Deltas | None, *,
            progress: Callable[[int], None] | None, cloud_period_s: float,
            cloud_size: int) -> EstimateRows:
        """:meth:`lgvtool.localize.estimator.Estimator.run` of ``est``: its rows, one per
        observation time at which it has a pose."""
        ...


class NumpyGaussian:
    """The reference: the estimator's ``predict``, ``update`` and ``estimate`` at every
    observation (:func:`lgvtool.localize.estimator.step_loop`)."""

    def run(self, est: GaussianPoseEstimator[GaussianParams], times: FloatArray,
            observations: Sequence[Observation | None], steps: Deltas | None, *,
            progress: Callable[[int], None] | None, cloud_period_s: float,
            cloud_size: int) -> EstimateRows:
        return step_loop(est, times, observations, steps, progress=progress,
                         cloud_period_s=cloud_period_s, cloud_size=cloud_size)
