"""The vehicle's installation corrections applied to a log's data before the estimators run.

A vehicle configuration may say that the NAV head is turned on its mount (``nav_yaw``, rad),
that its data reaches the host late (``nav_time_offset``, s), that the gyro has a scale factor
and a bias (``gyro_scale``, ``gyro_bias`` rad/s) and that generic odometry travels and turns by
a factor of what it reports (``odom_scale_v``, ``odom_scale_w``) and drifts to one side by
``odom_yaw_per_m`` rad per metre it reports. :func:`apply_installation`
turns the logged data into what an ideal installation would have logged:

- NAV poses and scans: their times minus ``nav_time_offset`` (poses also minus
  ``nav_pose_age``, the device's own reporting delay); the head's reported heading minus
  ``nav_yaw`` (the heading of the vehicle's axes at the head) and every bearing plus ``nav_yaw``
  (bearings from the vehicle's x axis), so that every estimator needs only ``nav_x``, ``nav_y``;
- MCU gyro rates: ``(rate - gyro_bias) / gyro_scale``;
- generic odometry: ``v * odom_scale_v``, ``omega * odom_scale_w + v * odom_yaw_per_m``.

With every value at its default the data is returned as it is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.config import Vehicle
from lgvtool.localize.logdata import LazyScans, LogData, ScanViewColumns
from lgvtool.localize.observations import RawScan, ScanBatch


def is_nominal(vehicle: Vehicle) -> bool:
    """True when the vehicle has no installation correction to apply."""
    return (vehicle.nav_yaw == 0.0 and vehicle.nav_time_offset == 0.0
            and vehicle.nav_pose_age == 0.0
            and vehicle.gyro_scale == 1.0 and vehicle.gyro_bias == 0.0
            and vehicle.odom_scale_v == 1.0 and vehicle.odom_scale_w == 1.0
            and vehicle.odom_yaw_per_m == 0.0)


class CorrectedScans(LazyScans):
    """Scans of a :class:`LazyScans` with their times moved by ``-offset`` s and their bearings
    turned by ``yaw`` rad, decoded (and corrected) when first used."""

    def __init__(self, scans: LazyScans, offset: float, yaw: float) -> None:
        self._inner = scans
        self._offset = offset
        self._yaw = yaw
        self._n = len(scans)
        self._all: tuple[ScanBatch, NDArray[np.int64]] | None = None
        self.source = scans.source
        self.received_ns = scans.received_ns - round(offset * 1e9)
        self.received = scans.received - offset

    def decoded(self) -> tuple[ScanBatch, NDArray[np.int64]]:
        if self._all is None:
            b, offsets = self._inner.decoded()
            t, bearings = b.t - self._offset, b.bearings + self._yaw
            t.setflags(write=False)
            bearings.setflags(write=False)
            self._all = (ScanBatch(t, b.period, b.counts, b.ranges, bearings, b.times, b.ids),
                         offsets)
        return self._all

    def decoded_columns(self) -> ScanViewColumns | None:
        """The scans as logged (the view draws what the NAV reported)."""
        return self._inner.decoded_columns()


def correct_scans(scans: Sequence[RawScan], offset: float, yaw: float) -> Sequence[RawScan]:
    """``scans`` with times minus ``offset`` (s) and bearings plus ``yaw`` (rad)."""
    if offset == 0.0 and yaw == 0.0:
        return scans
    if isinstance(scans, LazyScans):
        return CorrectedScans(scans, offset, yaw)
    return [RawScan(s.t - offset, s.period, s.ranges, s.bearings + yaw, s.times, s.ids)
            for s in scans]


def apply_installation(data: LogData, vehicle: Vehicle) -> LogData:
    """``data`` as an ideal installation of ``vehicle`` would have logged it (module docstring);
    ``data`` itself is not changed."""
    if is_nominal(vehicle):
        return data
    off, yaw = vehicle.nav_time_offset, vehicle.nav_yaw
    mcu = data.mcu
    if mcu is not None and (vehicle.gyro_scale != 1.0 or vehicle.gyro_bias != 0.0):
        mcu = dict(mcu, gyro_rate=(np.asarray(mcu["gyro_rate"], dtype=np.float64)
                                   - vehicle.gyro_bias) / vehicle.gyro_scale)
    twist = data.twist
    if twist is not None and (vehicle.odom_scale_v != 1.0 or vehicle.odom_scale_w != 1.0
                              or vehicle.odom_yaw_per_m != 0.0):
        twist = dict(twist, v=twist["v"] * vehicle.odom_scale_v,
                     omega=(twist["omega"] * vehicle.odom_scale_w
                            + twist["v"] * vehicle.odom_yaw_per_m))
    nav = data.nav
    age = off + vehicle.nav_pose_age
    if nav is not None and (age != 0.0 or yaw != 0.0):
        heading = np.asarray(nav["heading"], dtype=np.float64) - yaw
        nav = dict(nav, t=nav["t"] - age,
                   heading=wrap_angle(heading))
    return replace(data, mcu=mcu, twist=twist, nav=nav, scans=correct_scans(data.scans, off, yaw))
