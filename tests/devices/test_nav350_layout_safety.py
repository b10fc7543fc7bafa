"""The NAV350 recorder never harms the device: no layout written unless asked, a requested
write done once per recording, the stored layout read into the log, a mapping run from a stand,
and a clock read that fails given up after a bounded number of tries per device session."""

from __future__ import annotations

import base64
import math
from collections.abc import Sequence

import pytest
from test_nav350_device import device, revolutions, run_session

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_device import Nav350Device, Observation, Revolution, RevolutionSource
from lgvtool.devices.nav350.nav350_session import (
    LayoutRead,
    LayoutWritten,
    MappingDone,
    MapStand,
    Nav350Session,
    Nav350Settings,
    NavigationEntered,
    PoseDataReceived,
)
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder

_WRITES = {"mNLAYEraseLayout", "mNLAYAddLandmark", "mNLAYStoreLayout"}


def _kinds(events: Sequence[object]) -> list[str]:
    return [getattr(e, "kind", "") for e in events]


def _sessions(session: Nav350Session, dev: Nav350Device, count: int, seconds: float,
              moving_until: float = -1.0) -> list[object]:
    """``count`` device sessions of ``seconds`` s each over an ideal link (the device power
    cycled between them), time stepped by 1 ms; the vehicle moves until ``moving_until`` s.
    Returns the session's events."""
    dec = Nav350StreamDecoder()
    events: list[object] = []
    t = 0.0
    for _ in range(count):
        session.link_up(t)
        end = t + seconds
        while t < end:
            session.vehicle_moving(t < moving_until)
            req = session.poll(t)
            if req is not None:
                for r in dec.feed(req.encode()):
                    for raw in dev.handle(r, t):
                        session.feed(raw, t)
            for raw in dev.due(t):
                session.feed(raw, t)
            events += session.pop_events()
            t = round(t + 0.001, 6)
        session.link_down(t)
        dev.reset()
    return events


def test_by_default_the_stored_layout_is_read_and_nothing_is_written() -> None:
    dev = device()
    before = dev.layout
    events = run_session(dev, Nav350Settings(), 3.0)
    assert any(isinstance(e, NavigationEntered) for e in events)
    names = [r.name for _, r in dev.requests]
    assert not _WRITES & set(names)
    assert dev.layout == before
    read = [e for e in events if isinstance(e, LayoutRead)]
    assert len(read) == 1 and read[0].when == "before"
    assert [(m.global_id, m.x_mm, m.y_mm) for m in read[0].landmarks] == [
        (g, m.x_mm, m.y_mm) for g, m in sorted(before.items())]
    # the dialect is asked for as the vendor driver does, right after the login
    assert names[:2] == ["SetAccessMode", "EIHstCola"]


def test_no_read_layout_reads_nothing() -> None:
    dev = device()
    events = run_session(dev, Nav350Settings(read_layout=False), 2.0)
    assert not any(isinstance(e, LayoutRead) for e in events)
    names = {r.name for _, r in dev.requests}
    assert not names & ({"mNLAYGetLayer", "mNLAYGetLandmark"} | _WRITES)


def test_a_requested_write_is_done_once_even_after_a_reconnect() -> None:
    dev = device()
    layout = tuple(tg.LayoutLandmark(1000 * i, 2000, 1, 1, 80, (0,)) for i in range(5))
    session = Nav350Session(Nav350Settings(write_layout=layout))
    events = _sessions(session, dev, 2, 3.0)  # the link drops after 3 s and comes back
    names = [r.name for _, r in dev.requests]
    assert names.count("mNLAYEraseLayout") == 1
    assert names.count("mNLAYStoreLayout") == 1
    written = [e for e in events if isinstance(e, LayoutWritten)]
    assert len(written) == 1 and len(written[0].ids) == 5
    reads = [(e.when, len(e.landmarks)) for e in events if isinstance(e, LayoutRead)]
    # before and after the write; after the reconnect only read again
    assert reads[:2] == [("before", 4), ("after", 5)] and reads[2:] == [("before", 5)]
    assert sum(isinstance(e, NavigationEntered) for e in events) == 2


