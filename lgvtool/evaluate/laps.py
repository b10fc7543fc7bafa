"""Rotation (lap) segmentation of a circle drive.

The angle of a trajectory about the circle centre is unwrapped and measured from its first
sample, in the direction the vehicle turns. Rotation k (k = 1, 2, ...) holds the samples whose
swept angle lies in ``[2 pi (k - 1), 2 pi k)``. The swept angle is taken as a running maximum,
so noise that briefly turns it back never starts a rotation twice. Only complete rotations are
scored; what is left after the last one is a partial rotation, counted but not scored.

Rotations are found once per log, on one trajectory (the lap source), and their time
boundaries are then applied to every estimator, so that row k of Table 1 is the same stretch
of driving for all of them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.circle import Circle

PARTIAL_MIN_ANGLE = float(np.deg2rad(1.0))
"""Angular tolerance at the end of a drive, rad: a remainder smaller than this after the last
complete rotation is not a partial rotation, and a last rotation short of a full turn by less
than this counts as complete."""


STANDSTILL_ANGLE = 1e-6
"""Swept angle below which the vehicle has not started turning yet, rad: samples before the
last one below it (a standstill at the start) belong to no rotation."""


@dataclass(frozen=True)
class Laps:
    """Complete rotations of a drive as time intervals.

    ``boundaries`` holds ``complete + 1`` times (s): rotation k spans
    ``[boundaries[k-1], boundaries[k])``.
    """

    boundaries: tuple[float, ...] = ()
    partial: int = 0
    """Partial rotations left out (0 or 1 per drive)."""
    partial_fraction: float = 0.0
    """Fraction of a rotation that the partial one covers, dimensionless."""
    direction: int = 1
    """+1 counter-clockwise, -1 clockwise."""
    swept: float = 0.0
    """Total angle swept about the centre, rad (non-negative)."""
    source: str = ""
    """Name of the trajectory the rotations were found on."""

    @property
    def complete(self) -> int:
        """Number of complete rotations."""
        return max(len(self.boundaries) - 1, 0)

    def index(self, t: ArrayLike) -> NDArray[np.int64]:
        """Rotation number (1-based) of each time in ``t`` (s); 0 outside every rotation."""
        ta = np.asarray(t, dtype=float)
        if self.complete == 0:
            return np.zeros(ta.shape, dtype=np.int64)
        b = np.asarray(self.boundaries)
        k = np.searchsorted(b, ta, side="right")
        k[(ta < b[0]) | (ta >= b[-1])] = 0
        return k.astype(np.int64)


def swept_angle(
    x: ArrayLike, y: ArrayLike, centre: tuple[float, float]
) -> tuple[NDArray[np.float64], int]:
    """Angle swept about ``centre`` since the first sample, rad, as a running maximum in the
    turning direction, and that direction (+1 counter-clockwise, -1 clockwise)."""
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    phi = np.unwrap(np.arctan2(ya - centre[1], xa - centre[0]))
    rel = phi - phi[0]
    direction = 1 if rel[-1] >= 0 else -1
    return np.maximum.accumulate(direction * rel), direction


def segment_laps(
    t: ArrayLike, x: ArrayLike, y: ArrayLike, circle: Circle, *, source: str = ""
) -> Laps:
    """Complete rotations of the trajectory (t in s, x and y in m) about ``circle``'s centre.

    A rotation boundary is placed by linear interpolation of time at the swept angle
    ``2 pi k``, so boundaries do not depend on the sample rate.
    """
    ta = np.asarray(t, dtype=float)
    if ta.size < 2:
        return Laps(source=source)
    swept, direction = swept_angle(x, y, (circle.cx, circle.cy))
    total = float(swept[-1])
    # A drive that ends within PARTIAL_MIN_ANGLE of a full turn completes that turn.
    complete = int(np.floor((total + PARTIAL_MIN_ANGLE) / (2.0 * np.pi)))
    remainder = total - complete * 2.0 * np.pi
    boundaries: list[float] = []
    if complete > 0:
        targets = 2.0 * np.pi * np.arange(complete + 1)
        # swept is non-decreasing; np.interp needs strictly increasing x, so take the first
        # time each value is reached.
        uniq, first = np.unique(swept, return_index=True)
        boundaries = [float(v) for v in np.interp(targets, uniq, ta[first])]
        # The first rotation starts when the vehicle starts turning (not during a standstill).
        boundaries[0] = float(ta[np.searchsorted(swept, STANDSTILL_ANGLE, side="right") - 1])
        if targets[-1] > total:  # completed within the tolerance: ends when turning stops
            stop = int(np.searchsorted(swept, total - STANDSTILL_ANGLE, side="left"))
            boundaries[-1] = float(np.nextafter(ta[min(stop, ta.size - 1)], np.inf))
    partial = 1 if remainder >= PARTIAL_MIN_ANGLE else 0
    return Laps(
        boundaries=tuple(boundaries),
        partial=partial,
        partial_fraction=remainder / (2.0 * np.pi) if partial else 0.0,
        direction=direction,
        swept=total,
        source=source,
    )
