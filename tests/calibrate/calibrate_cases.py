"""The installation errors of the calibration tests and the true vehicle they make."""

from __future__ import annotations

import math

from lgvtool.sim.settings import DriveSettings

ERRORS = {"install.nav_dx_mm": 20.0, "install.nav_dy_mm": -10.0, "install.nav_yaw_deg": 0.5,
          "install.track_error_mm": 5.0, "install.nav_time_offset_ms": 30.0,
          "mcu.wheel_radius_error_left": 0.004, "mcu.wheel_radius_error_right": -0.003,
          "mcu.gyro_scale_error": 0.005, "sim.paper_scans": True}
"""The installation errors of the calibration's targets (docs/calibration.md), in the paper's
setup (the NAV200's reflector scans logged)."""

_DRIVE = DriveSettings()
LOAD = 1.0 + _DRIVE.load_fraction * _DRIVE.radius_change_at_rated_load
"""The load's compression of the encoder wheels (``drive.*``, on by default): the effective
radius a calibration finds is the wheel's radius times this."""

TRUE = {"nav_x": 1.02, "nav_y": -0.01, "nav_yaw": math.radians(0.5), "track": 0.605,
        "wheel_radius_left": 0.075 * 1.004 * LOAD, "wheel_radius_right": 0.075 * 0.997 * LOAD,
        "gyro_scale": 1.005, "nav_time_offset": 0.030}
"""The true vehicle of those drives (the default vehicle plus :data:`ERRORS`)."""
