"""The MCU frame: worked examples of docs/protocol.md, round trips, typed errors, wrap-around."""

from __future__ import annotations

import binascii
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from wire_strategies import mcu_frame_strategy

from lgvtool.devices.mcu.mcu_frame import (
    FRAME_SIZE,
    McuFrame,
    McuStatus,
    decode_mcu_frame,
    encode_mcu_frame,
)
from lgvtool.wire.checksum import crc16_ccitt_false
from lgvtool.wire.units import clock_delta_ms, counter_delta, seq_delta
from lgvtool.wire.wire_errors import (
    BadLengthError,
    BadSyncError,
    ChecksumError,
    EncodeError,
    TruncatedError,
    UnknownVersionError,
)

#: The worked examples of docs/protocol.md.
EXAMPLE_1 = (
    "A5 5A 19 01 01 00 64 00 00 00 00 00 00 00 00 00 00 00 00 00 EA 2A 00 00 00 00 01 00 15 ED"
)
EXAMPLE_2 = (
    "A5 5A 19 01 D2 04 08 E2 01 00 40 E2 01 00 47 94 03 00 4B 05 EA 2A 70 17 68 01 01 00 3C A6"
)
EXAMPLE_3 = (
    "A5 5A 19 01 FF FF FF FF FF FF FF FF FF FF 00 00 00 80 00 80 EA 2A 6C EE 06 FF 62 00 43 4B"
)

EXAMPLES = [
    (EXAMPLE_1, McuFrame(seq=1, mcu_time_ms=100, enc_left=0, enc_right=0, gyro_raw=0, status=1)),
    (
        EXAMPLE_2,
        McuFrame(
            seq=1234,
            mcu_time_ms=123400,
            enc_left=123456,
            enc_right=234567,
            gyro_raw=1355,
            gyro_scale_udeg_s=10986,
            steering_cdeg=6000,
            drive_speed_mm_s=360,
            status=1,
        ),
    ),
    (
        EXAMPLE_3,
        McuFrame(
            seq=65535,
            mcu_time_ms=4294967295,
            enc_left=-1,
            enc_right=-2147483648,
            gyro_raw=-32768,
            steering_cdeg=-4500,
            drive_speed_mm_s=-250,
            status=0x62,
        ),
    ),
]


@pytest.mark.parametrize(("hex_bytes", "frame"), EXAMPLES, ids=["idle", "circle", "extremes"])
def test_worked_examples(hex_bytes: str, frame: McuFrame) -> None:
    raw = bytes.fromhex(hex_bytes)
    assert len(raw) == FRAME_SIZE
    assert frame.encode() == raw
    assert decode_mcu_frame(raw) == frame
    # Cross-check the CRC with the standard library's CRC-CCITT (same polynomial, init 0xFFFF).
    assert binascii.crc_hqx(raw[2:28], 0xFFFF) == int.from_bytes(raw[28:30], "little")


def test_worked_example_si_values() -> None:
    circle = decode_mcu_frame(bytes.fromhex(EXAMPLE_2))
    assert circle.gyro_scale_deg_s == pytest.approx(0.010986)
    assert circle.gyro_rate == pytest.approx(math.radians(1355 * 0.010986))
    assert circle.gyro_rate == pytest.approx(0.36 * math.sin(math.radians(60)) / 1.2, abs=1e-3)
    assert circle.steering_angle == pytest.approx(math.radians(60))
    assert circle.drive_speed == pytest.approx(0.36)
    assert circle.has(McuStatus.DRIVE_ENABLED)
    extremes = decode_mcu_frame(bytes.fromhex(EXAMPLE_3))
    assert extremes.flags == McuStatus.ESTOP | McuStatus.GYRO_SATURATED | McuStatus.MCU_RESET
    assert extremes.steering_angle == pytest.approx(math.radians(-45))
    assert extremes.drive_speed == pytest.approx(-0.25)


def test_crc_check_value() -> None:
    assert crc16_ccitt_false(b"123456789") == 0x29B1


