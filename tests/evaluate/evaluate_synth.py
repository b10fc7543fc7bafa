"""Synthetic circle drives for the evaluation tests: DataFrames t (s), x (m), y (m),
heading (rad)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

H = 1.2
"""Distance from O to the drive wheel, m."""
DELTA = math.radians(60.0)
"""Steering angle, rad."""
R = H / math.tan(DELTA)
"""Kinematic radius, m."""
CENTRE = (10.0, 8.0)
SPEED = 0.18
"""Speed of O, m/s."""
PERIOD = 2.0 * math.pi * R / SPEED
"""Time of one rotation, s."""
T0 = 1_700_000_000.0


def circle_drive(
    *,
    rotations: float = 3.5,
    dt: float = 0.1,
    bias: float = 0.0,
    sd: float = 0.0,
    seed: int = 0,
    radius: float = R,
    centre: tuple[float, float] = CENTRE,
    direction: int = 1,
    phase: float = 0.0,
) -> pd.DataFrame:
    """A drive around the circle with a radial ``bias`` (m) and Gaussian radial noise ``sd``
    (m)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, rotations * PERIOD, dt)
    a = phase + direction * SPEED / radius * t
    r = radius + bias + rng.normal(0.0, sd, t.size) if sd > 0 else radius + bias + 0 * t
    return pd.DataFrame({
        "t": T0 + t,
        "x": centre[0] + r * np.cos(a),
        "y": centre[1] + r * np.sin(a),
        "heading": a + direction * math.pi / 2,
    })
