"""The MCU frame, version 1: encoders, gyro and drive unit, one frame every 100 ms.

Byte layout (all multi-byte fields little-endian; full table and worked examples in
``docs/protocol.md``)::

    off size field
    0   2    sync 0xA5 0x5A
    2   1    LEN = bytes from VER through the last payload byte (v1: 25)
    3   1    VER = 1
    4   2    seq, u16, wraps 65535 -> 0
    6   4    mcu_time_ms, u32, wraps
    10  4    enc_left, i32 cumulative counts, wraps
    14  4    enc_right, i32 cumulative counts, wraps
    18  2    gyro_raw, i16 counts (CCW positive)
    20  2    gyro_scale, u16, micro-degrees/s per count
    22  2    steering, i16, 0.01 deg (CCW positive)
    24  2    drive_speed, i16, mm/s
    26  2    status, u16 bit field (McuStatus)
    28  2    CRC-16/CCITT-FALSE over bytes 2..27 (LEN through status)

Total 30 bytes. :class:`McuFrame` keeps the raw integers and offers SI properties.
"""

from __future__ import annotations

import enum
import math
import struct
from dataclasses import dataclass

from lgvtool.wire.checksum import crc16_ccitt_false
from lgvtool.wire.units import (
    INT16_MAX,
    INT16_MIN,
    centideg_to_rad,
    rad_to_centideg,
    wrap_i32,
    wrap_u16,
    wrap_u32,
)
from lgvtool.wire.wire_errors import (
    BadLengthError,
    BadSyncError,
    ChecksumError,
    EncodeError,
    TruncatedError,
    UnknownVersionError,
)

__all__ = [
    "DEFAULT_GYRO_SCALE_UDEG_S",
    "FRAME_SIZE",
    "MCU_VERSION",
    "SYNC",
    "V1_LEN",
    "McuFrame",
    "McuStatus",
    "decode_mcu_frame",
    "encode_mcu_frame",
    "frame_size_for_len",
]

#: The two sync bytes that start every MCU frame.
SYNC = b"\xa5\x5a"
#: The frame format version this module encodes and decodes.
MCU_VERSION = 1
#: LEN of a version-1 frame: VER (1) + payload (24) bytes.
V1_LEN = 25
#: Bytes of a whole version-1 frame: sync (2) + LEN (1) + 25 + CRC (2).
FRAME_SIZE = 30
#: Gyro scale of a +-360 deg/s gyro over int16: 360/32768 deg/s = 10986 micro-deg/s per count.
DEFAULT_GYRO_SCALE_UDEG_S = 10986

# VER, seq, mcu_time_ms, enc_left, enc_right, gyro_raw, gyro_scale, steering, drive_speed, status
_BODY = struct.Struct("<BHIiihHhhH")
assert _BODY.size == V1_LEN


class McuStatus(enum.IntFlag):
    """Bits of the MCU ``status`` field; bits 7-15 are reserved and sent as 0."""

    DRIVE_ENABLED = 1 << 0
    ESTOP = 1 << 1
    ENC_LEFT_FAULT = 1 << 2
    ENC_RIGHT_FAULT = 1 << 3
    GYRO_FAULT = 1 << 4
    GYRO_SATURATED = 1 << 5
    #: the MCU clock (and its sequence number) restarted
    MCU_RESET = 1 << 6


def frame_size_for_len(length: int) -> int:
    """Total bytes of a frame whose LEN field is ``length``: sync + LEN + ``length`` + CRC."""
    return length + 5


