"""The worked examples of the NAV200 protocol description, byte for byte."""

from __future__ import annotations

import math

import pytest

from lgvtool.devices.nav200.nav200_commands import (
    COMMANDS,
    ErrorReply,
    Reply,
    Request,
    decode_reply,
    decode_request,
)
from lgvtool.devices.nav200.nav200_payloads import (
    ActionRadii,
    Count,
    Empty,
    Pose,
    ReflectorPosition,
    SpeedOmega,
)
from lgvtool.devices.nav200.nav200_replies import (
    build_ack_reply,
    build_error_reply,
    build_no_position_reply,
    build_pose_reply,
)
from lgvtool.devices.nav200.nav200_requests import (
    request_action_radii,
    request_download_end,
    request_pose,
    request_pose_with_speed,
    request_positioning_mean,
    request_positioning_mode,
    request_standby,
)

EXAMPLES: list[tuple[str, str, object]] = [
    ("PA request", "02 05 50 41 16", Request("PA")),
    ("PA reply", "02 05 50 41 16", Reply("PA")),
    ("SA request", "02 05 53 41 15", Request("SA")),
    ("PP request", "02 05 50 50 07", Request("PP")),
    ("PN n=4", "02 06 50 4E 04 1E", Request("PN", Count(4))),
    (
        "PO 1000/30000 mm",
        "02 0D 50 4F E8 03 00 00 30 75 00 00 BE",
        Request("PO", ActionRadii(1000, 30000)),
    ),
    ("Pw vx=500 mm/s", "02 0B 50 77 F4 01 00 00 00 00 DB", Request("Pw", SpeedOmega(500, 0, 0))),
    (
        "PP reply",
        "02 11 50 50 E8 03 00 00 30 F8 FF FF 00 40 64 04 10",
        Reply("PP", Pose(1000, -2000, 16384, 100, 4)),
    ),
    (
        "DR end marker",
        "02 0F 44 52 00 FF 00 00 00 00 00 00 00 00 E4",
        Request("DR", ReflectorPosition(0, 0xFF, 0, 0)),
    ),
]


@pytest.mark.parametrize(("name", "hex_bytes", "message"), EXAMPLES, ids=[e[0] for e in EXAMPLES])
def test_worked_example_encodes_and_decodes(name: str, hex_bytes: str, message: object) -> None:
    raw = bytes.fromhex(hex_bytes)
    assert isinstance(message, Request | Reply)
    assert message.encode() == raw
    decoded = (
        decode_request(raw) if isinstance(message, Request) else decode_reply(raw)
    )
    assert decoded == message


def test_worked_examples_from_si_builders() -> None:
    assert request_positioning_mode().encode() == bytes.fromhex("02 05 50 41 16")
    assert build_ack_reply("PA") == bytes.fromhex("02 05 50 41 16")
    assert build_ack_reply(request_positioning_mean(4)) == bytes.fromhex(
        "02 05 50 41 16"
    )
    assert request_standby().encode() == bytes.fromhex("02 05 53 41 15")
    assert request_pose().encode() == bytes.fromhex("02 05 50 50 07")
    assert request_positioning_mean(4).encode() == bytes.fromhex("02 06 50 4E 04 1E")
    assert request_action_radii(1.0, 30.0).encode() == bytes.fromhex(
        "02 0D 50 4F E8 03 00 00 30 75 00 00 BE"
    )
    assert request_pose_with_speed(0.5, 0.0, 0.0).encode() == bytes.fromhex(
        "02 0B 50 77 F4 01 00 00 00 00 DB"
    )
    assert build_pose_reply(1.0, -2.0, math.pi / 2, 100, 4) == bytes.fromhex(
        "02 11 50 50 E8 03 00 00 30 F8 FF FF 00 40 64 04 10"
    )
    assert request_download_end(0).encode() == bytes.fromhex(
        "02 0F 44 52 00 FF 00 00 00 00 00 00 00 00 E4"
    )


def test_pose_reply_units() -> None:
    reply = decode_reply(bytes.fromhex("02 11 50 50 E8 03 00 00 30 F8 FF FF 00 40 64 04 10"))
    assert isinstance(reply, Reply)
    pose = reply.payload
    assert isinstance(pose, Pose)
    assert pose.x == 1.0
    assert pose.y == -2.0
    assert pose.heading == pytest.approx(math.pi / 2, abs=1e-12)
    assert pose.quality == 100
    assert pose.reflectors_used == 4
    assert pose.valid


def test_every_empty_request_is_five_bytes() -> None:
    for code, spec in COMMANDS.items():
        if spec.request is Empty:
            raw = Request(code).encode()
            assert len(raw) == 5
            assert raw[1] == 5


def test_protocol_doc_examples() -> None:
    error = decode_reply(bytes.fromhex("02 09 50 45 50 01 07 09 41"))
    assert error == ErrorReply("P", "P", 1, 7, 9)
    assert build_error_reply("PP", 1, 7, 9) == bytes.fromhex("02 09 50 45 50 01 07 09 41")
    no_position = bytes.fromhex("02 11 50 50 00 00 00 00 00 00 00 00 00 00 FF 00 EC")
    assert build_no_position_reply() == no_position
    reply = decode_reply(no_position)
    assert isinstance(reply, Reply) and isinstance(reply.payload, Pose)
    assert not reply.payload.valid
