"""The NAV350 device model and the host session, driven by bytes and made-up times."""

from __future__ import annotations

import math
import random

import pytest

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_clock import ClockEstimator, unwrap_ms
from lgvtool.devices.nav350.nav350_cola import ASCII, BINARY
from lgvtool.devices.nav350.nav350_device import Nav350Device, Observation, Revolution, RevolutionSource
from lgvtool.devices.nav350.nav350_session import (
    ClockRead,
    Nav350Session,
    Nav350Settings,
    NavigationEntered,
    PoseDataReceived,
    SessionFatal,
)
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder


def revolutions(n: int = 400, period: float = 0.125) -> RevolutionSource:
    revs = []
    for k in range(n):
        start = k * period
        obs = tuple(Observation(5.0 + i, -3.0 + 1.5 * i, 0.02 * i + 0.01, i + 1) for i in range(4))
        revs.append(Revolution(start, period, start + period + 0.04, 10.0 + 0.01 * k, 5.0,
                               0.1, True, 90, 4, obs))
    return RevolutionSource(revs)


def device(**kw: float) -> Nav350Device:
    layout = {i: tg.LayoutLandmark(1000 * i, 0) for i in range(1, 5)}
    return Nav350Device(revolutions(), layout, **kw)  # type: ignore[arg-type]


def exchange(dev: Nav350Device, request: tg.Telegram, t: float, dialect: str = BINARY
             ) -> list[tg.Telegram]:
    dec = Nav350StreamDecoder()
    out = dev.handle(tg.Telegram(request.kind, request.name, request.value, dialect), t)
    out += dev.due(t + 1.0)
    return [x for raw in out for x in dec.feed(raw)]


#: The vendor driver's start-up sequence (protocol note section 2), in order.
VENDOR_SEQUENCE = [
    tg.request("sRN", "SCdevicestate"), tg.set_access_mode(), tg.request("sWN", "EIHstCola", 1),
    tg.request("sRN", "FirmwareVersion"), tg.request("sRN", "SCdevicestate"),
    tg.request("sRN", "ODoprh"), tg.request("sRN", "ODpwrc"), tg.request("sRN", "LocationName"),
    tg.request("sRN", "LMDscandatacfg"), tg.set_access_mode(), tg.change_state(1),
    tg.current_layer(0), *tg.data_formats(), tg.change_state(4), tg.get_pose_data(1, 2),
]


@pytest.mark.parametrize("dialect", [BINARY, ASCII])
def test_vendor_start_up_sequence_is_answered_in_order(dialect: str) -> None:
    dev = device()
    t = 0.0
    for req in VENDOR_SEQUENCE:
        replies = exchange(dev, req, t, dialect)
        t += 0.01
        assert replies, req.name
        assert not any(r.is_error for r in replies), (req.name, replies)
        assert all(r.dialect == dialect for r in replies)
        assert replies[-1].name == req.name
        if req.name == "mNEVAChangeState":
            assert [r.kind for r in replies] == ["sMA", "sAN"]
            assert replies[-1].fields == (0, req.fields[0])
    data = replies[-1].value
    assert data.error_code == 0 and data.pose is not None and data.info is not None
    assert data.landmarks is not None and len(data.landmarks.landmarks) == 4
    assert len(data.scans) == 1 and len(data.scans[0].data) == 1440
    assert data.remission is not None and data.scans[0].content == "DIST1"


def test_device_clock_advances_and_drifts() -> None:
    dev = device(offset_ms=2**32 - 100, drift_ppm=50.0)
    assert dev.tick(0.0) == 2**32 - 100
    assert dev.tick(0.2) == 100  # wrapped
    assert dev.tick(1000.0) - dev.tick(0.0) + 2**32 == pytest.approx(1000_050, abs=1)
    assert dev.time_of_tick(dev.tick(500.0) + 0.5, 499.0) == pytest.approx(500.0, abs=1e-3)