def _still_source(n: int = 200, period: float = 0.125) -> tuple[RevolutionSource, list[tuple[float, float]]]:
    """A head standing still at (2, 1) m, heading 30 deg, seeing four reflectors."""
    hx, hy, hh = 2.0, 1.0, math.radians(30.0)
    reflectors = [(6.0, 1.0), (2.0, 7.0), (-3.0, -1.0), (5.0, -4.0)]
    obs = []
    for x, y in reflectors:
        r = math.hypot(x - hx, y - hy)
        obs.append(Observation(r, math.atan2(y - hy, x - hx) - hh, 0.01, -1))
    revs = [Revolution(k * period, period, (k + 1) * period + 0.04, hx, hy, hh, True, 90, 4,
                       tuple(obs)) for k in range(n)]
    return RevolutionSource(revs), reflectors


def test_a_mapping_run_finds_the_reflectors_seen_from_the_stand() -> None:
    source, truth = _still_source()
    dev = Nav350Device(source, {i: tg.LayoutLandmark(1000 * i, 0) for i in range(1, 5)})
    stand = MapStand(2000, 1000, 30_000, mean=8)
    events = run_session(dev, Nav350Settings(map_at=stand), 6.0)
    done = [e for e in events if isinstance(e, MappingDone)]
    assert len(done) == 1 and done[0].error_code == 0
    found = sorted(done[0].landmarks)
    assert found == sorted((round(x * 1000), round(y * 1000)) for x, y in truth)
    names = [r.name for _, r in dev.requests]
    assert names.index("NMAPMapCfg") < names.index("mNMAPDoMapping") < names.index(
        "mNPOSGetData")
    assert not _WRITES & set(names)  # mapping reports; it writes nothing
    assert any(isinstance(e, PoseDataReceived) for e in events)  # then navigates


def test_mapping_waits_while_the_vehicle_moves() -> None:
    source, _ = _still_source()
    dev = Nav350Device(source, {})
    session = Nav350Session(Nav350Settings(map_at=MapStand(2000, 1000, 30_000, mean=4)))
    events = _sessions(session, dev, 1, 4.0, moving_until=2.0)
    asked_while_moving = any(t < 2.0 and r.name == "mNMAPDoMapping" for t, r in dev.requests)
    assert not asked_while_moving
    assert _kinds(events).count("mapping_waits") == 1
    assert any(isinstance(e, MappingDone) and e.error_code == 0 for e in events)


def test_a_mapping_reply_with_too_large_a_count_gives_one_diagnostic_and_navigation_goes_on() -> None:
    class _BadMapping(Nav350Device):
        def _do_mapping(self, request: tg.Telegram, t: float) -> list[bytes]:
            good = tg.Telegram("sAN", request.name, tg.MappingResult(0, tg.LandmarkData(1, (
                tg.Landmark((1000, 2000)),)))).encode(request.dialect)
            # landmark count 1 -> 9: the count is larger than the bytes that follow
            payload = bytearray(good[8:-1])
            i = payload.index(b"mNMAPDoMapping ") + len("mNMAPDoMapping ")
            payload[i + 4] = 9
            checksum = 0
            for b in payload:
                checksum ^= b
            bad = good[:8] + bytes(payload) + bytes([checksum])
            self._later.append((t + 0.1, bad))
            return [self._out(tg.reply("sMA", request.name), request.dialect)]

    source, _ = _still_source()
    dev = _BadMapping(source, {})
    events = run_session(dev, Nav350Settings(map_at=MapStand(0, 0, 0, mean=4)), 4.0)
    kinds = _kinds(events)
    assert kinds.count("mapping_failed") == 1
    assert [e.error_code for e in events if isinstance(e, MappingDone)] == [-1]
    assert any(isinstance(e, PoseDataReceived) for e in events)


