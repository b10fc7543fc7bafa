"""Decoded frames as the JSON message dicts of the log schemas.

``lgvtool.McuFrame`` from an :class:`~lgvtool.wire.mcu.McuFrame`, ``lgvtool.NavPose`` from a NAV200
:class:`~lgvtool.wire.nav200_payloads.Pose`. ``timestamp`` is the host time at which the frame's
last byte was received, ``{"sec": s, "nsec": ns}``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.wire.mcu import McuFrame
from lgvtool.wire.nav200_commands import Reply
from lgvtool.wire.nav200_payloads import Pose

_NS_PER_S = 1_000_000_000


def timestamp_from_ns(time_ns: int) -> dict[str, int]:
    """``{"sec", "nsec"}`` from nanoseconds since the Unix epoch."""
    sec, nsec = divmod(int(time_ns), _NS_PER_S)
    return {"sec": sec, "nsec": nsec}


def _stamp(timestamp: Mapping[str, int]) -> dict[str, int]:
    return {"sec": int(timestamp["sec"]), "nsec": int(timestamp["nsec"])}


def mcu_frame_message(frame: McuFrame, timestamp: Mapping[str, int]) -> dict[str, Any]:
    """An ``lgvtool.McuFrame`` message: raw counts plus SI values.

    ``gyro_scale`` in deg/s per count, ``gyro_rate`` rad/s, ``steering_angle`` rad,
    ``drive_speed`` m/s.
    """
    return {
        "timestamp": _stamp(timestamp),
        "version": frame.version,
        "seq": frame.seq,
        "mcu_time_ms": frame.mcu_time_ms,
        "enc_left": frame.enc_left,
        "enc_right": frame.enc_right,
        "gyro_raw": frame.gyro_raw,
        "gyro_scale": frame.gyro_scale_deg_s,
        "gyro_rate": frame.gyro_rate,
        "steering_angle": frame.steering_angle,
        "drive_speed": frame.drive_speed,
        "status": frame.status,
    }


def nav_pose_message(pose: Pose | Reply, timestamp: Mapping[str, int]) -> dict[str, Any]:
    """An ``lgvtool.NavPose`` message from a PP reply or its payload.

    x, y in m, heading in rad within (-pi, pi], ``valid`` False for quality 0xFE/0xFF.
    """
    if isinstance(pose, Reply):
        if not isinstance(pose.payload, Pose):
            raise TypeError(f"NAV200 {pose.code} reply carries no pose")
        pose = pose.payload
    return {
        "timestamp": _stamp(timestamp),
        "x": pose.x,
        "y": pose.y,
        "heading": pose.heading,
        "quality": pose.quality,
        "reflectors_used": pose.reflectors_used,
        "valid": pose.valid,
    }
