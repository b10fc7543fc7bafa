"""NAV350 pose data as the log's ``lgvtool.NavPose`` and ``lgvtool.ReflectorScan`` messages.

Both times are logged: ``timestamp`` of the pose is the host time the reply was received (as
for the NAV200), ``device_time_ms`` the NAV350 tick, and ``device_stamp`` the host time of that
tick by the online clock estimate (absent until the estimate exists). A scan's ``timestamp`` is
the host time of its start tick (DIST1 ``timestampStart``, else the first landmark's tick) and
each reflector's ``time_in_scan`` comes from its own tick, so the de-skew uses the device's
landmark timestamps. Angles: the NAV350's mdeg, counter-clockwise, turned into rad in
(-pi, pi].
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from lgvtool.devices.nav350.telegrams import PoseData
from lgvtool.timestamps import stamp

__all__ = ["NO_POSITION", "SCAN_PERIOD", "pose_message", "scan_message"]

#: ``quality`` of a NAV350 pose without a valid position (the NAV350 has no quality byte:
#: 0 otherwise, its own figures are ``mean_dev``, ``nav_mode`` and ``reflectors_used``).
NO_POSITION = 0xFF
#: Head revolution period the NAV350 runs at (8 Hz), s.
SCAN_PERIOD = 0.125


def _angle(mdeg: int) -> float:
    a = math.radians(mdeg / 1000.0)
    return math.atan2(math.sin(a), math.cos(a))


def pose_message(data: PoseData, received_ns: int,
                 host_ns_of_tick: Callable[[int], int | None]) -> dict[str, Any] | None:
    """The ``lgvtool.NavPose`` of a pose-data reply (None when it has neither pose nor pose
    information). ``host_ns_of_tick`` maps a device tick to host ns (None: no estimate yet)."""
    if data.pose is None and data.info is None:
        return None
    info = data.info
    valid = data.pose is not None and data.error_code == 0
    x, y, phi = data.pose if data.pose is not None else (0, 0, 0)
    msg: dict[str, Any] = {
        "timestamp": stamp(received_ns), "x": x / 1000.0, "y": y / 1000.0,
        "heading": _angle(phi), "quality": 0 if valid else NO_POSITION,
        "reflectors_used": 0 if info is None else info.used_reflectors, "valid": valid,
        "error_code": data.error_code,
    }
    if info is not None:
        msg.update(device_time_ms=info.timestamp_ms, mean_dev=info.mean_dev,
                   nav_mode=info.nav_mode, info_state=info.info_state,
                   output_mode=info.output_mode)
        ns = host_ns_of_tick(info.timestamp_ms)
        if ns is not None:
            msg["device_stamp"] = stamp(ns)
    return msg


def scan_message(data: PoseData, received_ns: int,
                 host_ns_of_tick: Callable[[int], int | None],
                 map_id: Mapping[int, int] | None = None) -> dict[str, Any] | None:
    """The ``lgvtool.ReflectorScan`` of a reply's landmark block (None without one): every
    landmark with a polar measurement; ``map_id`` turns the device's global ids into map ids
    (None: the same; a global id not in it: -1)."""
    block = data.landmarks
    if block is None:
        return None
    marks = [m for m in block.landmarks if m.polar is not None]
    ticks = [m.info.timestamp_ms for m in marks if m.info is not None]
    start_tick: int | None = None
    if data.scans:
        start_tick = data.scans[0].timestamp_ms
    elif ticks:
        start_tick = min(ticks, key=lambda t: (t - ticks[0] + 2**31) % 2**32)
    start_ns = None if start_tick is None else host_ns_of_tick(start_tick)
    if start_ns is None:
        start_ns = received_ns - round(SCAN_PERIOD * 1e9)
    observations = []
    for m in marks:
        assert m.polar is not None
        dist, phi = m.polar
        o: dict[str, Any] = {"range": dist / 1000.0, "bearing": _angle(phi),
                             "time_in_scan": 0.0, "id": -1}
        info = m.info
        if info is not None:
            gid = info.global_id
            o["id"] = (gid if gid != 0xFFFF else -1) if map_id is None else map_id.get(gid, -1)
            if start_tick is not None:
                dt = ((info.timestamp_ms - start_tick + 2**31) % 2**32 - 2**31) / 1000.0
                o["time_in_scan"] = max(0.0, dt)
            o.update(local_id=info.local_id, global_id=gid, quality=info.quality,
                     device_time_ms=info.timestamp_ms)
        observations.append(o)
    msg: dict[str, Any] = {"timestamp": stamp(start_ns), "scan_period": SCAN_PERIOD,
                           "observations": observations}
    if start_tick is not None:
        msg["device_time_ms"] = start_tick
    return msg
