"""The head velocity a host session sends to a laser navigation device as its speed input."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.config import Vehicle
    from lgvtool.devices.mcu.mcu_session import Motion

__all__ = ["HeadSpeed", "head_velocity"]


@dataclass(frozen=True)
class HeadSpeed:
    """Latest velocity of the NAV head in the vehicle's frame: ``vx``, ``vy`` m/s forward and
    left, ``omega`` rad/s counter-clockwise, measured at host time ``at`` s (``-inf``: never)."""

    vx: float = 0.0
    vy: float = 0.0
    omega: float = 0.0
    at: float = -math.inf


def head_velocity(motion: Motion, vehicle: Vehicle) -> tuple[float, float]:
    """Velocity (vx, vy) of the NAV head in the vehicle frame, m/s, from the motion of O
    (``motion.v`` m/s, ``motion.omega`` rad/s).

    The head sits at (nav_x, nav_y) from O, so it moves with v + omega x d:
    ``vx = v - omega * nav_y``, ``vy = omega * nav_x``.
    """
    return (motion.v - motion.omega * vehicle.nav_y, motion.omega * vehicle.nav_x)
