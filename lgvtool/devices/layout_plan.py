"""What ``lgvtool record`` does with a laser device's stored reflector layout.

One vocabulary for every laser family (the NAV200 and the NAV350):

- ``--layer L``: the layer read, written, mapped and navigated on;
- reading (default, ``--no-read-layout`` to skip): the device's stored layout of the layer is
  read into the log (/map/reflectors and the family's metadata); nothing is written;
- ``--write-layout FILE``: the only way anything is written to a device's layout. The stored
  layout of the layer is erased and replaced by FILE's reflectors of the layer, once per
  recording (never again after a reconnect), with the layout before and after in the log;
- ``--map-at X,Y,DEG``: one mapping run of the device from where the vehicle stands (the
  NAV head's pose in the layout frame, m and degrees), while the odometry shows no motion;
  the landmarks found are logged and, with ``--map-layout FILE``, merged into a layout file.

A family that cannot do one of these refuses it in one line (:class:`~lgvtool.errors.InputError`):
the NAV200 writes its layout (a download) but does not map.
"""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.config import Reflector

__all__ = ["LayoutPlan", "MapPose"]


@dataclass(frozen=True)
class MapPose:
    """Where the NAV head stands for a mapping run: ``x``, ``y`` m and ``heading`` rad in the
    layout frame."""

    x: float
    y: float
    heading: float


@dataclass(frozen=True)
class LayoutPlan:
    """The layout options of one recording (see the module docstring)."""

    layer: int = 0
    read: bool = True
    """Read the stored layout of ``layer`` into the log."""
    write: tuple[Reflector, ...] = ()
    """Reflectors to write as the layout of ``layer`` (empty: nothing is written)."""
    write_source: str | None = None
    """The file ``write`` came from (said in messages and logged)."""
    map_at: MapPose | None = None
    """Run one mapping from this stand; None: no mapping."""