@dataclass(frozen=True)
class McuFrame:
    """One MCU frame with its raw wire integers; SI values are properties.

    Attributes (raw, as on the wire):
        seq: sequence number, u16, wraps 65535 -> 0.
        mcu_time_ms: MCU clock, u32 ms, wraps.
        enc_left, enc_right: cumulative encoder counts, int32, wrap.
        gyro_raw: yaw rate, int16 counts, counter-clockwise positive.
        gyro_scale_udeg_s: gyro scale, u16 micro-degrees/s per count.
        steering_cdeg: steering angle of the drive wheel, int16 0.01 deg, CCW positive.
        drive_speed_mm_s: drive wheel speed, int16 mm/s.
        status: u16 bit field, see :class:`McuStatus`.
        version: frame format version (1).
    """

    seq: int
    mcu_time_ms: int
    enc_left: int
    enc_right: int
    gyro_raw: int
    gyro_scale_udeg_s: int = DEFAULT_GYRO_SCALE_UDEG_S
    steering_cdeg: int = 0
    drive_speed_mm_s: int = 0
    status: int = 0
    version: int = MCU_VERSION

    @property
    def gyro_scale_deg_s(self) -> float:
        """Gyro scale, deg/s per count."""
        return self.gyro_scale_udeg_s * 1e-6

    @property
    def gyro_rate(self) -> float:
        """Gyro yaw rate, rad/s, counter-clockwise positive."""
        return math.radians(self.gyro_raw * self.gyro_scale_udeg_s * 1e-6)

    @property
    def steering_angle(self) -> float:
        """Steering angle of the drive wheel, rad, counter-clockwise positive."""
        return centideg_to_rad(self.steering_cdeg)

    @property
    def drive_speed(self) -> float:
        """Drive wheel speed, m/s."""
        return self.drive_speed_mm_s / 1000.0

    @property
    def flags(self) -> McuStatus:
        """The known status bits as flags (reserved bits dropped)."""
        return McuStatus(self.status & 0x7F)

    def has(self, flag: McuStatus) -> bool:
        """True when every bit of ``flag`` is set in ``status``."""
        return (self.status & int(flag)) == int(flag)

    def encode(self) -> bytes:
        """The 30 wire bytes of this frame; EncodeError if a field is out of range."""
        return encode_mcu_frame(self)

    @classmethod
    def from_si(
        cls,
        *,
        seq: int,
        mcu_time_ms: int,
        enc_left: int,
        enc_right: int,
        gyro_rate_rad_s: float,
        steering_rad: float,
        drive_speed_m_s: float,
        status: int = 0,
        gyro_scale_udeg_s: int = DEFAULT_GYRO_SCALE_UDEG_S,
    ) -> McuFrame:
        """Build a frame from SI values, as an MCU (or the simulator) would.

        ``seq``, ``mcu_time_ms`` and the encoder counts are wrapped into their field ranges.
        The gyro rate (rad/s) is quantised with ``gyro_scale_udeg_s`` and clamped to int16; on
        clamping the GYRO_SATURATED bit is set. Steering (rad) goes to 0.01 deg and the drive
        speed (m/s) to mm/s, both clamped to int16.
        """
        if gyro_scale_udeg_s <= 0 or gyro_scale_udeg_s > 0xFFFF:
            raise EncodeError(f"gyro scale out of range: {gyro_scale_udeg_s} micro-deg/s")
        for name, value in (
            ("gyro rate", gyro_rate_rad_s),
            ("steering", steering_rad),
            ("drive speed", drive_speed_m_s),
        ):
            if not math.isfinite(value):
                raise EncodeError(f"{name} is not a finite number: {value!r}")
        gyro_counts = round(math.degrees(gyro_rate_rad_s) * 1e6 / gyro_scale_udeg_s)
        gyro_raw = min(max(gyro_counts, INT16_MIN), INT16_MAX)
        if gyro_raw != gyro_counts:
            status |= McuStatus.GYRO_SATURATED
        steering = min(max(rad_to_centideg(steering_rad), INT16_MIN), INT16_MAX)
        speed = min(max(round(drive_speed_m_s * 1000.0), INT16_MIN), INT16_MAX)
        return cls(
            seq=wrap_u16(seq),
            mcu_time_ms=wrap_u32(mcu_time_ms),
            enc_left=wrap_i32(enc_left),
            enc_right=wrap_i32(enc_right),
            gyro_raw=gyro_raw,
            gyro_scale_udeg_s=gyro_scale_udeg_s,
            steering_cdeg=steering,
            drive_speed_mm_s=speed,
            status=int(status) & 0xFFFF,
        )


def encode_mcu_frame(frame: McuFrame) -> bytes:
    """The 30 wire bytes of a version-1 frame: sync, LEN, body, CRC-16 (little-endian).

    Raises EncodeError when a field does not fit its wire type or the version is not 1.
    """
    if frame.version != MCU_VERSION:
        raise EncodeError(f"cannot encode MCU frame version {frame.version}")
    try:
        body = _BODY.pack(
            frame.version,
            frame.seq,
            frame.mcu_time_ms,
            frame.enc_left,
            frame.enc_right,
            frame.gyro_raw,
            frame.gyro_scale_udeg_s,
            frame.steering_cdeg,
            frame.drive_speed_mm_s,
            frame.status,
        )
    except struct.error as exc:
        raise EncodeError(f"MCU frame field out of range: {exc}") from None
    covered = bytes([V1_LEN]) + body
    return SYNC + covered + crc16_ccitt_false(covered).to_bytes(2, "little")


def decode_mcu_frame(data: bytes | bytearray | memoryview) -> McuFrame:
    """Decode exactly one frame from ``data`` (which must hold the whole frame and nothing else).

    Raises BadSyncError, TruncatedError, BadLengthError, ChecksumError or UnknownVersionError
    (the latter only when the CRC checks, so the frame is intact but of another version).
    """
    raw = bytes(data)
    if len(raw) < 3:
        raise TruncatedError(f"MCU frame truncated: {len(raw)} bytes")
    if raw[:2] != SYNC:
        raise BadSyncError(f"MCU frame does not start with A5 5A: {raw[:2].hex(' ')}")
    length = raw[2]
    if length < 1:
        raise BadLengthError("MCU frame LEN 0 (no version byte)")
    size = frame_size_for_len(length)
    if len(raw) < size:
        raise TruncatedError(f"MCU frame truncated: {len(raw)} of {size} bytes")
    if len(raw) > size:
        raise BadLengthError(f"MCU frame LEN {length} but {len(raw)} bytes given")
    version = raw[3]
    if version == MCU_VERSION and length != V1_LEN:
        raise BadLengthError(f"MCU frame version 1 with LEN {length} (expected {V1_LEN})")
    expected = crc16_ccitt_false(raw[2 : size - 2])
    received = int.from_bytes(raw[size - 2 : size], "little")
    if expected != received:
        raise ChecksumError(f"MCU frame CRC {received:04X}, computed {expected:04X}")
    if version != MCU_VERSION:
        raise UnknownVersionError(f"MCU frame version {version} is not supported")
    fields = _BODY.unpack(raw[3 : 3 + V1_LEN])
    return McuFrame(
        version=fields[0],
        seq=fields[1],
        mcu_time_ms=fields[2],
        enc_left=fields[3],
        enc_right=fields[4],
        gyro_raw=fields[5],
        gyro_scale_udeg_s=fields[6],
        steering_cdeg=fields[7],
        drive_speed_mm_s=fields[8],
        status=fields[9],
    )
