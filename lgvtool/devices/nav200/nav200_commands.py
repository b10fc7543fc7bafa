"""The NAV200 command table, and typed requests and replies.

A :class:`Request` (host -> device) and a :class:`Reply` (device -> host) are a two-letter code
plus a payload from :mod:`lgvtool.devices.nav200.nav200_payloads`; an :class:`ErrorReply` is the device's
'E' telegram with F0-F3 decoded. Some replies carry another function letter than their request
(RS -> RG, PN -> PA, MM/MN -> MS, Pv/Pw/PV -> PP): :func:`reply_code_for` gives it, and
:func:`reply_matches` tells whether a reply answers a request, as the drivers check it (mode,
function and LEN).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TypeVar

from lgvtool.devices.nav200.nav200_errorcodes import (
    error_class_meaning,
    error_detail_meaning,
    error_group_meaning,
)
from lgvtool.devices.nav200.nav200_framing import MIN_LEN, Telegram, encode_telegram, parse_telegram
from lgvtool.devices.nav200.nav200_payloads import (
    ActionRadii,
    Count,
    Direction,
    Empty,
    ErrorCode,
    Layer,
    LayerPose,
    MappingResult,
    MappingScan,
    MappingStart,
    Payload,
    Pose,
    ReflectorAddress,
    ReflectorPosition,
    ReflectorRadius,
    SerialNumber,
    Speed,
    SpeedOmega,
    Version,
    VersionText,
)
from lgvtool.wire.wire_errors import (
    BadLengthError,
    EncodeError,
    UnexpectedReplyError,
    UnknownCommandError,
)

P = TypeVar("P", bound=Payload)

#: Function letter of an error reply.
ERROR_FUNCTION = "E"
#: LEN of an error reply: 5 + F0-F3.
ERROR_REPLY_LEN = 9
#: Mode letters of the device's operating modes.
MODES = {
    "S": "standby",
    "R": "reflector radius",
    "M": "mapping",
    "P": "positioning",
    "U": "upload",
    "D": "download",
}


@dataclass(frozen=True)
class CommandSpec:
    """One row of the command table: request code and data, reply code and data."""

    code: str
    description: str
    request: type[Payload]
    reply_code: str
    reply: type[Payload]


def _spec(
    code: str, description: str, request: type[Payload], reply: type[Payload], reply_code: str = ""
) -> CommandSpec:
    return CommandSpec(code, description, request, reply_code or code, reply)


#: Every request lgvtool knows, by code.
COMMANDS: dict[str, CommandSpec] = {
    s.code: s
    for s in (
        _spec("SA", "enter standby", Empty, Empty),
        _spec("SV", "read software version", Empty, Version),
        _spec("ST", "read version text", Empty, VersionText),
        _spec("SS", "read serial number", Empty, SerialNumber),
        _spec("SU", "set rotation direction", Direction, Direction),
        _spec("SR", "read stored reflector", ReflectorAddress, ReflectorPosition),
        _spec("SC", "change stored reflector", ReflectorPosition, ReflectorPosition),
        _spec("SI", "insert reflector", ReflectorPosition, ReflectorPosition),
        _spec("SD", "delete reflector", ReflectorAddress, ReflectorPosition),
        _spec("RG", "get reflector radius", Layer, ReflectorRadius),
        _spec("RS", "set reflector radius", ReflectorRadius, ReflectorRadius, "RG"),
        _spec("MA", "enter mapping", Empty, Empty),
        _spec("MS", "map from a standing pose", MappingStart, MappingResult),
        _spec("MM", "map over several scans", MappingScan, MappingResult, "MS"),
        _spec("MN", "negative mapping", MappingScan, MappingResult, "MS"),
        _spec("MR", "read mapped reflector", ReflectorAddress, ReflectorPosition),
        _spec("PA", "enter positioning", Empty, Empty),
        _spec("PN", "enter positioning with sliding mean n", Count, Empty, "PA"),
        _spec("PP", "get pose", Empty, Pose),
        _spec("Pv", "get pose, vehicle speed input", Speed, Pose, "PP"),
        _spec("Pw", "get pose, vehicle speed and yaw rate input", SpeedOmega, Pose, "PP"),
        _spec("PV", "get pose, absolute speed and yaw rate input", SpeedOmega, Pose, "PP"),
        _spec("PL", "change layer", Layer, Layer),
        _spec("PM", "change layer with a pose estimate", LayerPose, LayerPose),
        _spec("PO", "set action radii", ActionRadii, ActionRadii),
        _spec("PC", "select N nearest reflectors", Count, Count),
        _spec("UA", "enter upload", Empty, Empty),
        _spec("UR", "upload next reflector", Layer, ReflectorPosition),
        _spec("DA", "enter download", Empty, Empty),
        _spec("DR", "download reflector", ReflectorPosition, ReflectorAddress),
    )
}


def _reply_table() -> dict[str, type[Payload]]:
    table: dict[str, type[Payload]] = {}
    for spec in COMMANDS.values():
        known = table.setdefault(spec.reply_code, spec.reply)
        assert known is spec.reply, spec.reply_code
    return table


#: Every (non-error) reply code, with its data layout.
REPLIES: dict[str, type[Payload]] = _reply_table()


def reply_code_for(request_code: str) -> str:
    """The code of the reply that answers ``request_code`` (e.g. ``"Pw"`` -> ``"PP"``)."""
    try:
        return COMMANDS[request_code].reply_code
    except KeyError:
        raise UnknownCommandError(f"unknown NAV200 command {request_code!r}") from None


def _telegram_length(payload_type: type[Payload]) -> int | None:
    size = payload_type.size()
    return None if size is None else MIN_LEN + size


def request_length(code: str) -> int | None:
    """LEN of request ``code`` (None: variable), or None when the code is unknown."""
    spec = COMMANDS.get(code)
    return None if spec is None else _telegram_length(spec.request)


def reply_length(code: str) -> int | None:
    """LEN of reply ``code`` (9 for any error reply; None: variable or unknown code)."""
    if len(code) == 2 and code[1] == ERROR_FUNCTION:
        return ERROR_REPLY_LEN
    payload = REPLIES.get(code)
    return None if payload is None else _telegram_length(payload)


def is_known_request(code: str) -> bool:
    """True when ``code`` is a request in the command table."""
    return code in COMMANDS


def is_known_reply(code: str) -> bool:
    """True when ``code`` is a reply in the table or an error reply (function 'E')."""
    return code in REPLIES or (len(code) == 2 and code[1] == ERROR_FUNCTION)


class _Coded:
    """What requests and replies share: a two-letter ``code`` and a data block."""

    code: str
    payload: Payload

    @property
    def mode(self) -> str:
        """Mode letter."""
        return self.code[0]

    @property
    def function(self) -> str:
        """Function letter."""
        return self.code[1]

    def telegram(self) -> Telegram:
        """Unframed telegram (letters and data bytes)."""
        return Telegram(self.mode, self.function, self.payload.pack())

    def encode(self) -> bytes:
        """The framed bytes as they travel on the wire."""
        return encode_telegram(self.mode, self.function, self.payload.pack())


@dataclass(frozen=True)
class Request(_Coded):
    """A host -> device telegram: ``code`` (e.g. ``"PP"``) and its data block.

    Construction checks that the code is known and the payload has the command's layout.
    """

    code: str
    payload: Payload = field(default_factory=Empty)

    def __post_init__(self) -> None:
        spec = COMMANDS.get(self.code)
        if spec is None:
            raise UnknownCommandError(f"unknown NAV200 command {self.code!r}")
        if type(self.payload) is not spec.request:
            raise EncodeError(
                f"NAV200 {self.code} takes {spec.request.__name__}, "
                f"not {type(self.payload).__name__}"
            )

    @property
    def spec(self) -> CommandSpec:
        """This command's row of the table."""
        return COMMANDS[self.code]

    @property
    def reply_code(self) -> str:
        """The code of the reply that answers this request."""
        return self.spec.reply_code


