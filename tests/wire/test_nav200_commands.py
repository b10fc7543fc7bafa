"""NAV200 command table, lengths, replies with other function letters, error replies."""

from __future__ import annotations

import math

import pytest

from lgvtool.devices.nav200.nav200_commands import (
    COMMANDS,
    ErrorReply,
    Reply,
    Request,
    check_reply,
    decode_reply,
    decode_request,
    reply_code_for,
    reply_length,
    reply_matches,
    request_length,
)
from lgvtool.devices.nav200.nav200_framing import encode_telegram, parse_telegram
from lgvtool.devices.nav200.nav200_payloads import (
    Count,
    Empty,
    MappingStart,
    Pose,
    ReflectorAddress,
    ReflectorPosition,
    SerialNumber,
    SpeedOmega,
    Version,
    VersionText,
)
from lgvtool.devices.nav200.nav200_replies import (
    build_ack_reply,
    build_download_reply,
    build_echo_reply,
    build_error_reply,
    build_mapping_reply,
    build_no_position_reply,
    build_pose_reply,
    build_radius_reply,
    build_reflector_reply,
    build_serial_reply,
    build_upload_reply,
    build_version_reply,
    build_version_text_reply,
)
from lgvtool.devices.nav200.nav200_requests import (
    request_change_reflector,
    request_layer_with_pose,
    request_map,
    request_map_scans,
    request_pose,
    request_pose_with_speed,
    request_positioning_mean,
    request_set_reflector_radius,
    request_upload_next,
)
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S_HALF_DEG
from lgvtool.wire.wire_errors import (
    BadLengthError,
    BadSyncError,
    ChecksumError,
    DeviceErrorReply,
    EncodeError,
    TruncatedError,
    UnexpectedReplyError,
    UnknownCommandError,
)

# (request code, request LEN, reply code, reply LEN) from the command table.
TABLE = [
    ("SA", 5, "SA", 5), ("SV", 5, "SV", 8), ("ST", 5, "ST", None), ("SS", 5, "SS", 7),
    ("SU", 6, "SU", 6), ("SR", 7, "SR", 15), ("SC", 15, "SC", 15), ("SI", 15, "SI", 15),
    ("SD", 7, "SD", 15), ("RG", 6, "RG", 7), ("RS", 7, "RG", 7), ("MA", 5, "MA", 5),
    ("MS", 17, "MS", 7), ("MM", 18, "MS", 7), ("MN", 18, "MS", 7), ("MR", 7, "MR", 15),
    ("PA", 5, "PA", 5), ("PN", 6, "PA", 5), ("PP", 5, "PP", 17), ("Pv", 9, "PP", 17),
    ("Pw", 11, "PP", 17), ("PV", 11, "PP", 17), ("PL", 6, "PL", 6), ("PM", 16, "PM", 16),
    ("PO", 13, "PO", 13), ("PC", 6, "PC", 6), ("UA", 5, "UA", 5), ("UR", 6, "UR", 15),
    ("DA", 5, "DA", 5), ("DR", 15, "DR", 7),
]  # fmt: skip


@pytest.mark.parametrize(("code", "req_len", "reply_code", "rep_len"), TABLE)
def test_command_table(code: str, req_len: int, reply_code: str, rep_len: int | None) -> None:
    assert request_length(code) == req_len
    assert reply_code_for(code) == reply_code
    assert reply_length(reply_code) == rep_len


def test_table_is_complete() -> None:
    assert set(COMMANDS) == {row[0] for row in TABLE}


def test_error_reply_decodes_meanings() -> None:
    raw = build_error_reply("PP", 1, 7, 9)
    assert raw[1] == 9 and raw[3] == ord("E")
    reply = decode_reply(raw)
    assert isinstance(reply, ErrorReply)
    assert reply.mode == "P"
    assert reply.rejected_function == "P"
    assert reply.class_meaning == "user software"
    assert reply.group_meaning == "positioning"
    assert reply.detail_meaning == "no reflectors in layer"
    assert "no reflectors in layer" in str(reply)
    assert reply.encode() == raw


def test_error_reply_unknown_codes_are_readable() -> None:
    reply = ErrorReply("S", "X", 99, 0, 200)
    assert reply.class_meaning == "unknown (99)"
    assert reply.group_meaning == "unknown (0)"
    assert reply.detail_meaning == "unknown (200)"


def test_error_reply_any_mode_and_explicit_mode() -> None:
    raw = build_error_reply(request_upload_next(0), 1, 5, 10, mode="S")
    reply = decode_reply(raw)
    assert isinstance(reply, ErrorReply)
    assert (reply.mode, reply.rejected_function, reply.detail) == ("S", "R", 10)
    with pytest.raises(DeviceErrorReply) as info:
        raise DeviceErrorReply(reply)
    assert info.value.reply is reply
    assert "all reflectors transferred" in str(info.value)


def test_error_reply_with_wrong_length() -> None:
    bad = encode_telegram("P", "E", b"\x50\x01\x07")
    with pytest.raises(BadLengthError):
        decode_reply(bad)


