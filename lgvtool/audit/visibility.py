"""Which layout reflectors the NAV head could see from a pose: in range, in its field of view,
and not hidden behind a nearer reflector (SI units: m, rad).

Pure: values in, values out. Poses are those of the laser head (the NAV's own position, not the
vehicle's rotation centre O: :func:`lgvtool.localize.geometry.o_to_nav` gives it from O's pose).

A reflector is a cylinder of radius ``a`` m; seen from the head at centre range ``r`` m it covers
the bearings within ``asin(a / r)`` rad of its centre's. A farther reflector whose centre bearing
falls inside a nearer one's extent is hidden: the head's pulses at that bearing return from the
nearer cylinder. A reflector is in range when its centre range lies in
``[range_min_m, range_max_m]``, and in view when its bearing relative to the head's heading lies
within half the field of view (the NAV200 and the NAV350 scan all round: 360 deg).

Poses are processed in blocks (:data:`PAIR_BUDGET` pose-reflector-reflector elements each), so
the memory stays bounded whatever the length of the drive.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.angles import wrap_angle
from lgvtool.config import Reflector
from lgvtool.declared import make, setting
from lgvtool.errors import ConfigError
from lgvtool.suggest import unknown_tail

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

PAIR_BUDGET = 500_000
"""Most pose x reflector x reflector elements of one block of the occlusion test (4 MB of
float64 in each of its two buffers; larger blocks are no faster)."""


@dataclass(frozen=True)
class DeviceView:
    """What a NAV head can see and how well it measures: the limits of its sightings and the
    measurement noise its position fit works with (the geometry's dilution of precision)."""

    range_min_m: float = setting(
        0.5, "Closest reflector (centre range) the head measures, m.", unit="m", minimum=0.0)
    range_max_m: float = setting(
        70.0, "Farthest reflector (centre range) the head measures, m.", unit="m",
        minimum=0.0, min_open=True)
    field_of_view_deg: float = setting(
        360.0, "Angular field of view, centred on the head's heading, deg.", unit="deg",
        minimum=0.0, min_open=True, maximum=360.0)
    sigma_range_m: float = setting(
        0.012, "Standard deviation of one reflector's range, m (weights the GDOP).", unit="m",
        minimum=0.0, min_open=True)
    sigma_bearing_deg: float = setting(
        0.04, "Standard deviation of one reflector's bearing, deg (weights the GDOP).",
        unit="deg", minimum=0.0, min_open=True)
    min_reflectors: int = setting(
        3, "Fewest reflectors the device needs for a position.", unit="", minimum=1, maximum=64)

    @property
    def sigma_bearing_rad(self) -> float:
        """:attr:`sigma_bearing_deg` in rad."""
        return math.radians(self.sigma_bearing_deg)

    @classmethod
    def for_family(cls, family: str, overrides: Mapping[str, object] | None = None
                   ) -> DeviceView:
        """The view of a device family (``"nav200"`` or ``"nav350"``) from its data sheet, with
        ``overrides`` (``{field: value}``, each checked by its declaration) applied.

        NAV350: 0.5 m to 70 m (operating instructions 8013889, section 3.10.3: the measuring
        area starts 0.5 m in front of the optics; the beam table and the reflector positioning
        range end at 70 m). NAV200: 1.2 m to 28.5 m (its product information). Both scan all
        round (360 deg) and need 3 reflectors for a position. The noise figures are those the
        simulator's device fit assumes (``nav.solver_sigma_range_mm``,
        ``nav.solver_sigma_bearing_deg``: 12 mm, 0.04 deg); the data sheets give a position
        accuracy, not a per-reflector noise.

        :raises ConfigError: (exit 2) for an unknown family or a bad override.
        """
        base = _FAMILIES.get(family)
        if base is None:
            raise ConfigError(f"unknown device family {family!r}"
                              + unknown_tail(family, sorted(_FAMILIES)))
        return make(cls, "view", dict(overrides or {}), base)


_FAMILIES: dict[str, DeviceView] = {
    "nav350": DeviceView(range_min_m=0.5, range_max_m=70.0),
    "nav200": DeviceView(range_min_m=1.2, range_max_m=28.5),
}


def reflector_arrays(reflectors: Sequence[Reflector]) -> tuple[FloatArray, FloatArray,
                                                               FloatArray]:
    """The layout as columns: x (m), y (m), radius (m), in the order given."""
    x = np.fromiter((r.x for r in reflectors), np.float64, len(reflectors))
    y = np.fromiter((r.y for r in reflectors), np.float64, len(reflectors))
    a = np.fromiter((r.radius for r in reflectors), np.float64, len(reflectors))
    return x, y, a


def pose_blocks(n_poses: int, n_reflectors: int, budget: int | None = None
                ) -> Iterator[slice]:
    """Slices of ``range(n_poses)`` whose pose x reflector^2 size stays within ``budget``
    (default :data:`PAIR_BUDGET`)."""
    size = max(1, (PAIR_BUDGET if budget is None else budget)
               // max(1, n_reflectors * n_reflectors))
    for start in range(0, n_poses, size):
        yield slice(start, min(n_poses, start + size))


def expected_visibility(head_x: ArrayLike, head_y: ArrayLike, head_heading: ArrayLike,
                        reflectors: Sequence[Reflector], view: DeviceView) -> BoolArray:
    """Which ``reflectors`` the head could see at each pose: bool ``(n_poses, n_reflectors)``.

    ``head_x``, ``head_y`` (m) and ``head_heading`` (rad) are the head's poses in the map frame
    (1-D, same length). A reflector is visible when its centre range is within
    ``[view.range_min_m, view.range_max_m]``, its bearing within the field of view, and no
    nearer reflector's angular extent (``asin(radius / range)``, any reflector of the layout,
    in range or not) covers its bearing. Columns follow the order of ``reflectors``.
    """
    hx = np.atleast_1d(np.asarray(head_x, dtype=np.float64))
    hy = np.atleast_1d(np.asarray(head_y, dtype=np.float64))
    hth = np.atleast_1d(np.asarray(head_heading, dtype=np.float64))
    if not hx.shape == hy.shape == hth.shape or hx.ndim != 1:
        raise ValueError("head_x, head_y and head_heading must be 1-D of one length")
    n, m = len(hx), len(reflectors)
    out = np.zeros((n, m), dtype=np.bool_)
    if n == 0 or m == 0:
        return out
    rx, ry, ra = reflector_arrays(reflectors)
    half_fov = math.radians(view.field_of_view_deg) / 2.0
    for rows in pose_blocks(n, m):
        out[rows] = _visible_block(hx[rows], hy[rows], hth[rows], rx, ry, ra, view, half_fov)
    return out


def _visible_block(hx: FloatArray, hy: FloatArray, hth: FloatArray, rx: FloatArray,
                   ry: FloatArray, ra: FloatArray, view: DeviceView, half_fov: float
                   ) -> BoolArray:
    """:func:`expected_visibility` of one block of poses (p, m)."""
    dx = rx[None, :] - hx[:, None]
    dy = ry[None, :] - hy[:, None]
    r = np.hypot(dx, dy)
    seen = (r >= view.range_min_m) & (r <= view.range_max_m)
    if half_fov < math.pi:
        seen &= np.abs(wrap_angle(np.arctan2(dy, dx) - hth[:, None])) <= half_fov
    # unit vectors to the reflectors, and the sine of each one's angular half extent as an
    # occluder (1 or more: the head is inside the cylinder, which covers a half circle)
    safe = np.maximum(r, 1e-12)
    ux, uy = dx / safe, dy / safe
    sin_half = ra[None, :] / safe
    # pairs (pose, occluder k, target j): j's bearing within k's extent, i.e. the angle
    # between them at most asin(min(1, sin_half_k)) (at most 90 deg: dot >= 0, and
    # |sin(angle)| = |u_k x u_j| <= sin_half_k), and k nearer than j; computed in place (two
    # pair-sized buffers: the block's memory and time are those of a few passes over them)
    uxk, uyk, uxj, uyj = ux[:, :, None], uy[:, :, None], ux[:, None, :], uy[:, None, :]
    buf = np.multiply(uxk, uyj)
    tmp = np.multiply(uyk, uxj)
    np.subtract(buf, tmp, out=buf)
    np.abs(buf, out=buf)
    covers = buf <= sin_half[:, :, None]
    np.multiply(uxk, uxj, out=buf)
    np.multiply(uyk, uyj, out=tmp)
    buf += tmp
    covers &= buf >= 0.0
    covers &= r[:, :, None] < r[:, None, :]
    hidden = covers.any(axis=1)
    return seen & ~hidden
