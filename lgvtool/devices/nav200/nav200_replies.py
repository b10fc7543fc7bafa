"""Device-side NAV200 reply builders: the bytes a real NAV200 sends, from SI values.

Used by the simulator and the device emulators. Every function returns the framed telegram
(STX ... BCC). Lengths in m (sent as whole mm), angles in rad (sent as 65536 units per
revolution, wrapped), raw u8 fields as they go on the wire.
"""

from __future__ import annotations

from lgvtool.devices.nav200.nav200_commands import COMMANDS, ErrorReply, Reply, Request
from lgvtool.devices.nav200.nav200_payloads import (
    Empty,
    MappingResult,
    Pose,
    ReflectorAddress,
    ReflectorPosition,
    ReflectorRadius,
    SerialNumber,
    Version,
    VersionText,
)
from lgvtool.wire.wire_errors import EncodeError

#: Quality byte sent when the device has no valid position.
NO_POSITION = 0xFF
#: The other "no valid position" quality byte.
NO_POSITION_ALT = 0xFE

#: F1 error class "user software", F2 group "I/O telegram traffic", F3 "unknown command".
CLASS_USER_SOFTWARE = 1
GROUP_TELEGRAM_TRAFFIC = 1
DETAIL_UNKNOWN_COMMAND = 1
#: F3 "wrong command" (e.g. a command not allowed in the current mode).
DETAIL_WRONG_COMMAND = 3
#: F3 "all reflectors transferred" (upload finished).
DETAIL_ALL_TRANSFERRED = 10


def build_pose_reply(
    x_m: float, y_m: float, heading_rad: float, quality: int, reflectors_used: int
) -> bytes:
    """PP reply (LEN 17) with the head pose: x, y in m, heading in rad, quality and count u8."""
    return Reply("PP", Pose.from_si(x_m, y_m, heading_rad, quality, reflectors_used)).encode()


def build_no_position_reply(quality: int = NO_POSITION, reflectors_used: int = 0) -> bytes:
    """PP reply saying "no valid position": quality 0xFF (or 0xFE), X = Y = heading = 0."""
    if quality not in (NO_POSITION, NO_POSITION_ALT):
        raise EncodeError(f"no-position quality must be 0xFE or 0xFF, not {quality}")
    return Reply("PP", Pose(0, 0, 0, quality, reflectors_used)).encode()


def build_ack_reply(request: Request | str) -> bytes:
    """The reply of a mode change with no data (SA, MA, PA, UA, DA; PN is answered with PA)."""
    code = request.reply_code if isinstance(request, Request) else COMMANDS[request].reply_code
    return Reply(code, Empty()).encode()


def build_echo_reply(request: Request) -> bytes:
    """The reply that echoes ``request``'s data (SU, SC, SI, RS -> RG, PL, PM, PO, PC).

    EncodeError when the command's reply does not have the request's layout.
    """
    spec = request.spec
    if spec.reply is not spec.request:
        raise EncodeError(f"NAV200 {request.code} is not answered with an echo")
    return Reply(spec.reply_code, request.payload).encode()


def build_version_reply(major: int, minor: int, patch: int) -> bytes:
    """SV reply (LEN 8): version a.b.c, three u8."""
    return Reply("SV", Version(major, minor, patch)).encode()


def build_version_text_reply(text: str) -> bytes:
    """ST reply (variable LEN): version text, single-byte characters, at most 250."""
    return Reply("ST", VersionText(text)).encode()


def build_serial_reply(serial: int) -> bytes:
    """SS reply (LEN 7): serial number, i16."""
    return Reply("SS", SerialNumber(serial)).encode()


def build_reflector_reply(code: str, layer: int, number: int, x_m: float, y_m: float) -> bytes:
    """A reply carrying one reflector position (RP, LEN 15): SR, SC, SI, SD, MR or UR."""
    if code not in ("SR", "SC", "SI", "SD", "MR", "UR"):
        raise EncodeError(f"NAV200 {code} reply does not carry a reflector position")
    return Reply(code, ReflectorPosition.from_si(layer, number, x_m, y_m)).encode()


def build_upload_reply(layer: int, number: int, x_m: float, y_m: float) -> bytes:
    """UR reply (LEN 15): the next stored reflector at (x, y), m.

    The host stops uploading when ``number`` exceeds the reflector count (above 32 in the
    player driver); send e.g. ``number=0xFF`` after the last one.
    """
    return build_reflector_reply("UR", layer, number, x_m, y_m)


def build_radius_reply(layer: int, radius: int) -> bytes:
    """RG reply (LEN 7), also the answer to RS: layer and radius u8 (unit assumed mm)."""
    return Reply("RG", ReflectorRadius(layer, radius)).encode()


def build_mapping_reply(layer: int, count: int) -> bytes:
    """MS reply (LEN 7), the answer to MS, MM and MN: layer and number of reflectors found."""
    return Reply("MS", MappingResult(layer, count)).encode()


def build_download_reply(layer: int, number: int) -> bytes:
    """DR reply (LEN 7): layer and number of the reflector just stored."""
    return Reply("DR", ReflectorAddress(layer, number)).encode()


def build_error_reply(
    rejected: Request | str,
    error_class: int,
    group: int,
    detail: int,
    *,
    mode: str | None = None,
) -> bytes:
    """Error reply (function 'E', LEN 9) to ``rejected`` (a request or its two-letter code).

    F0 is the rejected function letter; F1-F3 the class, group and detail bytes. The mode
    byte is the rejected request's mode unless ``mode`` is given (its real value is undocumented).
    """
    code = rejected.code if isinstance(rejected, Request) else rejected
    if len(code) != 2:
        raise EncodeError(f"rejected command must be a two-letter code: {code!r}")
    return ErrorReply(mode or code[0], code[1], error_class, group, detail).encode()