@dataclass(frozen=True)
class Reply(_Coded):
    """A device -> host telegram other than an error: ``code`` and its data block."""

    code: str
    payload: Payload = field(default_factory=Empty)

    def __post_init__(self) -> None:
        expected = REPLIES.get(self.code)
        if expected is None:
            raise UnknownCommandError(f"unknown NAV200 reply {self.code!r}")
        if type(self.payload) is not expected:
            raise EncodeError(
                f"NAV200 {self.code} reply carries {expected.__name__}, "
                f"not {type(self.payload).__name__}"
            )


@dataclass(frozen=True)
class ErrorReply:
    """A NAV200 error telegram: function 'E', data F0-F3.

    ``mode`` is the mode byte as received (its value is not documented; lgvtool's device
    builders send the mode of the rejected request). ``rejected_function`` is F0, the function
    letter of the rejected command; ``error_class``, ``group``, ``detail`` are F1, F2, F3.
    """

    mode: str
    rejected_function: str
    error_class: int
    group: int
    detail: int

    @property
    def code(self) -> str:
        """Mode letter plus 'E'."""
        return self.mode + ERROR_FUNCTION

    @property
    def class_meaning(self) -> str:
        """Readable F1."""
        return error_class_meaning(self.error_class)

    @property
    def group_meaning(self) -> str:
        """Readable F2."""
        return error_group_meaning(self.group)

    @property
    def detail_meaning(self) -> str:
        """Readable F3."""
        return error_detail_meaning(self.detail)

    def describe(self) -> str:
        """One line: rejected function and the three meanings."""
        return (
            f"function {self.rejected_function!r} rejected: {self.detail_meaning} "
            f"(class: {self.class_meaning}; group: {self.group_meaning})"
        )

    def __str__(self) -> str:
        return self.describe()

    def payload(self) -> ErrorCode:
        """F0-F3 as raw bytes."""
        f0 = self.rejected_function.encode("latin-1", errors="replace")
        if len(f0) != 1:
            raise EncodeError(f"F0 must be one character: {self.rejected_function!r}")
        return ErrorCode(f0[0], self.error_class, self.group, self.detail)

    def telegram(self) -> Telegram:
        """Unframed telegram (letters and data bytes)."""
        return Telegram(self.mode, ERROR_FUNCTION, self.payload().pack())

    def encode(self) -> bytes:
        """The framed bytes as the device sends them."""
        return encode_telegram(self.mode, ERROR_FUNCTION, self.payload().pack())


