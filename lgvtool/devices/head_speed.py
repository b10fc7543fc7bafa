"""The head velocity a host session sends to a laser navigation device as its speed input."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class HeadSpeed:
    """Latest velocity of the NAV head in the vehicle's frame: ``vx``, ``vy`` m/s forward and
    left, ``omega`` rad/s counter-clockwise, measured at host time ``at`` s (``-inf``: never)."""

    vx: float = 0.0
    vy: float = 0.0
    omega: float = 0.0
    at: float = -math.inf
