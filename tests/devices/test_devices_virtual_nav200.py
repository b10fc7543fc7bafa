"""The virtual NAV200: modes, error replies, the upload loop, the download, speed input and
the sliding mean."""

from __future__ import annotations

import math

import pytest
from devices_helpers import circle_playback

from lgvtool.config import Vehicle
from lgvtool.devices.nav200.nav200_commands import (
    DeviceReply,
    ErrorReply,
    Reply,
    Request,
    decode_reply,
)
from lgvtool.devices.nav200.nav200_device import PoseFix
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.devices.nav200.nav200_requests import (
    request_action_radii,
    request_download_end,
    request_download_mode,
    request_download_reflector,
    request_pose,
    request_pose_with_speed,
    request_positioning_mean,
    request_positioning_mode,
    request_upload_mode,
    request_upload_next,
    request_version,
)
from lgvtool.sim.emulate import Playback, playback_from_scenario
from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200


def ask(dev: VirtualNav200, request: Request, t: float = 1.0) -> DeviceReply:
    (reply,) = dev.feed(request.encode(), t)
    return decode_reply(reply)


def test_wrong_mode_gets_an_error_reply() -> None:
    dev = VirtualNav200(circle_playback(5.0))
    assert dev.mode == "standby"
    err = ask(dev, request_pose())
    assert isinstance(err, ErrorReply)
    assert (err.rejected_function, err.error_class, err.group, err.detail) == ("P", 1, 2, 3)
    assert isinstance(ask(dev, request_positioning_mode()), Reply)
    pose = ask(dev, request_pose(), t=2.0)
    assert isinstance(pose, Reply) and pose.code == "PP"
    fix = dev.playback.pose_at(2.0)
    assert fix is not None
    assert isinstance(pose.payload, Pose)
    assert abs(pose.payload.x - fix.x) < 0.001 and pose.payload.valid
    err = ask(dev, request_version())
    assert isinstance(err, ErrorReply) and err.group == 7


def test_upload_loop_end_marker_then_all_transferred() -> None:
    pb = circle_playback(1.0)
    dev = VirtualNav200(pb)
    ask(dev, request_upload_mode())
    numbers = []
    for _ in range(len(pb.reflectors)):
        r = ask(dev, request_upload_next(0))
        numbers.append(r.payload.number)
    assert numbers == [r.id for r in pb.reflectors]
    end = ask(dev, request_upload_next(0))
    assert end.payload.number == 0xFF
    done = ask(dev, request_upload_next(0))
    assert isinstance(done, ErrorReply) and done.detail == 10


def test_download_replaces_the_layer_and_settings_are_checked() -> None:
    dev = VirtualNav200(circle_playback(1.0))
    ask(dev, request_download_mode())
    ask(dev, request_download_reflector(0, 1, 1.0, 2.0))
    ask(dev, request_download_reflector(0, 2, 3.0, 4.0))
    ask(dev, request_download_end(0))
    assert [(r.id, r.x, r.y) for r in dev.reflectors()] == [(1, 1.0, 2.0), (2, 3.0, 4.0)]
    ask(dev, request_positioning_mode())
    bad = ask(dev, request_action_radii(5.0, 1.0))
    assert isinstance(bad, ErrorReply) and bad.detail == 13
    ok = ask(dev, request_action_radii(1.0, 5.0))
    assert isinstance(ok, Reply) and ok.code == "PO"
    dev.reset()
    assert dev.mode == "standby" and len(dev.reflectors()) == 2


def _o_radial_error(fix: PoseFix, pb_centre: tuple[float, float], radius: float) -> float:
    """Distance (m) of O, converted from the reported head pose, from the driven circle."""
    veh = Vehicle()
    ox = fix.x - veh.nav_x * math.cos(fix.heading) + veh.nav_y * math.sin(fix.heading)
    oy = fix.y - veh.nav_x * math.sin(fix.heading) - veh.nav_y * math.cos(fix.heading)
    return math.hypot(ox - pb_centre[0], oy - pb_centre[1]) - radius


@pytest.fixture(scope="module")
def circle_run() -> tuple[Playback, tuple[float, float], float]:
    """A noise-free simulated paper-circle run, its circle centre and radius (m)."""
    from lgvtool.sim.simulation import simulate

    overrides = {"sim.world": "ideal", "sim.noise": False, "site.survey_sigma_mm": 0.0,
                 "nav.angle_step_deg": 0.0}
    ref = simulate("paper-circle", seed=1, duration=60.0, overrides=overrides).plan.reference
    pb = playback_from_scenario("paper-circle", seed=1, duration=60.0, overrides=overrides)
    return pb, (ref["centre_x"], ref["centre_y"]), ref["radius"]


def _head_speed() -> tuple[float, float, float]:
    """The head's velocity on the paper's circle: vx, vy (m/s, vehicle axes), omega (rad/s)."""
    veh, d = Vehicle(), math.radians(60.0)
    v, w = 0.36 * math.cos(d), 0.36 * math.sin(d) / veh.h
    return v - w * veh.nav_y, w * veh.nav_x, w


def test_speed_input_compensates_the_turning_skew(circle_run) -> None:
    pb, centre, radius = circle_run
    assert pb.per_revolution
    dev = VirtualNav200(pb)
    ask(dev, request_positioning_mode(), t=0.0)
    times = [20.0 + 0.45 * i for i in range(40)]
    plain = [_o_radial_error(dev.current_fix(t), centre, radius)
             for t in times if isinstance(ask(dev, request_pose(), t=t), Reply)]
    vx, vy, w = _head_speed()
    fast = []
    for t in times:
        reply = ask(dev, request_pose_with_speed(vx, vy, w), t=t)
        assert isinstance(reply, Reply) and isinstance(reply.payload, Pose)
        assert reply.payload.valid
        fast.append(_o_radial_error(dev.current_fix(t), centre, radius))
    assert dev.speed_inputs and dev.speed_inputs[0][1] == "Pw"
    assert abs(sum(plain) / len(plain)) > 0.03  # the skew: a bias of tens of mm
    assert max(abs(e) for e in fast[1:]) < 0.002  # compensated from the first speed input on
    # a stale speed input is not used: a PP 1 s later gets the skewed solution again
    t = times[-1] + 1.0
    ask(dev, request_pose(), t=t)
    assert abs(_o_radial_error(dev.current_fix(t), centre, radius)) > 0.03


def test_sliding_mean_averages_the_last_revolutions(circle_run) -> None:
    pb = circle_run[0]
    dev = VirtualNav200(pb)
    ask(dev, request_positioning_mean(4), t=0.0)
    t = 30.0
    reply = ask(dev, request_pose(), t=t)
    i = pb.index_at(t)
    last = pb.poses[i - 3:i + 1]
    assert reply.payload.x == pytest.approx(sum(f.x for f in last) / 4, abs=0.0006)
    assert reply.payload.y == pytest.approx(sum(f.y for f in last) / 4, abs=0.0006)
    assert abs(reply.payload.x - pb.poses[i].x) > 0.005  # not the newest alone
    ask(dev, request_positioning_mode(), t=t)  # PA: back to a mean of one
    assert ask(dev, request_pose(), t=t).payload.x == pytest.approx(pb.poses[i].x,
                                                                          abs=0.0006)