#: Anything the device sends.
DeviceReply = Reply | ErrorReply


def _as_telegram(message: Telegram | bytes | bytearray | memoryview) -> Telegram:
    if isinstance(message, Telegram):
        return message
    return parse_telegram(message)


def decode_request(message: Telegram | bytes | bytearray | memoryview) -> Request:
    """Decode one request from a telegram or its framed bytes (device side).

    Raises the framing errors of :func:`parse_telegram`, UnknownCommandError, BadLengthError.
    """
    tel = _as_telegram(message)
    spec = COMMANDS.get(tel.code)
    if spec is None:
        raise UnknownCommandError(f"unknown NAV200 request {tel.code!r}")
    return Request(tel.code, _unpack(spec.request, tel))


def decode_reply(message: Telegram | bytes | bytearray | memoryview) -> DeviceReply:
    """Decode one reply from a telegram or its framed bytes (host side).

    A telegram with function 'E' (and any mode letter) is an :class:`ErrorReply`. Raises the
    framing errors of :func:`parse_telegram`, UnknownCommandError, BadLengthError.
    """
    tel = _as_telegram(message)
    if tel.function == ERROR_FUNCTION:
        code = _unpack(ErrorCode, tel)
        return ErrorReply(tel.mode, chr(code.f0), code.f1, code.f2, code.f3)
    payload_type = REPLIES.get(tel.code)
    if payload_type is None:
        raise UnknownCommandError(f"unknown NAV200 reply {tel.code!r}")
    return Reply(tel.code, _unpack(payload_type, tel))


def _unpack(payload_type: type[P], tel: Telegram) -> P:
    try:
        return payload_type.unpack(tel.data)
    except BadLengthError as exc:
        raise BadLengthError(f"NAV200 {tel.code}: {exc}") from None


def reply_matches(request: Request, reply: DeviceReply) -> bool:
    """True when ``reply`` answers ``request``.

    A normal reply must carry the request's reply code (its LEN was checked when decoding). An
    error reply answers any request: F0 should be the request's function letter, but the drivers
    do not check it and neither does this function.
    """
    if isinstance(reply, ErrorReply):
        return True
    return reply.code == request.reply_code


def check_reply(request: Request, reply: DeviceReply) -> DeviceReply:
    """Return ``reply`` if it answers ``request``; else raise UnexpectedReplyError."""
    if not reply_matches(request, reply):
        raise UnexpectedReplyError(
            f"NAV200 {reply.code} reply does not answer {request.code} "
            f"(expected {request.reply_code})"
        )
    return reply


__all__ = [
    "COMMANDS",
    "ERROR_FUNCTION",
    "ERROR_REPLY_LEN",
    "MODES",
    "REPLIES",
    "CommandSpec",
    "DeviceReply",
    "ErrorReply",
    "Reply",
    "Request",
    "check_reply",
    "decode_reply",
    "decode_request",
    "is_known_reply",
    "is_known_request",
    "reply_code_for",
    "reply_length",
    "reply_matches",
    "request_length",
]
