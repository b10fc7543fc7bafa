"""``deadreckoning``: odometry alone from a first pose.

The first pose is the caller's initial pose (e.g. ground truth) when given, else the first
valid NAV pose converted to O (or, with ``init = landmarks``, the first scan that fixes the pose:
two reflector ids that agree, or three reflectors matched on the layout by their geometry,
:func:`lgvtool.localize.fix.scan_fix`). After that, observations are ignored and the covariance
only grows.
"""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.localize.ekf import GaussianInitParams, GaussianPoseEstimator
from lgvtool.localize.estimator import Observation
from lgvtool.localize.noise import MotionParams
from lgvtool.localize.params import param


@dataclass(frozen=True)
class DeadReckoningParams(MotionParams, GaussianInitParams):
    """Parameters of dead reckoning."""

    use_ids: bool = param(True, "a landmark fix may use reflector ids")


class DeadReckoning(GaussianPoseEstimator[DeadReckoningParams]):
    """Integrates the odometry from a first pose; never corrected."""

    name = "deadreckoning"
    Params = DeadReckoningParams
    summary = "odometry + gyro from the first NAV pose (or a given initial pose)"
    corrects = False

    def update(self, obs: Observation) -> bool:
        if self.mu is not None:
            return False
        return self._try_start(obs)
