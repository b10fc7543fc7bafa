"""The virtual NAV200: modes, error replies, the upload loop, the download."""

from __future__ import annotations

from devices_helpers import circle_playback

from lgvtool.sim.emulate import VirtualNav200
from lgvtool.wire import nav200 as proto


def ask(dev: VirtualNav200, request: proto.Request, t: float = 1.0) -> proto.AnyReply:
    (reply,) = dev.feed(request.encode(), t)
    return proto.decode_reply(reply)


def test_wrong_mode_gets_an_error_reply() -> None:
    dev = VirtualNav200(circle_playback(5.0))
    assert dev.mode == "standby"
    err = ask(dev, proto.request_pose())
    assert isinstance(err, proto.ErrorReply)
    assert (err.rejected_function, err.error_class, err.group, err.detail) == ("P", 1, 2, 3)
    assert isinstance(ask(dev, proto.request_positioning_mode()), proto.Reply)
    pose = ask(dev, proto.request_pose(), t=2.0)
    assert isinstance(pose, proto.Reply) and pose.code == "PP"
    fix = dev.playback.pose_at(2.0)
    assert fix is not None
    assert abs(pose.payload.x - fix.x) < 0.001 and pose.payload.valid
    err = ask(dev, proto.request_version())
    assert isinstance(err, proto.ErrorReply) and err.group == 7


def test_upload_loop_end_marker_then_all_transferred() -> None:
    pb = circle_playback(1.0)
    dev = VirtualNav200(pb)
    ask(dev, proto.request_upload_mode())
    numbers = []
    for _ in range(len(pb.reflectors)):
        r = ask(dev, proto.request_upload_next(0))
        numbers.append(r.payload.number)
    assert numbers == [r.id for r in pb.reflectors]
    end = ask(dev, proto.request_upload_next(0))
    assert end.payload.number == 0xFF
    done = ask(dev, proto.request_upload_next(0))
    assert isinstance(done, proto.ErrorReply) and done.detail == 10


def test_download_replaces_the_layer_and_settings_are_checked() -> None:
    dev = VirtualNav200(circle_playback(1.0))
    ask(dev, proto.request_download_mode())
    ask(dev, proto.request_download_reflector(0, 1, 1.0, 2.0))
    ask(dev, proto.request_download_reflector(0, 2, 3.0, 4.0))
    ask(dev, proto.request_download_end(0))
    assert [(r.id, r.x, r.y) for r in dev.reflectors()] == [(1, 1.0, 2.0), (2, 3.0, 4.0)]
    ask(dev, proto.request_positioning_mode())
    bad = ask(dev, proto.request_action_radii(5.0, 1.0))
    assert isinstance(bad, proto.ErrorReply) and bad.detail == 13
    ok = ask(dev, proto.request_action_radii(1.0, 5.0))
    assert isinstance(ok, proto.Reply) and ok.code == "PO"
    dev.reset()
    assert dev.mode == "standby" and len(dev.reflectors()) == 2
