"""Parameters shared by every estimator that integrates motion, and the motion noise model.

Motion noise is zero-mean Gaussian in the body frame of the earlier pose, with standard
deviations that grow linearly with the path length ``dist`` (m) and the absolute rotation
``rot`` (rad) of the step:

- along track: ``noise_dist * dist``
- across track: ``noise_lat * dist``
- heading: ``noise_rot * rot + noise_rot_per_m * dist``
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.motion import FUSIONS, STEP_FORMS, MotionSettings
from lgvtool.localize.params import param

#: a motion's size: one (float) or one per motion (an array)
MotionSize = TypeVar("MotionSize", float, NDArray[np.float64])


@dataclass(frozen=True)
class MotionParams:
    """How motion is read and how uncertain it is (see :mod:`lgvtool.localize.motion`)."""

    fusion: str = param("gyro", "heading source: gyro (encoder distance + gyro heading), "
                        "encoders, or blend", choices=FUSIONS)
    gyro_weight: float = param(0.98, "weight of the gyro in the blend fusion, 0..1",
                               minimum=0.0, maximum=1.0)
    max_gyro_gap_s: float = param(0.5, "longer gaps between MCU frames take their heading "
                                  "change from the encoders, s", minimum=0.0)
    step_form: str = param("arc", "step integration: arc (exact at constant curvature) or "
                           "paper (eq. 9 as printed, heading after the step)", choices=STEP_FORMS)
    noise_dist: float = param(0.02, "along-track motion noise per metre travelled, m/m",
                              minimum=0.0)
    noise_lat: float = param(0.005, "across-track motion noise per metre travelled, m/m",
                             minimum=0.0)
    noise_rot: float = param(0.02, "heading noise per radian turned, rad/rad", minimum=0.0)
    noise_rot_per_m: float = param(0.002, "heading noise per metre travelled, rad/m",
                                   minimum=0.0)

    def motion_settings(self) -> MotionSettings:
        """The settings of the odometry track these parameters ask for."""
        return MotionSettings(self.fusion, self.gyro_weight, self.max_gyro_gap_s, self.step_form)

    def noise_sigmas(self, dist: MotionSize, rot: MotionSize
                     ) -> tuple[MotionSize, MotionSize, MotionSize]:
        """Body-frame standard deviations (along m, across m, heading rad) of one motion of
        length ``dist`` (m) and rotation ``rot`` (rad), or of each of arrays of them."""
        return (self.noise_dist * dist, self.noise_lat * dist,
                self.noise_rot * rot + self.noise_rot_per_m * dist)


def perturbed_motion(rng: np.random.Generator, n: int, dx: float, dy: float, dth: float,
                     sigmas: tuple[float, float, float]
                     ) -> tuple[NDArray[np.float64] | float, NDArray[np.float64] | float,
                                NDArray[np.float64] | float]:
    """``n`` noisy copies of a body-frame motion; returns the scalars when all sigmas are 0."""
    sa, sl, st = sigmas
    if sa == 0.0 and sl == 0.0 and st == 0.0:
        return dx, dy, dth
    z = rng.standard_normal((3, n))
    return dx + sa * z[0], dy + sl * z[1], dth + st * z[2]
