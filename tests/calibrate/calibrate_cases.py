"""The installation errors of the calibration tests and the true vehicle they make."""

from __future__ import annotations

import math

ERRORS = {"install.nav_dx_mm": 20.0, "install.nav_dy_mm": -10.0, "install.nav_yaw_deg": 0.5,
          "install.track_error_mm": 5.0, "install.nav_time_offset_ms": 30.0,
          "mcu.wheel_radius_error_left": 0.004, "mcu.wheel_radius_error_right": -0.003,
          "mcu.gyro_scale_error": 0.005}
"""The installation errors of the calibration's targets (docs/calibration.md)."""

TRUE = {"nav_x": 1.02, "nav_y": -0.01, "nav_yaw": math.radians(0.5), "track": 0.605,
        "wheel_radius_left": 0.075 * 1.004, "wheel_radius_right": 0.075 * 0.997,
        "gyro_scale": 1.005, "nav_time_offset": 0.030}
"""The true vehicle of those drives (the default vehicle plus :data:`ERRORS`)."""