def test_wait_one_answers_with_the_next_revolution() -> None:
    dev = device()
    for req in (tg.set_access_mode(), tg.change_state(4)):
        exchange(dev, req, 0.0)
    assert dev.handle(tg.get_pose_data(1, 2), 1.0) == []
    nxt = dev.next_due()
    assert nxt is not None and 1.0 < nxt <= 1.0 + 0.125 + 1e-9
    assert dev.due(nxt - 1e-3) == []
    assert len(dev.due(nxt)) == 1
    # a second request while one waits is refused with errorCode 6
    dev.handle(tg.get_pose_data(1, 2), 2.0)
    again = Nav350StreamDecoder().feed(dev.handle(tg.get_pose_data(1, 2), 2.001)[0])
    assert again[0].value.error_code == 6


def test_wrong_mode_login_and_unknown_requests() -> None:
    dev = device()
    assert exchange(dev, tg.get_pose_data(), 0.0)[0].is_error  # not logged in: sFA 1
    assert exchange(dev, tg.set_access_mode(3, 0x12345678), 0.0)[0].fields == (0,)
    assert exchange(dev, tg.set_access_mode(), 0.0)[0].fields == (1,)
    assert exchange(dev, tg.get_pose_data(), 0.0)[0].value.error_code == 1  # standby
    sent = dev.sfa_sent
    reply = exchange(dev, tg.Telegram("sMN", "mNFooBar", None), 0.0)
    assert reply[0].is_error and reply[0].fields == (2,) and dev.sfa_sent == sent + 1
    assert dev.sfa_sent >= 2


def run_session(dev: Nav350Device, settings: Nav350Settings, seconds: float,
                latency: float = 0.0005, *, until_fatal: bool = False) -> list[object]:
    """Session and device over an ideal link, time stepped by 1 ms."""
    session = Nav350Session(settings)
    session.link_up(0.0)
    dec = Nav350StreamDecoder(deliver_unknown=True)
    events: list[object] = []
    inflight: list[tuple[float, bytes]] = []
    t = 0.0
    while t < seconds:
        req = session.poll(t)
        if req is not None:
            for r in dec.feed(req.encode()):
                for raw in dev.handle(r, t + latency):
                    inflight.append((t + 2 * latency, raw))
        for raw in dev.due(t):
            inflight.append((t + latency, raw))
        for _at, raw in [x for x in inflight if x[0] <= t]:
            session.feed(raw, t)
        inflight = [x for x in inflight if x[0] > t]
        events += session.pop_events()
        if until_fatal and any(isinstance(e, SessionFatal) for e in events):
            break
        t = round(t + 0.001, 6)
    return events


@pytest.mark.parametrize("dialect", [BINARY, ASCII])
def test_session_writes_a_requested_layout_navigates_and_polls_at_the_device_rate(dialect: str) -> None:
    dev = device()
    layout = tuple(tg.LayoutLandmark(1000 * i, 2000, 1, 1, 80, (0,)) for i in range(60))
    events = run_session(dev, Nav350Settings(dialect=dialect, write_layout=layout), 6.0)
    assert any(isinstance(e, NavigationEntered) for e in events)
    assert len(dev.layout) == 60  # erased, then two AddLandmark chunks (50 + 10)
    adds = [r for _, r in dev.requests if r.name == "mNLAYAddLandmark"]
    assert [len(r.value) for r in adds] == [50, 10]
    poses = [e for e in events if isinstance(e, PoseDataReceived)]
    rate = len(poses) / (poses[-1].received - poses[0].received)
    assert 7.0 < rate < 8.5
    names = [r.name for _, r in dev.requests]
    assert names.index("SetAccessMode") < names.index("NEVACurrLayer") < names.index(
        "mNPOSGetData")


