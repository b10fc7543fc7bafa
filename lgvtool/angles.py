"""Angles: the one wrap convention of lgvtool, and the mean of angles (rad).

Every angle lgvtool computes is wrapped to the half-open interval (-pi, pi]: -pi itself maps
to +pi. Scalars and arrays follow the same rule (:func:`wrap_angle` for arrays,
:func:`wrap_scalar` for hot scalar paths), so a pose written by one stage and read by another
never flips sign at the seam.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["TWO_PI", "circular_mean", "wrap_angle", "wrap_scalar"]

TWO_PI = 2.0 * math.pi


def wrap_angle(a: ArrayLike) -> NDArray[np.float64]:
    """Wrap angles to (-pi, pi], rad."""
    w = np.remainder(np.asarray(a, dtype=np.float64) + math.pi, TWO_PI) - math.pi
    return np.where(w <= -math.pi, w + TWO_PI, w)


def wrap_scalar(a: float) -> float:
    """Wrap one angle to (-pi, pi], rad (pure Python, for hot scalar paths)."""
    w = math.fmod(a + math.pi, TWO_PI)
    if w < 0.0:
        w += TWO_PI
    w -= math.pi
    return w + TWO_PI if w <= -math.pi else w


def circular_mean(angles: NDArray[np.float64], weights: NDArray[np.float64] | None = None) -> float:
    """Weighted mean of angles via the mean unit vector, rad in (-pi, pi]."""
    if weights is None:
        s, c = float(np.sin(angles).sum()), float(np.cos(angles).sum())
    else:
        s, c = float(weights @ np.sin(angles)), float(weights @ np.cos(angles))
    return wrap_scalar(math.atan2(s, c))
