"""MCU stream decoding, sequence gaps, and the motion estimate for speed input."""

from __future__ import annotations

import math

from devices_helpers import circle_playback

from lgvtool.config import Vehicle
from lgvtool.devices.head_speed import head_velocity
from lgvtool.devices.mcu.mcu_frame import McuFrame, McuStatus, decode_mcu_frame
from lgvtool.devices.mcu.mcu_session import McuLink, motion_between


def test_frames_in_any_chunking_and_gaps_reported() -> None:
    chunks = [c.data for c in circle_playback(2.0).mcu]
    stream = b"".join(chunks[:5]) + b"".join(chunks[8:])  # frames 5, 6, 7 lost
    link = McuLink()
    frames = []
    for i in range(0, len(stream), 7):
        frames += link.feed(stream[i:i + 7])
    assert [f.seq for f in frames] == [*range(5), *range(8, len(chunks))]
    events = link.pop_events()
    (gap,) = [e for e in events if e.kind == "seq_gap"]
    assert gap.details["missing_frames"] == 3 and gap.details["first_missing_seq"] == 5
    assert link.stats.frames_missing == 3


def test_motion_matches_the_circle_drive() -> None:
    veh = Vehicle()
    chunks = circle_playback(2.0).mcu
    link = McuLink(veh)
    for c in chunks:
        link.feed(c.data)
    m = link.motion
    assert m is not None
    v_d, delta = 0.36, math.radians(60)
    assert math.isclose(m.v, v_d * math.cos(delta), abs_tol=0.005)
    assert math.isclose(m.omega, v_d * math.sin(delta) / veh.h, abs_tol=0.002)
    vx, vy = head_velocity(m, veh)
    assert math.isclose(vx, m.v) and math.isclose(vy, m.omega * veh.nav_x)


def test_motion_falls_back_on_faults() -> None:
    veh = Vehicle()
    a, b = (decode_mcu_frame(c.data) for c in circle_playback(1.0).mcu[:2])
    gyro_bad = McuFrame(**{**b.__dict__, "status": int(McuStatus.GYRO_FAULT)})
    m = motion_between(a, gyro_bad, veh)
    assert m is not None
    good = motion_between(a, b, veh)
    assert good is not None and math.isclose(m.omega, good.omega, rel_tol=0.05)
    enc_bad = McuFrame(**{**b.__dict__, "status": int(McuStatus.ENC_LEFT_FAULT)})
    m2 = motion_between(a, enc_bad, veh)
    assert m2 is not None and math.isclose(m2.v, 0.36 * math.cos(math.radians(60)), abs_tol=1e-3)
    both = McuFrame(**{**b.__dict__, "status": int(McuStatus.ENC_LEFT_FAULT | McuStatus.GYRO_FAULT)})
    assert motion_between(a, both, veh) is None
    assert motion_between(b, a, veh) is None  # clock went backwards (wraps to a huge step)
