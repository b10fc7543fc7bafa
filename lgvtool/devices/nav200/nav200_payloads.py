"""Data blocks of NAV200 telegrams, one dataclass per layout.

Each payload keeps the raw wire integers (mm, heading units of 65536 per revolution, ...) and
offers SI properties (m, rad, m/s, rad/s). ``pack()`` gives the little-endian data bytes,
``unpack(data)`` parses them and checks their length. Several commands share one layout (for
example :class:`ReflectorPosition` is the RP block of SR, SC, SI, SD, MR, UR replies and of the
SC, SI, DR requests); which command uses which is in :mod:`lgvtool.devices.nav200.nav200_commands`.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, fields
from typing import ClassVar, Self

from lgvtool.wire.units import (
    OMEGA_UNITS_PER_RAD_S,
    heading_to_rad,
    m_to_mm,
    mm_to_m,
    omega_to_rad_s,
    rad_s_to_omega,
    rad_to_heading,
)
from lgvtool.wire.wire_errors import BadLengthError, EncodeError

#: Quality bytes that mean "no valid position" (player driver).
NO_POSITION_QUALITIES = frozenset({0xFE, 0xFF})


class Payload:
    """Base of every data block: a fixed ``FORMAT`` over the dataclass fields, in order."""

    FORMAT: ClassVar[struct.Struct] = struct.Struct("<")

    @classmethod
    def size(cls) -> int | None:
        """Number of data bytes, or None when the block has a variable length."""
        return cls.FORMAT.size

    def pack(self) -> bytes:
        """The data bytes; EncodeError when a field does not fit its wire type."""
        values = tuple(getattr(self, f.name) for f in fields(self))  # type: ignore[arg-type]
        try:
            return self.FORMAT.pack(*values)
        except struct.error as exc:
            raise EncodeError(f"{type(self).__name__}: field out of range ({exc})") from None

    @classmethod
    def unpack(cls, data: bytes) -> Self:
        """Parse the data bytes; BadLengthError when their number does not match."""
        if len(data) != cls.FORMAT.size:
            raise BadLengthError(
                f"{cls.__name__}: {len(data)} data bytes, expected {cls.FORMAT.size}"
            )
        return cls(*cls.FORMAT.unpack(data))


class _PoseFields:
    """SI views of the raw pose fields ``x_mm``, ``y_mm``, ``heading_raw`` of a payload."""

    x_mm: int
    y_mm: int
    heading_raw: int

    @property
    def x(self) -> float:
        """X of the vehicle's head, m."""
        return mm_to_m(self.x_mm)

    @property
    def y(self) -> float:
        """Y of the vehicle's head, m."""
        return mm_to_m(self.y_mm)

    @property
    def heading(self) -> float:
        """Heading, rad in (-pi, pi]."""
        return heading_to_rad(self.heading_raw)


@dataclass(frozen=True)
class Empty(Payload):
    """No data (SA, SV, ST, SS, MA, PA, PP, UA, DA requests; SA, MA, PA, UA, DA replies)."""

    FORMAT = struct.Struct("<")


@dataclass(frozen=True)
class Version(Payload):
    """SV reply: software version a.b.c as three u8."""

    FORMAT = struct.Struct("<BBB")
    major: int
    minor: int
    patch: int

    def __str__(self) -> str:
        return f"{self.major}.{self.minor}.{self.patch}"


@dataclass(frozen=True)
class VersionText(Payload):
    """ST reply: version text, ASCII, variable length (0-250 bytes, latin-1 round-trips)."""

    text: str

    @classmethod
    def size(cls) -> int | None:
        return None

    def pack(self) -> bytes:
        try:
            data = self.text.encode("latin-1")
        except UnicodeEncodeError:
            raise EncodeError(f"version text is not single-byte text: {self.text!r}") from None
        if len(data) > 250:
            raise EncodeError(f"version text too long: {len(data)} > 250 bytes")
        return data

    @classmethod
    def unpack(cls, data: bytes) -> Self:
        return cls(bytes(data).decode("latin-1"))


@dataclass(frozen=True)
class SerialNumber(Payload):
    """SS reply: serial number, i16."""

    FORMAT = struct.Struct("<h")
    serial: int


@dataclass(frozen=True)
class Direction(Payload):
    """SU request and reply: rotation direction u8 (0 is assumed to be anticlockwise)."""

    FORMAT = struct.Struct("<B")
    direction: int


@dataclass(frozen=True)
class Layer(Payload):
    """A layer number u8 (RG, PL, UR requests; PL reply)."""

    FORMAT = struct.Struct("<B")
    layer: int


@dataclass(frozen=True)
class Count(Payload):
    """One u8 count: PN sliding-mean count n, PC number N of nearest reflectors."""

    FORMAT = struct.Struct("<B")
    n: int


@dataclass(frozen=True)
class ReflectorAddress(Payload):
    """A reflector's address: layer u8, number u8 (SR, SD, MR requests; DR reply)."""

    FORMAT = struct.Struct("<BB")
    layer: int
    number: int


@dataclass(frozen=True)
class ReflectorPosition(Payload):
    """RP: layer u8, number u8, X i32 mm, Y i32 mm (10 bytes)."""

    FORMAT = struct.Struct("<BBii")
    layer: int
    number: int
    x_mm: int
    y_mm: int

    @property
    def x(self) -> float:
        """X of the reflector, m."""
        return mm_to_m(self.x_mm)

    @property
    def y(self) -> float:
        """Y of the reflector, m."""
        return mm_to_m(self.y_mm)

    @classmethod
    def from_si(cls, layer: int, number: int, x_m: float, y_m: float) -> ReflectorPosition:
        """Build from metres (rounded to whole mm)."""
        return cls(layer, number, m_to_mm(x_m), m_to_mm(y_m))


