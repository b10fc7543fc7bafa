"""Host-side NAV200 request builders, in SI units.

Each function returns a :class:`~lgvtool.devices.nav200.nav200_commands.Request`; ``.encode()`` gives the
bytes to send, and a host session keeps the request to match the reply against it. Lengths are
in m (sent as whole mm), angles in rad (sent as 65536 units per revolution), speeds in m/s
(sent as mm/s), yaw rates in rad/s (sent in ``omega_scale`` units per rad/s).
"""

from __future__ import annotations

from lgvtool.devices.nav200.nav200_commands import Request
from lgvtool.devices.nav200.nav200_payloads import (
    ActionRadii,
    Count,
    Direction,
    Empty,
    Layer,
    LayerPose,
    MappingScan,
    MappingStart,
    ReflectorAddress,
    ReflectorPosition,
    ReflectorRadius,
    Speed,
    SpeedOmega,
)
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S, m_to_mm, rad_to_heading
from lgvtool.wire.wire_errors import EncodeError

#: Reflector number that marks the end of a download (sent with X = Y = 0).
DOWNLOAD_END_NUMBER = 0xFF


def request_standby() -> Request:
    """SA: enter standby mode."""
    return Request("SA", Empty())


def request_version() -> Request:
    """SV: read the software version (reply: three u8)."""
    return Request("SV", Empty())


def request_version_text() -> Request:
    """ST: read the version as text."""
    return Request("ST", Empty())


def request_serial_number() -> Request:
    """SS: read the serial number."""
    return Request("SS", Empty())


def request_rotation_direction(direction: int) -> Request:
    """SU: set the head's rotation direction (u8; 0 is assumed to be anticlockwise)."""
    return Request("SU", Direction(direction))


def request_read_reflector(layer: int, number: int) -> Request:
    """SR: read stored reflector ``number`` of ``layer``."""
    return Request("SR", ReflectorAddress(layer, number))


def request_change_reflector(layer: int, number: int, x_m: float, y_m: float) -> Request:
    """SC: change stored reflector ``number`` of ``layer`` to (x, y), m."""
    return Request("SC", ReflectorPosition.from_si(layer, number, x_m, y_m))


def request_insert_reflector(layer: int, number: int, x_m: float, y_m: float) -> Request:
    """SI: insert a reflector at (x, y), m, into ``layer``."""
    return Request("SI", ReflectorPosition.from_si(layer, number, x_m, y_m))


def request_delete_reflector(layer: int, number: int) -> Request:
    """SD: delete stored reflector ``number`` of ``layer``."""
    return Request("SD", ReflectorAddress(layer, number))


def request_reflector_radius(layer: int) -> Request:
    """RG: read the reflector radius of ``layer``."""
    return Request("RG", Layer(layer))


def request_set_reflector_radius(layer: int, radius: int) -> Request:
    """RS: set the reflector radius of ``layer`` (raw u8; unit assumed mm). Reply code RG."""
    return Request("RS", ReflectorRadius(layer, radius))


def request_mapping_mode() -> Request:
    """MA: enter mapping mode."""
    return Request("MA", Empty())


def request_map(layer: int, x_m: float, y_m: float, heading_rad: float, radius: int) -> Request:
    """MS: map the reflectors seen from the head pose (x, y m, heading rad); radius raw u8."""
    return Request(
        "MS", MappingStart(layer, m_to_mm(x_m), m_to_mm(y_m), rad_to_heading(heading_rad), radius)
    )


def request_map_scans(
    layer: int,
    scans: int,
    x_m: float,
    y_m: float,
    heading_rad: float,
    radius: int,
    *,
    negative: bool = False,
) -> Request:
    """MM (or MN when ``negative``): map over ``scans`` scans from a head pose. Reply code MS."""
    payload = MappingScan(
        layer, scans, m_to_mm(x_m), m_to_mm(y_m), rad_to_heading(heading_rad), radius
    )
    return Request("MN" if negative else "MM", payload)


def request_mapped_reflector(layer: int, number: int) -> Request:
    """MR: read mapped reflector ``number`` of ``layer``."""
    return Request("MR", ReflectorAddress(layer, number))


def request_positioning_mode() -> Request:
    """PA: enter positioning mode."""
    return Request("PA", Empty())


def request_positioning_mean(n: int) -> Request:
    """PN: enter positioning with a sliding mean over ``n`` poses. Reply code PA."""
    return Request("PN", Count(n))


def request_pose() -> Request:
    """PP: get the pose."""
    return Request("PP", Empty())


def request_pose_with_speed(
    vx_m_s: float,
    vy_m_s: float,
    omega_rad_s: float | None = None,
    *,
    absolute: bool = False,
    omega_scale: float = OMEGA_UNITS_PER_RAD_S,
) -> Request:
    """Get the pose while telling the device the vehicle's speed. Reply code PP.

    Without ``omega_rad_s``: Pv (vx, vy). With it: Pw (vehicle-frame speeds, assumed) or, when
    ``absolute``, PV (world-frame speeds). Speeds in m/s, yaw rate in rad/s, sent with
    ``omega_scale`` units per rad/s (lgvtool's default: 32768/pi).
    """
    if omega_rad_s is None:
        if absolute:
            raise EncodeError("an absolute (PV) speed request needs omega_rad_s")
        return Request("Pv", Speed(m_to_mm(vx_m_s), m_to_mm(vy_m_s)))
    payload = SpeedOmega.from_si(vx_m_s, vy_m_s, omega_rad_s, omega_scale)
    return Request("PV" if absolute else "Pw", payload)


def request_layer(layer: int) -> Request:
    """PL: change to ``layer``."""
    return Request("PL", Layer(layer))


def request_layer_with_pose(layer: int, x_m: float, y_m: float, heading_rad: float) -> Request:
    """PM: change to ``layer`` with a pose estimate of the head (m, rad)."""
    return Request("PM", LayerPose(layer, m_to_mm(x_m), m_to_mm(y_m), rad_to_heading(heading_rad)))


def request_action_radii(r_min_m: float, r_max_m: float) -> Request:
    """PO: set the minimum and maximum action radii, m."""
    return Request("PO", ActionRadii(m_to_mm(r_min_m), m_to_mm(r_max_m)))


def request_nearest_reflectors(n: int) -> Request:
    """PC: use the ``n`` nearest reflectors."""
    return Request("PC", Count(n))


def request_upload_mode() -> Request:
    """UA: enter upload mode."""
    return Request("UA", Empty())


def request_upload_next(layer: int) -> Request:
    """UR: upload the next stored reflector of ``layer``."""
    return Request("UR", Layer(layer))


def request_download_mode() -> Request:
    """DA: enter download mode."""
    return Request("DA", Empty())


def request_download_reflector(layer: int, number: int, x_m: float, y_m: float) -> Request:
    """DR: download one reflector at (x, y), m."""
    return Request("DR", ReflectorPosition.from_si(layer, number, x_m, y_m))


def request_download_end(layer: int) -> Request:
    """DR end marker: number 0xFF, X = Y = 0."""
    return Request("DR", ReflectorPosition(layer, DOWNLOAD_END_NUMBER, 0, 0))
