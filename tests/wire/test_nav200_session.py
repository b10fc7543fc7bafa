"""The NAV200 host session: replies matched to pending requests."""

from __future__ import annotations

from lgvtool.devices.nav200 import nav200_protocol as nav200
from lgvtool.devices.nav200.nav200_protocol import ErrorReply, Nav200ReplyMatcher


def test_pose_polling() -> None:
    session = Nav200ReplyMatcher()
    assert session.send(nav200.request_pose_with_speed(0.3, 0.0, 0.1)) == (
        nav200.request_pose_with_speed(0.3, 0.0, 0.1).encode()
    )
    reply = nav200.build_pose_reply(1.0, 2.0, 0.5, 100, 6)
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
        (nav200.request_set_reflector_radius(0, 45), nav200.build_radius_reply(0, 45)),
        (nav200.request_positioning_mean(4), nav200.build_ack_reply("PA")),
        (nav200.request_map_scans(0, 2, 0, 0, 0, 45), nav200.build_mapping_reply(0, 12)),
    ]
    for request, reply in pairs:
        session.send(request)
        (exchange,) = session.feed(reply)
        assert exchange.request == request
    assert session.stats.unexpected_reply == 0


def test_wrong_reply_is_counted_not_raised() -> None:
    session = Nav200ReplyMatcher()
    session.send(nav200.request_pose())
    (exchange,) = session.feed(nav200.build_ack_reply("SA"))
    assert not exchange.matched
    assert session.stats.unexpected_reply == 1
    assert session.pending is not None  # still waiting for the pose
    (event,) = session.pop_events()
    assert event.kind == "unexpected_reply"
    assert event.details == {"reply": "SA", "expected_reply": "PP"}
    (exchange,) = session.feed(nav200.build_pose_reply(0, 0, 0, 50, 3))
    assert exchange.matched


def test_unsolicited_reply_and_unanswered_request() -> None:
    session = Nav200ReplyMatcher()
    (exchange,) = session.feed(nav200.build_pose_reply(0, 0, 0, 50, 3))
    assert exchange.request is None
    session.send(nav200.request_pose())
    session.send(nav200.request_pose())
    assert session.stats.unanswered == 1
    assert session.cancel() == nav200.request_pose()
    assert session.stats.unanswered == 2
    assert session.cancel() is None
    kinds = [e.kind for e in session.pop_events()]
    assert kinds == ["unexpected_reply", "unanswered", "unanswered"]


def test_error_reply_answers_pending_request() -> None:
    session = Nav200ReplyMatcher()
    request = nav200.request_upload_next(0)
    session.send(request)
    (exchange,) = session.feed(nav200.build_error_reply(request, 1, 5, 10))
    assert exchange.request == request
    assert isinstance(exchange.reply, ErrorReply)
    assert exchange.reply.detail_meaning == "all reflectors transferred"
    assert session.stats.error_replies == 1


def test_redecoding_logged_traffic() -> None:
    session = Nav200ReplyMatcher()
    tx = nav200.request_positioning_mode().encode() + nav200.request_pose().encode()
    # The host wrote PA; the device answered; then PP and its answer, in separate chunks.
    assert [r.code for r in session.sent(tx[:5])] == ["PA"]
    (first,) = session.feed(nav200.build_ack_reply("PA"))
    assert [r.code for r in session.sent(tx[5:])] == ["PP"]
    (second,) = session.feed(nav200.build_pose_reply(3.0, 4.0, -1.0, 80, 5))
    assert first.matched and second.matched
    assert session.flush() == []
    assert session.request_stats.frames == 2
