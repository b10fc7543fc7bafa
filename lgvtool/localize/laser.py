"""``laser``: the navigation device's own pose converted to O, the paper's comparison baseline."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Unpack

import numpy as np

from lgvtool.localize.estimator import (
    Estimate,
    Estimator,
    EstimatorContext,
    Motion,
    Observation,
)
from lgvtool.localize.observations import PoseObservation
from lgvtool.localize.params import param


@dataclass(frozen=True)
class LaserParams:
    """The laser baseline has no tuning; its covariance is nominal, for display only."""

    sigma_xy_m: float = param(0.02, "nominal position noise of the head pose, m", minimum=0.0)
    sigma_heading_rad: float = param(0.005, "nominal heading noise of the head pose, rad",
                                     minimum=0.0)
    pose_gate: bool = param(True, "leave out NAV poses that jump farther than the odometry "
                            "allows since the last accepted one (docs/reading.md)")


class LaserBaseline(Estimator[LaserParams]):
    """Each valid NAV pose converted to O with eq. 5 (corrected); motion is ignored.

    The covariance maps the nominal head noise through the lever arm ``(nav_x, nav_y)``, which
    is the paper's "error amplification in the coordinate conversion".
    """

    name = "laser"
    Params = LaserParams
    summary = "NAV pose converted to O (eq. 5): the paper's baseline"
    uses_motion = False
    uses_scans = False

    def __init__(self, params: LaserParams | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, **context)
        self._est: Estimate | None = None

    @property
    def initialized(self) -> bool:
        return self._est is not None

    def predict(self, motion: Motion) -> None:
        """The baseline holds the last reported pose."""

    def update(self, obs: Observation) -> bool:
        if not isinstance(obs, PoseObservation):
            return False
        th = obs.heading
        c, s = math.cos(th), math.sin(th)
        mx, my = self.vehicle.nav_x, self.vehicle.nav_y
        x = obs.x - mx * c + my * s
        y = obs.y - mx * s - my * c
        # d(x_O, y_O)/d(theta): the lever arm turns heading noise into position noise at O
        jx, jy = mx * s + my * c, -mx * c + my * s
        sp, sh = self.params.sigma_xy_m ** 2, self.params.sigma_heading_rad ** 2
        cov = np.array([[sp + jx * jx * sh, jx * jy * sh, jx * sh],
                        [jx * jy * sh, sp + jy * jy * sh, jy * sh],
                        [jx * sh, jy * sh, sh]])
        self._est = Estimate(x, y, th, cov)
        return True

    def estimate(self) -> Estimate | None:
        return self._est
