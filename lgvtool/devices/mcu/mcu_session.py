"""The MCU side of a recording: decode the frame stream, and estimate the vehicle's motion.

The MCU streams one frame every 100 ms without being asked. :class:`McuLink` feeds the bytes
to the resynchronising decoder of :mod:`lgvtool.devices.mcu.mcu_stream` (bad checksums, garbage and
sequence gaps become diagnostics) and keeps the latest velocity estimate, which the NAV200
session can send as speed input (:func:`lgvtool.devices.head_speed.head_velocity`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from lgvtool.config import Vehicle
from lgvtool.devices.mcu.mcu_frame import McuFrame, McuStatus
from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.wire.decode_events import DecodeEvent, DecoderStats
from lgvtool.wire.units import clock_delta_ms, counter_delta

__all__ = ["McuLink", "Motion", "motion_between"]

#: Frames further apart than this (MCU clock) give no velocity estimate, s.
MAX_VELOCITY_GAP = 1.0


@dataclass(frozen=True)
class Motion:
    """Velocity of the point O in the vehicle frame: ``v`` forward, m/s; ``omega`` yaw rate,
    rad/s counter-clockwise; ``mcu_time_ms`` of the later frame."""

    v: float
    omega: float
    mcu_time_ms: int


def motion_between(prev: McuFrame, cur: McuFrame, vehicle: Vehicle) -> Motion | None:
    """Velocity of O between two consecutive frames, or None when they cannot give one.

    Forward speed from the encoder counts over the MCU clock (encoder fault: drive wheel speed
    times cos of the steering angle); yaw rate from the gyro (gyro fault or saturation: from the
    encoder difference over the track).
    """
    dt = clock_delta_ms(prev.mcu_time_ms, cur.mcu_time_ms) / 1000.0
    if not 0.0 < dt <= MAX_VELOCITY_GAP or cur.has(McuStatus.MCU_RESET):
        return None
    k_left, k_right = vehicle.metres_per_count()
    d_left = counter_delta(prev.enc_left, cur.enc_left) * k_left
    d_right = counter_delta(prev.enc_right, cur.enc_right) * k_right
    encoders_ok = not (cur.status & (McuStatus.ENC_LEFT_FAULT | McuStatus.ENC_RIGHT_FAULT))
    gyro_ok = not (cur.status & (McuStatus.GYRO_FAULT | McuStatus.GYRO_SATURATED))
    # encoder fault: the drive wheel's speed along the vehicle axis instead
    v = (d_left + d_right) / 2.0 / dt if encoders_ok \
        else cur.drive_speed * math.cos(cur.steering_angle)
    if gyro_ok:
        omega = cur.gyro_rate
    elif encoders_ok:
        omega = (d_right - d_left) / vehicle.track / dt
    else:
        return None
    return Motion(v, omega, cur.mcu_time_ms)


class McuLink:
    """Decode an MCU byte stream and track the vehicle's motion.

    :param vehicle: geometry for the velocity estimate (encoder wheels, track).
    """

    def __init__(self, vehicle: Vehicle | None = None) -> None:
        self.vehicle = vehicle or Vehicle()
        self._decoder = McuStreamDecoder()
        self._last: McuFrame | None = None
        #: latest velocity estimate, or None
        self.motion: Motion | None = None

    @property
    def stats(self) -> DecoderStats:
        """Decoder counters: frames, skipped bytes, checksum errors, sequence gaps."""
        return self._decoder.stats

    def feed(self, data: bytes) -> list[McuFrame]:
        """Received bytes in, decoded frames out (in stream order)."""
        return self.feed_frames(self._decoder.feed(data))

    def flush(self) -> list[McuFrame]:
        """End of the stream: the frames still buffered (a cut-off one counts as truncated)."""
        return self.feed_frames(self._decoder.flush())

    def feed_frames(self, frames: list[McuFrame]) -> list[McuFrame]:
        """Track the motion over ``frames`` (decoded in stream order); return them."""
        for frame in frames:
            if self._last is not None:
                motion = motion_between(self._last, frame, self.vehicle)
                if motion is not None:
                    self.motion = motion
            self._last = frame
        return frames

    def link_lost(self) -> None:
        """The link went down: a frame cut in half is counted as truncated; the velocity
        estimate is dropped (sequence tracking goes on, so the frames lost show as a gap)."""
        self._decoder.flush()
        self._last = None
        self.motion = None

    def pop_events(self) -> list[DecodeEvent]:
        """Diagnostics since the last call (checksum errors, skipped bytes, sequence gaps)."""
        return self._decoder.pop_events()