@pytest.mark.parametrize(
    ("request_", "reply_bytes"),
    [
        (request_set_reflector_radius(0, 45), build_radius_reply(0, 45)),
        (request_positioning_mean(4), build_ack_reply("PA")),
        (request_map_scans(0, 3, 1, 2, 0, 45), build_mapping_reply(0, 7)),
        (
            request_map_scans(0, 3, 1, 2, 0, 45, negative=True),
            build_mapping_reply(0, 7),
        ),
        (request_pose_with_speed(0.1, 0.0), build_pose_reply(0, 0, 0, 90, 5)),
        (request_pose_with_speed(0.1, 0.0, 0.2), build_pose_reply(0, 0, 0, 90, 5)),
        (
            request_pose_with_speed(0.1, 0.0, 0.2, absolute=True),
            build_pose_reply(0, 0, 0, 90, 5),
        ),
    ],
)
def test_replies_with_another_function_letter(request_: Request, reply_bytes: bytes) -> None:
    reply = decode_reply(reply_bytes)
    assert reply_matches(request_, reply)
    assert check_reply(request_, reply) is reply
    assert reply.code != request_.code


def test_reply_to_the_wrong_request() -> None:
    reply = decode_reply(build_ack_reply("SA"))
    assert not reply_matches(request_pose(), reply)
    with pytest.raises(UnexpectedReplyError):
        check_reply(request_pose(), reply)
    error = decode_reply(build_error_reply("PP", 1, 7, 3))
    assert reply_matches(request_pose(), error)


def test_speed_request_units() -> None:
    req = request_pose_with_speed(0.36, -0.1, 0.5)
    assert req.code == "Pw"
    payload = req.payload
    assert isinstance(payload, SpeedOmega)
    assert (payload.vx_mm_s, payload.vy_mm_s) == (360, -100)
    assert payload.omega_raw == round(0.5 * 32768 / math.pi)
    assert payload.omega() == pytest.approx(0.5, abs=1e-4)
    half_deg = request_pose_with_speed(
        0, 0, math.radians(10), omega_scale=OMEGA_UNITS_PER_RAD_S_HALF_DEG
    )
    assert isinstance(half_deg.payload, SpeedOmega)
    assert half_deg.payload.omega_raw == 20
    with pytest.raises(EncodeError):
        request_pose_with_speed(0.1, 0.0, absolute=True)


def test_no_position_reply() -> None:
    for quality in (0xFE, 0xFF):
        reply = decode_reply(build_no_position_reply(quality))
        assert isinstance(reply, Reply) and isinstance(reply.payload, Pose)
        assert not reply.payload.valid
        assert reply.payload.quality == quality
    with pytest.raises(EncodeError):
        build_no_position_reply(100)


def test_device_builders() -> None:
    assert decode_reply(build_version_reply(1, 2, 3)) == Reply(
        "SV", Version(1, 2, 3)
    )
    assert str(Version(1, 2, 3)) == "1.2.3"
    assert decode_reply(build_serial_reply(-5)) == Reply(
        "SS", SerialNumber(-5)
    )
    assert decode_reply(build_version_text_reply("NAV200 V1.4")) == Reply(
        "ST", VersionText("NAV200 V1.4")
    )
    upload = decode_reply(build_upload_reply(0, 3, 12.5, -0.25))
    assert upload == Reply("UR", ReflectorPosition(0, 3, 12500, -250))
    assert isinstance(upload, Reply) and isinstance(upload.payload, ReflectorPosition)
    assert (upload.payload.x, upload.payload.y) == (12.5, -0.25)
    assert decode_reply(build_download_reply(0, 7)) == Reply(
        "DR", ReflectorAddress(0, 7)
    )
    echo = request_layer_with_pose(1, 2.0, 3.0, math.pi)
    assert decode_reply(build_echo_reply(echo)) == Reply("PM", echo.payload)
    radius = request_set_reflector_radius(0, 45)
    assert decode_reply(build_echo_reply(radius)) == Reply("RG", radius.payload)
    with pytest.raises(EncodeError):
        build_echo_reply(request_pose())
    with pytest.raises(EncodeError):
        build_reflector_reply("PP", 0, 1, 0, 0)


def test_device_side_request_parser() -> None:
    req = decode_request(request_map(0, 1.5, -2.5, -math.pi / 2, 45).encode())
    assert isinstance(req.payload, MappingStart)
    assert (req.payload.x, req.payload.y) == (1.5, -2.5)
    assert req.payload.heading == pytest.approx(-math.pi / 2)
    assert req.payload.radius == 45


def test_typed_errors_for_bad_telegrams() -> None:
    good = request_pose().encode()
    with pytest.raises(TruncatedError):
        parse_telegram(good[:3])
    with pytest.raises(TruncatedError):
        parse_telegram(b"")
    with pytest.raises(BadSyncError):
        parse_telegram(b"\x03" + good[1:])
    with pytest.raises(ChecksumError):
        parse_telegram(good[:-1] + b"\x00")
    with pytest.raises(BadLengthError):
        parse_telegram(b"\x02\x04PP")
    with pytest.raises(BadLengthError):
        parse_telegram(good + b"\x00")
    with pytest.raises(UnknownCommandError):
        decode_request(encode_telegram("X", "Y"))
    with pytest.raises(UnknownCommandError):
        decode_reply(encode_telegram("P", "v"))  # Pv is a request only
    with pytest.raises(BadLengthError):
        decode_request(encode_telegram("P", "P", b"\x00"))
    with pytest.raises(UnknownCommandError):
        Request("XX")
    with pytest.raises(EncodeError):
        Request("PP", Count(1))
    with pytest.raises(EncodeError):
        Reply("PP", Empty())
    with pytest.raises(EncodeError):
        Request("PN", Count(256)).encode()
    with pytest.raises(EncodeError):
        encode_telegram("1", "P")
    with pytest.raises(EncodeError):
        encode_telegram("P", "P", bytes(251))
    with pytest.raises(EncodeError):
        request_change_reflector(0, 1, math.nan, 0.0)
