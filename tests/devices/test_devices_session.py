"""The NAV200 host session against the virtual NAV200, with made-up times and no I/O."""

from __future__ import annotations

import math

from devices_helpers import circle_playback

from lgvtool.devices.nav200.nav200_commands import Request
from lgvtool.devices.nav200.nav200_payloads import SpeedOmega
from lgvtool.devices.nav200.nav200_replies import (
    build_ack_reply,
    build_error_reply,
    build_serial_reply,
)
from lgvtool.devices.nav200.nav200_session import (
    DeviceIdentity,
    MapUploaded,
    Nav200Session,
    Nav200Settings,
    PoseReceived,
)
from lgvtool.devices.session_events import DeviceSilent, PositioningEntered
from lgvtool.json_types import as_number
from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200
from lgvtool.wire.decode_events import DecodeEvent

PLAYBACK = circle_playback(10.0)


class Wire:
    """Session and device joined by a perfect line; the device answers after ``delay`` s."""

    def __init__(self, settings: Nav200Settings | None = None, delay: float = 0.01) -> None:
        self.session = Nav200Session(settings)
        self.device = VirtualNav200(PLAYBACK)
        self.delay = delay
        self.events: list = []
        self.sent: list[str] = []
        self.mute = False

    def run(self, t0: float, t1: float, dt: float = 0.005) -> float:
        t = t0
        while t < t1:
            req = self.session.poll(t)
            if req is not None:
                self.sent.append(req.code)
                replies = self.device.feed(req.encode(), t)
                if not self.mute:
                    for r in replies:
                        self.session.feed(r, t + self.delay)
            self.events += self.session.pop_events()
            t += dt
        return t

    def of(self, kind: type) -> list:
        return [e for e in self.events if isinstance(e, kind)]

    def diags(self, kind: str) -> list[DecodeEvent]:
        return [e for e in self.events if isinstance(e, DecodeEvent) and e.kind == kind]


def test_startup_sequence_uploads_map_applies_settings_and_polls() -> None:
    s = Nav200Settings(poll_period=0.45, sliding_mean=4, action_radii=(1.0, 30.0),
                       nearest_reflectors=6)
    w = Wire(s)
    w.session.start(0.0)
    w.run(0.0, 2.0)
    n_map = len(PLAYBACK.reflectors)
    assert w.sent[:3] == ["SA", "SV", "SS"]
    assert w.sent[3:5] == ["UA", "UR"]
    # every reflector, then the end marker, then back to standby and into positioning
    assert w.sent.count("UR") == n_map + 1
    i = w.sent.index("SA", 3)
    assert w.sent[i:i + 5] == ["SA", "PN", "PO", "PC", "PP"]
    (ident,) = w.of(DeviceIdentity)
    assert ident.version == "2.4.1" and ident.serial == 20417
    (up,) = w.of(MapUploaded)
    assert [rp.number for rp in up.reflectors] == [r.id for r in PLAYBACK.reflectors]
    assert math.isclose(up.reflectors[0].x, PLAYBACK.reflectors[0].x, abs_tol=1e-3)
    (entered,) = w.of(PositioningEntered)
    assert entered.settings["sliding_mean"] == 4 and entered.settings["entered_with"] == "PN"
    assert w.device.mode == "positioning"
    # polled every 0.45 s from entering positioning: t = 0..2 s gives 5 requests
    assert w.sent.count("PP") in (4, 5)
    poses = w.of(PoseReceived)
    assert len(poses) == w.sent.count("PP") and all(p.pose.valid for p in poses)
    assert all(math.isclose(p.round_trip, 0.01, abs_tol=1e-9) for p in poses)


def test_speed_input_uses_pw_with_rev_units() -> None:
    w = Wire(Nav200Settings(speed_input=True, upload_map=False))
    w.session.start(0.0)
    w.session.set_speed(0.5, 0.2, 0.1, 0.0)
    w.run(0.0, 0.3)
    assert "Pw" in w.sent and "PP" not in w.sent
    _, code, payload = w.device.speed_inputs[0]
    assert code == "Pw"
    assert isinstance(payload, SpeedOmega)
    assert (payload.vx_mm_s, payload.vy_mm_s) == (500, 200)
    assert payload.omega_raw == round(0.1 * 32768 / math.pi)
    # stale odometry: plain PP
    w.run(0.3, 1.6)
    assert w.sent[-1] == "PP"


def test_device_reset_error_reply_leads_back_into_positioning() -> None:
    w = Wire(Nav200Settings(upload_map=False, poll_period=0.2))
    w.session.start(0.0)
    w.run(0.0, 1.0)
    before = len(w.of(PoseReceived))
    w.device.reset()  # power cycle: standby
    w.run(1.0, 2.0)
    lost = w.diags("positioning_lost")
    assert len(lost) == 1 and lost[0].details["detail"] == 3  # wrong command
    assert [d for d in w.events if isinstance(d, DecodeEvent) and d.kind == "device_error"]
    assert w.device.mode == "positioning"
    assert len(w.of(PositioningEntered)) == 2
    assert len(w.of(PoseReceived)) > before + 2
    # the map was not uploaded again: the serial number did not change
    assert w.sent.count("UA") == 0


