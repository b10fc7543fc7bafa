"""Property-based round trips for every NAV200 request and reply type."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from wire_strategies import error_reply_strategy, reply_strategy, request_strategy

from lgvtool.devices.nav200.nav200_commands import (
    COMMANDS,
    ERROR_REPLY_LEN,
    REPLIES,
    ErrorReply,
    Reply,
    Request,
    decode_reply,
    decode_request,
    reply_length,
    request_length,
)
from lgvtool.devices.nav200.nav200_framing import STX
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.devices.nav200.nav200_replies import build_pose_reply
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder, Nav200RequestDecoder
from lgvtool.wire.checksum import xor_bcc

ROUND_TRIP = settings(max_examples=25, deadline=None)


@pytest.mark.parametrize("code", sorted(COMMANDS))
@ROUND_TRIP
@given(data=st.data())
def test_request_round_trip(code: str, data: st.DataObject) -> None:
    request = data.draw(request_strategy(code))
    raw = request.encode()
    assert raw[0] == STX
    assert raw[1] == len(raw) == request_length(code)
    assert raw[2:4] == code.encode()
    assert xor_bcc(raw) == 0
    assert decode_request(raw) == request
    decoder = Nav200RequestDecoder()
    assert decoder.feed(raw) == [request]


@pytest.mark.parametrize("code", sorted(REPLIES))
@ROUND_TRIP
@given(data=st.data())
def test_reply_round_trip(code: str, data: st.DataObject) -> None:
    reply = data.draw(reply_strategy(code))
    raw = reply.encode()
    assert raw[1] == len(raw)
    expected_len = reply_length(code)
    if expected_len is not None:
        assert len(raw) == expected_len
    assert xor_bcc(raw) == 0
    assert decode_reply(raw) == reply
    assert Nav200ReplyDecoder().feed(raw) == [reply]


@ROUND_TRIP
@given(error_reply_strategy)
def test_error_reply_round_trip(reply: ErrorReply) -> None:
    raw = reply.encode()
    assert len(raw) == ERROR_REPLY_LEN
    assert decode_reply(raw) == reply


@ROUND_TRIP
@given(
    x=st.floats(-2_000_000, 2_000_000),
    y=st.floats(-2_000_000, 2_000_000),
    heading=st.floats(-100, 100),
    quality=st.integers(0, 255),
    used=st.integers(0, 255),
)
def test_pose_reply_si_round_trip(
    x: float, y: float, heading: float, quality: int, used: int
) -> None:
    reply = decode_reply(build_pose_reply(x, y, heading, quality, used))
    assert isinstance(reply, Reply) and isinstance(reply.payload, Pose)
    pose = reply.payload
    assert abs(pose.x - x) <= 0.0005 + 1e-9
    assert abs(pose.y - y) <= 0.0005 + 1e-9
    diff = math.remainder(pose.heading - heading, 2 * math.pi)
    assert abs(diff) <= math.pi / 65536 + 1e-9
    assert -math.pi < pose.heading <= math.pi
    assert pose.valid == (quality < 0xFE)


@ROUND_TRIP
@given(st.integers(-32768, 32767))
def test_heading_units_round_trip(raw_heading: int) -> None:
    pose = Pose(0, 0, raw_heading, 0, 0)
    again = Pose.from_si(0, 0, pose.heading, 0, 0)
    assert again.heading_raw == raw_heading


@ROUND_TRIP
@given(request_strategy())
def test_host_request_is_parsed_by_device(request: Request) -> None:
    assert Nav200RequestDecoder().feed(request.encode()) == [request]


@ROUND_TRIP
@given(st.lists(reply_strategy(), max_size=8))
def test_many_replies_in_one_chunk(replies: list[Reply | ErrorReply]) -> None:
    decoder = Nav200ReplyDecoder()
    assert decoder.feed(b"".join(r.encode() for r in replies)) == replies
    assert decoder.stats.total_errors == sum(isinstance(r, ErrorReply) for r in replies)
    assert decoder.stats.bytes_skipped == 0