def test_session_clock_estimate_within_2_ms_after_10_s_at_50_ppm() -> None:
    dev = device(drift_ppm=50.0, offset_ms=4_294_960_000)  # wraps during the run
    events = run_session(dev, Nav350Settings(), 12.0, latency=0.0015)
    reads = [e for e in events if isinstance(e, ClockRead) and e.estimate is not None]
    last = reads[-1]
    assert last.received > 10.0
    est = last.estimate
    assert est is not None
    for tick_t in (5.0, 10.0, 11.5):
        tick = dev.tick(tick_t)
        u = tick + (2**32 if tick < 2**31 else 0)
        assert est.host_time((u + 0.5) / 1000.0) == pytest.approx(
            dev.time_of_tick(tick + 0.5, tick_t), abs=0.002)


def test_session_stops_on_a_refused_login_and_recovers_from_sfa() -> None:
    dev = device()
    events = run_session(dev, Nav350Settings(password=0x1), 2.0, until_fatal=True)
    assert any(isinstance(e, SessionFatal) for e in events)
    dev = device()
    dev.faults.sfa_count = 1  # the login is answered sFA: retried after a pause
    events = run_session(dev, Nav350Settings(), 3.0)
    kinds = [getattr(e, "kind", None) for e in events]
    assert "start_failed" in kinds
    assert any(isinstance(e, NavigationEntered) for e in events)


def test_session_reports_error_codes_and_restarts_on_wrong_mode() -> None:
    dev = device()
    dev.faults.error_code, dev.faults.error_until = 5, 3.0
    events = run_session(dev, Nav350Settings(restart_after=100), 4.0)
    codes = [getattr(e, "details", {})["error_code"] for e in events
             if getattr(e, "kind", "") == "device_error_code"]
    assert codes and set(codes) == {5}
    dev = device()
    session_events = run_session(dev, Nav350Settings(), 1.5)
    assert sum(isinstance(e, NavigationEntered) for e in session_events) == 1
    dev.faults.error_code, dev.faults.error_until = 1, math.inf
    events = run_session(dev, Nav350Settings(), 1.5)
    assert any(getattr(e, "kind", "") == "device_error_code" for e in events)
    assert sum(isinstance(e, NavigationEntered) for e in events) >= 2  # started over


def test_clock_estimator_bounds_and_unwrap() -> None:
    assert unwrap_ms(5, 2**32 - 5) == 2**32 + 5
    assert unwrap_ms(2**32 - 5, 5) == -5
    rng = random.Random(2)
    est = ClockEstimator()
    offset, drift = 1234.5, -50e-6
    for i in range(100):
        device_s = 100.0 + 0.5 * i
        host = device_s + offset + drift * (device_s - 100.0)
        sent = host - rng.uniform(0.0002, 0.004)
        received = host + rng.uniform(0.0002, 0.004)
        est.add(math.floor(device_s * 1000.0), sent, received)
    e = est.estimate
    assert e is not None
    truth = 150.0 + offset + drift * 50.0
    assert abs(e.host_time(150.0) - truth) < e.bound_s + 1e-4
    assert e.drift * 1e6 == pytest.approx(-50.0, abs=20.0)
    assert e.bound_s < 0.002


class _StuckInStandby(Nav350Device):
    """A device that answers every change to navigation with 'still in standby'."""

    def _change(self, request: tg.Telegram, t: float) -> list[bytes]:
        if int(request.fields[0]) == tg.MODE_NAVIGATION:
            return [self._out(tg.reply("sMA", request.name), request.dialect),
                    self._out(tg.reply("sAN", request.name, 1, tg.MODE_STANDBY),
                              request.dialect)]
        return super()._change(request, t)


def test_a_device_that_never_leaves_standby_gets_one_diagnostic_per_attempt() -> None:
    layout = {i: tg.LayoutLandmark(1000 * i, 0) for i in range(1, 5)}
    dev = _StuckInStandby(revolutions(), layout)
    events = run_session(dev, Nav350Settings(), 8.0)
    refused = [e for e in events if getattr(e, "kind", "") == "mode_refused"]
    assert 2 <= len(refused) <= 6  # retried with backoff, not hammered
    assert not any(isinstance(e, NavigationEntered) for e in events)
    assert not any(isinstance(e, PoseDataReceived) for e in events)