def _crc16_bitwise(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE from its definition, a bit at a time."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=80), st.integers(0, 0xFFFF))
def test_crc_is_the_definition_and_continues_a_running_value(data: bytes, start: int) -> None:
    assert crc16_ccitt_false(data) == _crc16_bitwise(data)
    assert crc16_ccitt_false(data, start) == _crc16_bitwise(data, start)
    cut = len(data) // 3
    assert crc16_ccitt_false(data[cut:], crc16_ccitt_false(data[:cut])) == _crc16_bitwise(data)
    assert crc16_ccitt_false(memoryview(data)) == crc16_ccitt_false(bytearray(data))


@settings(max_examples=200, deadline=None)
@given(mcu_frame_strategy)
def test_round_trip(frame: McuFrame) -> None:
    raw = encode_mcu_frame(frame)
    assert len(raw) == FRAME_SIZE
    assert decode_mcu_frame(raw) == frame


@settings(max_examples=100, deadline=None)
@given(
    gyro=st.floats(-20, 20),
    steering=st.floats(-3, 3),
    speed=st.floats(-30, 30),
    seq=st.integers(-(2**20), 2**20),
    left=st.integers(-(2**40), 2**40),
)
def test_from_si(gyro: float, steering: float, speed: float, seq: int, left: int) -> None:
    frame = McuFrame.from_si(
        seq=seq,
        mcu_time_ms=2**33 + 5,
        enc_left=left,
        enc_right=0,
        gyro_rate_rad_s=gyro,
        steering_rad=steering,
        drive_speed_m_s=speed,
    )
    back = decode_mcu_frame(frame.encode())
    assert back.seq == seq % 65536
    assert back.mcu_time_ms == 5
    assert counter_delta(0, back.enc_left) == counter_delta(0, left)
    step = math.radians(back.gyro_scale_deg_s)
    if back.has(McuStatus.GYRO_SATURATED):
        assert abs(gyro) > 32767 * step
        assert abs(back.gyro_raw) >= 32767
    else:
        assert abs(back.gyro_rate - gyro) <= step / 2 + 1e-9
    assert abs(back.steering_angle - steering) <= math.radians(0.005) + 1e-9
    assert abs(back.drive_speed - min(max(speed, -32.768), 32.767)) <= 0.0005 + 1e-9


def test_typed_errors() -> None:
    raw = bytes.fromhex(EXAMPLE_2)
    with pytest.raises(TruncatedError):
        decode_mcu_frame(raw[:29])
    with pytest.raises(TruncatedError):
        decode_mcu_frame(raw[:2])
    with pytest.raises(BadSyncError):
        decode_mcu_frame(b"\xa5\x5b" + raw[2:])
    with pytest.raises(ChecksumError):
        decode_mcu_frame(raw[:10] + bytes([raw[10] ^ 0x40]) + raw[11:])
    with pytest.raises(BadLengthError):
        decode_mcu_frame(raw + b"\x00")
    with pytest.raises(BadLengthError):
        decode_mcu_frame(b"\xa5\x5a\x00\x00\x00")
    with pytest.raises(BadLengthError):  # version 1 must have LEN 25
        decode_mcu_frame(_frame_with(bytes([24]) + raw[3:27]))
    with pytest.raises(UnknownVersionError):
        decode_mcu_frame(_frame_with(bytes([3, 2, 0xAA, 0xBB])))
    with pytest.raises(EncodeError):
        McuFrame(seq=65536, mcu_time_ms=0, enc_left=0, enc_right=0, gyro_raw=0).encode()
    with pytest.raises(EncodeError):
        McuFrame(seq=0, mcu_time_ms=0, enc_left=0, enc_right=0, gyro_raw=0, version=2).encode()
    with pytest.raises(EncodeError):
        McuFrame.from_si(
            seq=0,
            mcu_time_ms=0,
            enc_left=0,
            enc_right=0,
            gyro_rate_rad_s=math.inf,
            steering_rad=0,
            drive_speed_m_s=0,
        )


def _frame_with(covered: bytes) -> bytes:
    """Sync + ``covered`` (LEN onwards) + its valid CRC."""
    return b"\xa5\x5a" + covered + crc16_ccitt_false(covered).to_bytes(2, "little")


def test_wrap_helpers() -> None:
    assert seq_delta(65535, 0) == 1
    assert seq_delta(10, 13) == 3
    assert seq_delta(13, 10) == 65533
    assert seq_delta(7, 7) == 0
    assert counter_delta(2**31 - 1, -(2**31)) == 1
    assert counter_delta(-(2**31), 2**31 - 1) == -1
    assert counter_delta(-5, 5) == 10
    assert counter_delta(100, 40) == -60
    assert clock_delta_ms(2**32 - 50, 50) == 100
    assert clock_delta_ms(0, 100) == 100


@settings(max_examples=100, deadline=None)
@given(st.integers(-(2**31), 2**31 - 1), st.integers(-(2**31) + 1, 2**31 - 1))
def test_counter_delta_over_wrap(start: int, step: int) -> None:
    end = ((start + step + 2**31) % 2**32) - 2**31
    assert counter_delta(start, end) == step


def test_future_version_doc_example() -> None:
    raw = bytes.fromhex("A5 5A 03 02 AA BB 79 95")
    assert raw == _frame_with(bytes([3, 2, 0xAA, 0xBB]))
    with pytest.raises(UnknownVersionError):
        decode_mcu_frame(raw)
