"""The quantities ``lgvtool calibrate`` estimates: names, units, which motion data they need,
when a drive observes them, and how they are shown."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Quantity:
    """One calibrated quantity, a field of :class:`lgvtool.config.Vehicle` (SI units)."""

    name: str
    """The ``vehicle.*`` key it is written to."""
    unit: str
    """Unit shown in tables and JSON (``display`` converts the SI value to it)."""
    display: float
    """Factor from the SI value to the shown unit."""
    motion: str
    """``mcu``, ``twist`` (generic odometry) or ``any``: the motion data it belongs to."""
    max_sigma: float
    """The drive observes the quantity when its 1-sigma (SI) is at most this."""
    prior_sigma: float
    """Standard deviation (SI) of the weak prior around the starting value that keeps the
    problem solvable when a drive does not observe the quantity."""
    needs: str
    """What a drive must contain to observe it (shown when it does not)."""


QUANTITIES: dict[str, Quantity] = {q.name: q for q in (
    Quantity("nav_x", "mm", 1e3, "any", 0.02, 1.0,
             "turning, and changes of speed or of turn rate (a straight line cannot tell it "
             "from a pose shift, one steady circle from the time offset and the yaw)"),
    Quantity("nav_y", "mm", 1e3, "any", 0.02, 1.0,
             "turning, and changes of speed or of turn rate (a straight line cannot tell it "
             "from a pose shift, one steady circle from the time offset and the yaw)"),
    Quantity("nav_yaw", "deg", 180.0 / math.pi, "any", math.radians(0.5), math.radians(20.0),
             "reflectors in several directions, travel, and changes of turn rate"),
    Quantity("wheel_radius_left", "mm", 1e3, "mcu", 0.075 * 0.005, 0.01,
             "travel at two curvatures at least (straights and turns)"),
    Quantity("wheel_radius_right", "mm", 1e3, "mcu", 0.075 * 0.005, 0.01,
             "travel at two curvatures at least (straights and turns)"),
    Quantity("track", "mm", 1e3, "mcu", 0.02, 0.3,
             "travel at two curvatures at least (straights and turns)"),
    Quantity("gyro_scale", "", 1.0, "mcu", 0.005, 0.2, "turning"),
    Quantity("gyro_bias", "deg/s", 180.0 / math.pi, "mcu", math.radians(0.05),
             math.radians(5.0), "standing still or driving straight"),
    Quantity("nav_time_offset", "ms", 1e3, "any", 0.02, 1.0,
             "driving at changing speeds (or turning at changing rates)"),
    Quantity("nav_pose_age", "ms", 1e3, "any", 0.02, 1.0,
             "NAV poses beside reflector scans, and turning"),
    Quantity("odom_scale_v", "", 1.0, "twist", 0.05, 1.0, "travel"),
    Quantity("odom_scale_w", "", 1.0, "twist", 0.05, 1.0, "turning"),
    Quantity("odom_yaw_per_m", "deg/m", 180.0 / math.pi, "twist", math.radians(2.0),
             math.radians(30.0), "travel, with straight stretches beside the turns"),
)}
"""Every quantity by name, in the order of the tables."""

GLOBAL = ("nav_x", "nav_y", "nav_yaw", "wheel_radius_left", "wheel_radius_right", "track",
          "gyro_scale", "nav_time_offset", "odom_scale_v", "odom_scale_w", "odom_yaw_per_m")
"""Quantities that are one unknown of the least squares each (``gyro_bias`` is one unknown per
stretch of each log, ``nav_pose_age`` is fitted after the drive, :mod:`lgvtool.calibrate.solve`)."""


def default_names(motion: str, has_scans: bool, has_poses: bool) -> list[str]:
    """The quantities estimated by default for logs with ``motion`` (``mcu`` or ``twist``)
    data: every one of that motion, plus the NAV pose age when poses stand beside scans."""
    out = [q.name for q in QUANTITIES.values() if q.motion in ("any", motion)]
    if not (has_scans and has_poses):
        out.remove("nav_pose_age")
    return out
