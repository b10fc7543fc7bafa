"""Unit conversions at the wire edge and wrap-around arithmetic of device counters.

Inside lgvtool everything is SI (m, rad, s); the wire carries mm, NAV200 heading units
(65536 per revolution, int16), 0.01 degrees and micro-degrees per second. These functions are the
only place where the conversions happen.
"""

from __future__ import annotations

import math

from lgvtool.wire.wire_errors import EncodeError

#: NAV200 heading units per radian: 65536 per revolution, so 32768/pi.
HEADING_UNITS_PER_RAD = 32768.0 / math.pi

#: NAV200 speed-request omega (Pw, PV) units per rad/s assumed by lgvtool: the heading unit per
#: second (65536 per revolution per second), as the player driver sends it.
OMEGA_UNITS_PER_RAD_S = 32768.0 / math.pi

#: The alternative omega scale of the Robotnik nav200_laser driver: units of 0.5 deg/s.
OMEGA_UNITS_PER_RAD_S_HALF_DEG = 360.0 / math.pi

INT16_MIN, INT16_MAX = -(1 << 15), (1 << 15) - 1
INT32_MIN, INT32_MAX = -(1 << 31), (1 << 31) - 1


def mm_to_m(value_mm: int) -> float:
    """Millimetres (wire) to metres."""
    return value_mm / 1000.0


def m_to_mm(value_m: float) -> int:
    """Metres to whole millimetres (wire), rounded to nearest; EncodeError if not finite."""
    return _round(value_m * 1000.0, "length")


def heading_to_rad(units: int) -> float:
    """NAV200 heading (int16, 65536 per revolution) to radians in (-pi, pi].

    -32768 (half a revolution) maps to +pi.
    """
    wrapped = wrap_i16(units)
    if wrapped == INT16_MIN:
        return math.pi
    return wrapped / HEADING_UNITS_PER_RAD


def rad_to_heading(angle_rad: float) -> int:
    """Radians (any value) to the NAV200 heading int16, wrapped into [-32768, 32767]."""
    return wrap_i16(_round(angle_rad * HEADING_UNITS_PER_RAD, "heading"))


def omega_to_rad_s(units: int, scale: float = OMEGA_UNITS_PER_RAD_S) -> float:
    """NAV200 speed-request omega (int16) to rad/s; ``scale`` is units per rad/s."""
    return units / scale


def rad_s_to_omega(rate_rad_s: float, scale: float = OMEGA_UNITS_PER_RAD_S) -> int:
    """rad/s to the NAV200 speed-request omega units (``scale`` per rad/s), rounded."""
    return _round(rate_rad_s * scale, "omega")


def centideg_to_rad(value_cdeg: int) -> float:
    """0.01 degree units to radians."""
    return math.radians(value_cdeg / 100.0)


def rad_to_centideg(angle_rad: float) -> int:
    """Radians to whole 0.01 degree units, rounded to nearest."""
    return _round(math.degrees(angle_rad) * 100.0, "angle")


def wrap_u16(value: int) -> int:
    """``value`` modulo 2**16, in [0, 65535]."""
    return value & 0xFFFF


def wrap_u32(value: int) -> int:
    """``value`` modulo 2**32, in [0, 4294967295]."""
    return value & 0xFFFFFFFF


def wrap_i16(value: int) -> int:
    """``value`` wrapped into int16, [-32768, 32767] (two's complement)."""
    return ((value + (1 << 15)) & 0xFFFF) - (1 << 15)


def wrap_i32(value: int) -> int:
    """``value`` wrapped into int32, [-2**31, 2**31 - 1] (two's complement)."""
    return ((value + (1 << 31)) & 0xFFFFFFFF) - (1 << 31)


def seq_delta(a: int, b: int) -> int:
    """Sequence-number steps from ``a`` to ``b``, modulo 65536, in [0, 65535].

    ``seq_delta(65535, 0) == 1``; 1 means ``b`` directly follows ``a``.
    """
    return (b - a) & 0xFFFF


def counter_delta(a: int, b: int) -> int:
    """Signed change of an int32 wrapping counter from ``a`` to ``b``, in counts.

    ``counter_delta(2**31 - 1, -2**31) == 1``: correct as long as the true change is less than
    2**31 counts in magnitude.
    """
    return wrap_i32(b - a)


def clock_delta_ms(a: int, b: int) -> int:
    """Elapsed MCU clock from ``a`` to ``b`` (u32 milliseconds, wrapping), in [0, 2**32 - 1] ms."""
    return (b - a) & 0xFFFFFFFF


def _round(value: float, what: str) -> int:
    if not math.isfinite(value):
        raise EncodeError(f"{what} is not a finite number: {value!r}")
    return round(value)