def test_silent_device_backs_off_and_comes_back() -> None:
    s = Nav200Settings(upload_map=False, poll_period=0.2, reply_timeout=0.5, silent_after=3,
                       retry_initial=0.5, retry_max=2.0)
    w = Wire(s)
    w.session.start(0.0)
    w.run(0.0, 1.0)
    w.mute = True
    t = w.run(1.0, 9.0)
    (silent,) = w.diags("device_silent")
    assert silent.details["timeouts"] == 3
    assert len(w.of(DeviceSilent)) == 1
    assert w.session.state == "silent"
    # retries back off: 0.5, 1, 2, 2 ... s apart (plus the 0.5 s timeout each)
    retries = w.sent[w.sent.index("SA", 1):]
    assert 3 <= retries.count("SA") <= 6
    w.mute = False
    w.run(t, t + 4.0)
    (back,) = w.diags("device_back")
    assert as_number(back.details["gap_s"]) > 7.0
    assert w.session.state == "positioning"
    assert w.of(PoseReceived)[-1].pose.valid


def test_refused_sliding_mean_falls_back_to_pa() -> None:
    w = Wire(Nav200Settings(sliding_mean=300 % 256, upload_map=False))
    # a device that refuses PN: answer PN with an error reply
    real = w.device.answer

    def answer(request: Request, t: float) -> bytes:
        if request.code == "PN":
            return build_error_reply(request, 1, 7, 2)
        return real(request, t)

    w.device.answer = answer  # type: ignore[method-assign]
    w.session.start(0.0)
    w.run(0.0, 0.5)
    assert w.diags("setting_refused")
    assert "PA" in w.sent and w.session.state == "positioning"
    assert w.of(PositioningEntered)[0].settings["entered_with"] == "PA"


def test_unexpected_and_garbled_replies_are_diagnosed() -> None:
    session = Nav200Session(Nav200Settings(upload_map=False))
    session.start(0.0)
    req = session.poll(0.0)
    assert req is not None and req.code == "SA"
    # garbage, a reply nobody asked for, then the right reply
    session.feed(b"\x02\x03\xffnoise" + build_serial_reply(7) + build_ack_reply("SA"),
                 0.01)
    kinds = [e.kind for e in session.pop_events() if isinstance(e, DecodeEvent)]
    assert "unexpected_reply" in kinds and "bytes_skipped" in kinds
    nxt = session.poll(0.02)
    assert nxt is not None and nxt.code == "SV"


def test_timeout_resends_a_startup_step() -> None:
    session = Nav200Session(Nav200Settings(reply_timeout=0.5))
    session.start(0.0)
    assert session.poll(0.0).code == "SA"
    assert session.poll(0.4) is None
    assert session.next_deadline(0.4) == 0.5
    again = session.poll(0.5)
    assert again is not None and again.code == "SA"
    assert [e.kind for e in session.pop_events()] == ["unanswered"]


def test_after_a_device_reset_the_map_is_read_again_and_compared() -> None:
    w = Wire(Nav200Settings(poll_period=0.2))
    w.session.start(0.0)
    w.run(0.0, 2.0)
    assert w.sent.count("UA") == 1 and len(w.of(MapUploaded)) == 1
    held = w.session.map
    w.device.reset()  # power cycle: standby, the stored map is kept
    w.run(2.0, 4.0)
    assert w.sent.count("UA") == 2
    assert len(w.of(MapUploaded)) == 2
    assert len(w.diags("map_verified")) == 1 and not w.diags("map_changed")
    assert w.session.map == held
    # the device comes back holding another map: the recorder says so and uses it
    w.device.store.pop(next(iter(w.device.store)))
    w.device.reset()
    w.run(4.0, 6.0)
    (changed,) = w.diags("map_changed")
    assert changed.details["reflectors"] == as_number(changed.details["before"]) - 1
    assert w.session.map is not None and len(w.session.map) == len(held or ()) - 1
    assert w.device.mode == "positioning"


def test_a_requested_layout_is_downloaded_once_between_two_uploads() -> None:
    """Nothing is written unless asked; asked, the map is read before, downloaded once (DA,
    DR x n, the end marker) and read back, and a device reset does not write it again."""
    layout = ((1, 2.0, 3.0), (2, 10.0, 3.0), (5, 6.0, 9.5))
    w = Wire(Nav200Settings(poll_period=0.2, write_layout=layout))
    w.session.start(0.0)
    w.run(0.0, 3.0)
    assert w.sent.count("DA") == 1 and w.sent.count("DR") == len(layout) + 1
    assert w.sent.index("UA") < w.sent.index("DA") < len(w.sent) - 1 - w.sent[::-1].index("UA")
    before, after = w.of(MapUploaded)
    assert len(before.reflectors) == len(PLAYBACK.reflectors)
    assert [(rp.number, rp.x, rp.y) for rp in after.reflectors] == list(layout)
    assert [e.kind for e in w.events if isinstance(e, DecodeEvent) and e.kind.startswith(
        "layout_")] == ["layout_erasing", "layout_written"]
    assert w.device.mode == "positioning"
    w.device.reset()
    w.run(3.0, 5.0)
    assert w.sent.count("DA") == 1  # not written again
    assert len(w.of(MapUploaded)) == 3 and len(w.diags("map_verified")) == 1


def test_without_a_requested_layout_nothing_is_downloaded() -> None:
    w = Wire(Nav200Settings(poll_period=0.2))
    w.session.start(0.0)
    w.run(0.0, 2.0)
    assert "DA" not in w.sent and "DR" not in w.sent