class _GarbageClock(Nav350Device):
    """Answers every clock read with a reply whose arguments do not fit its layout."""

    def handle(self, request: tg.Telegram, t: float) -> list[bytes]:
        if request.name == "mNAVGetTimestamp":
            self.requests.append((t, request))
            from lgvtool.devices.nav350.nav350_cola import encode_frame

            return [encode_frame(request.dialect, "sAN", "mNAVGetTimestamp", b"\x00\x01")]
        return super().handle(request, t)


def test_garbage_clock_replies_are_given_up_after_a_bounded_number_per_device_session() -> None:
    dev = _GarbageClock(revolutions(), {i: tg.LayoutLandmark(1000 * i, 0) for i in range(1, 5)})
    events = run_session(dev, Nav350Settings(), 10.0)
    clock_requests = [r for _, r in dev.requests if r.name == "mNAVGetTimestamp"]
    assert 1 <= len(clock_requests) <= 5
    assert _kinds(events).count("clock_given_up") == 1
    poses = [e for e in events if isinstance(e, PoseDataReceived)]
    rate = len(poses) / (poses[-1].received - poses[0].received)
    assert rate > 7.0  # poses keep coming at the device's rate


def test_the_clock_read_is_tried_again_in_a_new_device_session() -> None:
    dev = _GarbageClock(revolutions(), {})
    session = Nav350Session(Nav350Settings())
    events = _sessions(session, dev, 2, 4.0)
    per_session = len([r for _, r in dev.requests if r.name == "mNAVGetTimestamp"])
    assert 2 * 1 <= per_session <= 2 * 5
    assert _kinds(events).count("clock_given_up") == 2


@pytest.mark.parametrize("fields", [(0, 0), (1, 1)])
def test_layout_unreadable_is_said_once_and_navigation_goes_on(fields: tuple[int, int]) -> None:
    class _NoLayoutRead(Nav350Device):
        def handle(self, request: tg.Telegram, t: float) -> list[bytes]:
            if request.name == "mNLAYGetLayer":
                self.requests.append((t, request))
                if fields == (0, 0):
                    return [self._sfa(2, request.dialect)]
                return [self._out(tg.Telegram("sAN", request.name, tg.LayerIds(7, ())),
                                  request.dialect)]
            return super().handle(request, t)

    dev = _NoLayoutRead(revolutions(), {})
    events = run_session(dev, Nav350Settings(), 3.0)
    assert _kinds(events).count("layout_unreadable") == 1
    assert any(isinstance(e, NavigationEntered) for e in events)


def test_a_recording_against_garbage_clock_replies_keeps_the_pose_rate(tmp_path, monkeypatch
                                                                        ) -> None:
    """The record-level check: the virtual NAV350 answers every clock read with garbage."""
    from lgvtool.devices.nav350 import nav350_device as device_module
    from lgvtool.log import LogReader
    from lgvtool.sim.emulate.emulator_playback import playback_from_scenario
    from lgvtool.sim.emulate.nav350 import nav350_emulator
    from lgvtool.sim.emulate.nav350.nav350_loopback import loopback

    # the emulator module is imported before either patch, so that undoing them restores the
    # real device model there too (imported under the patch, it would keep the fake one)
    monkeypatch.setattr(nav350_emulator, "Nav350Device", _GarbageClock)
    monkeypatch.setattr(device_module, "Nav350Device", _GarbageClock)
    pb = playback_from_scenario("paper-circle", seed=6, duration=20.0)
    out = tmp_path / "clock.mcap"
    r = loopback(pb, out, seconds=6.0)
    assert r.diagnostics.get("clock_given_up", 0) == 1
    raw = b"".join(base64.b64decode(m.data["data"])
                   for m in LogReader(out).messages(["/nav350/tx"]))
    asked = [t.name for t in Nav350StreamDecoder().feed(raw)]
    assert 1 <= asked.count("mNAVGetTimestamp") <= 5
    assert r.log_poses >= 6 * 7 - 8  # about 8 a second after the start-up