@dataclass(frozen=True)
class ReflectorRadius(Payload):
    """RG reply, RS request: layer u8, reflector radius u8 (unit assumed mm)."""

    FORMAT = struct.Struct("<BB")
    layer: int
    radius: int

    @property
    def radius_m(self) -> float:
        """Reflector radius, m, assuming the wire unit is mm (an open point)."""
        return mm_to_m(self.radius)


@dataclass(frozen=True)
class MappingStart(_PoseFields, Payload):
    """MS request: layer u8, X i32 mm, Y i32 mm, heading i16, radius u8 (12 bytes)."""

    FORMAT = struct.Struct("<BiihB")
    layer: int
    x_mm: int
    y_mm: int
    heading_raw: int
    radius: int


@dataclass(frozen=True)
class MappingScan(_PoseFields, Payload):
    """MM and MN requests: layer u8, scans u8, X i32 mm, Y i32 mm, heading i16, radius u8."""

    FORMAT = struct.Struct("<BBiihB")
    layer: int
    scans: int
    x_mm: int
    y_mm: int
    heading_raw: int
    radius: int


@dataclass(frozen=True)
class MappingResult(Payload):
    """MS reply (to MS, MM, MN): layer u8, count u8 of reflectors found."""

    FORMAT = struct.Struct("<BB")
    layer: int
    count: int


@dataclass(frozen=True)
class Pose(_PoseFields, Payload):
    """PP reply: X i32 mm, Y i32 mm, heading i16, quality u8, reflectors used u8 (12 bytes).

    Heading: 65536 units per revolution, counter-clockwise from the map x axis (assumed).
    Quality 0xFE and 0xFF mean "no valid position".
    """

    FORMAT = struct.Struct("<iihBB")
    x_mm: int
    y_mm: int
    heading_raw: int
    quality: int
    reflectors_used: int


    @property
    def valid(self) -> bool:
        """False when the quality byte says "no valid position" (0xFE, 0xFF)."""
        return self.quality not in NO_POSITION_QUALITIES

    @classmethod
    def from_si(
        cls, x_m: float, y_m: float, heading_rad: float, quality: int, reflectors_used: int
    ) -> Pose:
        """Build from metres and radians (any angle; wrapped to one revolution)."""
        return cls(
            m_to_mm(x_m), m_to_mm(y_m), rad_to_heading(heading_rad), quality, reflectors_used
        )


class _SpeedFields:
    """SI views of the raw speed fields ``vx_mm_s``, ``vy_mm_s`` of a payload."""

    vx_mm_s: int
    vy_mm_s: int

    @property
    def vx(self) -> float:
        """Speed along x, m/s."""
        return mm_to_m(self.vx_mm_s)

    @property
    def vy(self) -> float:
        """Speed along y, m/s."""
        return mm_to_m(self.vy_mm_s)


@dataclass(frozen=True)
class Speed(_SpeedFields, Payload):
    """Pv request: vx i16 mm/s, vy i16 mm/s (vehicle frame, assumed)."""

    FORMAT = struct.Struct("<hh")
    vx_mm_s: int
    vy_mm_s: int


@dataclass(frozen=True)
class SpeedOmega(_SpeedFields, Payload):
    """Pw (vehicle frame, assumed) and PV (world frame) requests: vx, vy i16 mm/s, omega i16.

    Omega units are an open point; lgvtool uses 65536 per revolution per second (32768/pi per
    rad/s) unless a ``scale`` is given.
    """

    FORMAT = struct.Struct("<hhh")
    vx_mm_s: int
    vy_mm_s: int
    omega_raw: int

    def omega(self, scale: float = OMEGA_UNITS_PER_RAD_S) -> float:
        """Yaw rate, rad/s, with ``scale`` wire units per rad/s."""
        return omega_to_rad_s(self.omega_raw, scale)

    @classmethod
    def from_si(
        cls,
        vx_m_s: float,
        vy_m_s: float,
        omega_rad_s: float,
        scale: float = OMEGA_UNITS_PER_RAD_S,
    ) -> SpeedOmega:
        """Build from m/s and rad/s (``scale`` wire units per rad/s)."""
        return cls(m_to_mm(vx_m_s), m_to_mm(vy_m_s), rad_s_to_omega(omega_rad_s, scale))


@dataclass(frozen=True)
class LayerPose(_PoseFields, Payload):
    """PM request and reply: layer u8, X i32 mm, Y i32 mm, heading i16 (11 bytes)."""

    FORMAT = struct.Struct("<Biih")
    layer: int
    x_mm: int
    y_mm: int
    heading_raw: int


@dataclass(frozen=True)
class ActionRadii(Payload):
    """PO request and reply: minimum and maximum action radius, i32 mm each."""

    FORMAT = struct.Struct("<ii")
    r_min_mm: int
    r_max_mm: int

    @property
    def r_min(self) -> float:
        """Minimum action radius, m."""
        return mm_to_m(self.r_min_mm)

    @property
    def r_max(self) -> float:
        """Maximum action radius, m."""
        return mm_to_m(self.r_max_mm)


@dataclass(frozen=True)
class ErrorCode(Payload):
    """Error reply data F0-F3: rejected function letter, error class, group, detail (4 x u8)."""

    FORMAT = struct.Struct("<BBBB")
    f0: int
    f1: int
    f2: int
    f3: int
