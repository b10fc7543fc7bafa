"""The NAV200 reply matcher: replies matched to pending requests."""

from __future__ import annotations

from lgvtool.devices.nav200.nav200_commands import ErrorReply
from lgvtool.devices.nav200.nav200_matcher import Nav200ReplyMatcher
from lgvtool.devices.nav200.nav200_replies import (
    build_ack_reply,
    build_error_reply,
    build_mapping_reply,
    build_pose_reply,
    build_radius_reply,
)
from lgvtool.devices.nav200.nav200_requests import (
    request_map_scans,
    request_pose,
    request_pose_with_speed,
    request_positioning_mean,
    request_positioning_mode,
    request_set_reflector_radius,
    request_upload_next,
)


def test_pose_polling() -> None:
    session = Nav200ReplyMatcher()
    assert session.send(request_pose_with_speed(0.3, 0.0, 0.1)) == (
        request_pose_with_speed(0.3, 0.0, 0.1).encode()
    )
    reply = build_pose_reply(1.0, 2.0, 0.5, 100, 6)
    assert session.feed(reply[:7]) == []
    (exchange,) = session.feed(reply[7:])
    assert exchange.matched
    assert exchange.request is not None and exchange.request.code == "Pw"
    assert exchange.reply.code == "PP"
    assert session.pending is None
    assert session.stats.total_errors == 0


def test_replies_with_other_letters_match() -> None:
    session = Nav200ReplyMatcher()
    pairs = [
        (request_set_reflector_radius(0, 45), build_radius_reply(0, 45)),
        (request_positioning_mean(4), build_ack_reply("PA")),
        (request_map_scans(0, 2, 0, 0, 0, 45), build_mapping_reply(0, 12)),
    ]
    for request, reply in pairs:
        session.send(request)
        (exchange,) = session.feed(reply)
        assert exchange.request == request
    assert session.stats.unexpected_reply == 0


def test_wrong_reply_is_counted_not_raised() -> None:
    session = Nav200ReplyMatcher()
    session.send(request_pose())
    (exchange,) = session.feed(build_ack_reply("SA"))
    assert not exchange.matched
    assert session.stats.unexpected_reply == 1
    assert session.pending is not None  # still waiting for the pose
    (event,) = session.pop_events()
    assert event.kind == "unexpected_reply"
    assert event.details == {"reply": "SA", "expected_reply": "PP"}
    (exchange,) = session.feed(build_pose_reply(0, 0, 0, 50, 3))
    assert exchange.matched


def test_unsolicited_reply_and_unanswered_request() -> None:
    session = Nav200ReplyMatcher()
    (exchange,) = session.feed(build_pose_reply(0, 0, 0, 50, 3))
    assert exchange.request is None
    session.send(request_pose())
    session.send(request_pose())
    assert session.stats.unanswered == 1
    assert session.cancel() == request_pose()
    assert session.stats.unanswered == 2
    assert session.cancel() is None
    kinds = [e.kind for e in session.pop_events()]
    assert kinds == ["unexpected_reply", "unanswered", "unanswered"]


def test_error_reply_answers_pending_request() -> None:
    session = Nav200ReplyMatcher()
    request = request_upload_next(0)
    session.send(request)
    (exchange,) = session.feed(build_error_reply(request, 1, 5, 10))
    assert exchange.request == request
    assert isinstance(exchange.reply, ErrorReply)
    assert exchange.reply.detail_meaning == "all reflectors transferred"
    assert session.stats.error_replies == 1


def test_redecoding_logged_traffic() -> None:
    session = Nav200ReplyMatcher()
    tx = request_positioning_mode().encode() + request_pose().encode()
    # The host wrote PA; the device answered; then PP and its answer, in separate chunks.
    assert [r.code for r in session.sent(tx[:5])] == ["PA"]
    (first,) = session.feed(build_ack_reply("PA"))
    assert [r.code for r in session.sent(tx[5:])] == ["PP"]
    (second,) = session.feed(build_pose_reply(3.0, 4.0, -1.0, 80, 5))
    assert first.matched and second.matched
    assert session.flush() == []
    assert session.request_stats.frames == 2
