"""Recording the virtual NAV350 over loopback: both sides counted, faults, downstream commands."""

from __future__ import annotations

import base64
import json
from collections import Counter
from itertools import pairwise
from pathlib import Path

import jsonschema
import pytest

from lgvtool.log import LogReader
from lgvtool.log.schemas import schema_json
from lgvtool.sim.emulate.emulator_playback import playback_from_scenario
from lgvtool.sim.emulate.nav350.nav350_loopback import loopback
from lgvtool.wire.decode_events import STREAM_EVENT_KINDS

FAULTS = ("garbage:nav350:2:400", "badsum:nav350:3:2", "sfa:nav350:4:13",
          "error:nav350:8.5:0.5:7", "drop:nav350:5.5:1.5")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, object]:
    out = tmp_path_factory.mktemp("nav350") / "rec.mcap"
    pb = playback_from_scenario("paper-circle", seed=3, duration=30.0)
    result = loopback(pb, out, seconds=11.0, faults=FAULTS, drift_ppm=50.0)
    return out, result


def test_every_pose_and_landmark_served_is_logged_and_the_link_resumes(recorded) -> None:
    out, r = recorded
    assert r.device_poses > 40 and r.device_landmarks > 200
    assert r.log_poses == r.device_poses
    assert r.log_landmarks == r.device_landmarks
    assert len(r.faults) == len(FAULTS)
    d = r.diagnostics
    assert d.get("link_up", 0) >= 1 and d.get("link_down", 0) >= 1
    for kind in ("device_error", "device_error_code", "bad_checksum", "bytes_skipped"):
        assert d.get(kind, 0) >= 1, kind
    reader = LogReader(out)
    last = max(m.log_time_ns for m in reader.messages(["/nav/pose"]))
    first = min(m.log_time_ns for m in reader.messages(["/nav/pose"]))
    assert (last - first) / 1e9 > 9.0  # poses again after the drop


def test_clock_estimate_tracks_a_50_ppm_fast_device(recorded) -> None:
    _, r = recorded
    assert r.clock_errors_ms
    assert r.clock_error_after(8.0) < 2.0


def test_messages_validate_and_carry_both_times(recorded) -> None:
    out, _ = recorded
    reader = LogReader(out)
    pose_v = jsonschema.Draft202012Validator(schema_json("lgvtool.NavPose"))
    scan_v = jsonschema.Draft202012Validator(schema_json("lgvtool.ReflectorScan"))
    with_stamp = 0
    for m in reader.messages(["/nav/pose", "/nav/reflectors"]):
        (pose_v if m.topic == "/nav/pose" else scan_v).validate(m.data)
        if m.topic == "/nav/pose" and m.data["valid"]:
            assert {"device_time_ms", "mean_dev", "nav_mode", "reflectors_used"} <= set(m.data)
            with_stamp += "device_stamp" in m.data
        elif m.topic == "/nav/reflectors":
            times = [o["time_in_scan"] for o in m.data["observations"]]
            assert all(0.0 <= t < 0.2 for t in times)
            assert all(o["id"] >= 1 for o in m.data["observations"])
    assert with_stamp > 0
    meta = reader.metadata["device.nav350"]
    assert meta["FirmwareVersion"] and "clock" in meta


def test_decode_info_and_replay_work_on_the_recording(recorded, run_cli, tmp_path: Path) -> None:
    out, r = recorded
    dec = run_cli("decode", out, "-o", tmp_path / "dec.mcap", "--json")
    assert dec.returncode == 0, dec.stderr
    report = json.loads(dec.stdout)
    assert report["nav350"]["landmarks"] == r.log_landmarks
    # the recorder's link and session events cannot be decoded again from the bytes: they are
    # kept, the decoder's own are written anew (as many as the recording's live decoder wrote)
    before = Counter((d["source"], d["kind"])
                     for d in (m.data for m in LogReader(out).messages(["/diagnostics"])))
    after_reader = LogReader(tmp_path / "dec.mcap")
    after = Counter((d["source"], d["kind"])
                    for d in (m.data for m in after_reader.messages(["/diagnostics"])))
    session = {k for k in before if k[1] not in STREAM_EVENT_KINDS}
    assert {("nav350", "link_down"), ("nav350", "device_error_code")} <= session
    assert {k: after[k] for k in session} == {k: before[k] for k in session}
    assert after == before
    mirrored = Counter(m.data["message"] for m in after_reader.messages(["/diagnostics/log"]))
    assert sum(mirrored.values()) == sum(after.values())
    info = run_cli("info", tmp_path / "dec.mcap", "--json")
    assert info.returncode == 0, info.stderr
    rep = run_cli("replay", out, "-o", tmp_path / "rep.mcap", "-e", "laser", "-e", "pf-paper",
                  "--particles", "200")
    assert rep.returncode == 0, rep.stderr
    names = set(LogReader(tmp_path / "rep.mcap").topic_names())
    assert {"/estimate/laser/pose", "/estimate/pf-paper/pose"} <= names


def test_record_rejects_a_serial_nav350_url(run_cli, tmp_path: Path) -> None:
    r = run_cli("record", "--nav350", "/dev/ttyS0", "-o", tmp_path / "x.mcap", "--duration", "1")
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "tcp://HOST:2112" in r.stderr


def test_speed_input_is_stamped_in_the_nav350_clock(tmp_path: Path) -> None:
    pb = playback_from_scenario("paper-circle", seed=4, duration=20.0)
    r = loopback(pb, tmp_path / "speed.mcap", seconds=4.0, speed_input=True, drift_ppm=50.0)
    assert len(r.speed_tick_errors_ms) > 10
    # the tick is the odometry's time: a little before the request reaches the device
    assert all(-500.0 < e <= 2.0 for e in r.speed_tick_errors_ms)


def test_a_refused_login_stops_the_recording_with_one_line(tmp_path: Path, monkeypatch) -> None:
    from lgvtool.devices.nav350 import nav350_device as device_module
    from lgvtool.devices.nav350.nav350_worker import Nav350Stopped

    monkeypatch.setattr(device_module, "PASSWORD_CLIENT", 0x1)
    pb = playback_from_scenario("paper-circle", seed=4, duration=10.0)
    out = tmp_path / "refused.mcap"
    with pytest.raises(Nav350Stopped, match="refused the login") as info:
        loopback(pb, out, seconds=5.0)
    assert "\n" not in str(info.value)
    kinds = [m.data["kind"] for m in LogReader(out).messages(["/diagnostics"])]
    assert "fatal" in kinds and "stopped" in kinds  # the log is complete


@pytest.mark.parametrize("dialect", ["binary", "ascii"])
def test_served_nav350_answers_the_vendor_sequence_over_tcp(dialect: str) -> None:
    """The vendor driver's start-up (protocol note section 2) against `simulate serve`, in
    order, then pose requests whose scan start ticks advance with time (its clock lock)."""
    import socket
    import time

    from lgvtool.devices.nav350 import nav350_telegrams as tg
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
    from lgvtool.sim.emulate.emulator_server import EmulatorServer

    pb = playback_from_scenario("paper-circle", seed=2, duration=10.0)
    server = EmulatorServer(pb, nav=None, mcu=None, nav350="tcp://127.0.0.1:0", wait=False)
    server.start()
    try:
        host, port = server.urls["nav350"][len("tcp://"):].rsplit(":", 1)
        sock = socket.create_connection((host, int(port)), timeout=2.0)
        dec = Nav350StreamDecoder()

        def ask(req: tg.Telegram, replies: int = 1) -> list[tg.Telegram]:
            sock.sendall(req.encode(dialect))
            got: list[tg.Telegram] = []
            deadline = time.monotonic() + 2.0
            while len(got) < replies and time.monotonic() < deadline:
                got += dec.feed(sock.recv(65536))
            return got

        sequence = [
            tg.request("sRN", "SCdevicestate"), tg.set_access_mode(),
            tg.request("sWN", "EIHstCola", 1 if dialect == "binary" else 0),
            tg.request("sRN", "FirmwareVersion"), tg.request("sRN", "SCdevicestate"),
            tg.request("sRN", "ODoprh"), tg.request("sRN", "ODpwrc"),
            tg.request("sRN", "LocationName"), tg.request("sRN", "LMDscandatacfg"),
            tg.set_access_mode(), tg.change_state(1), tg.current_layer(0), *tg.data_formats(),
            tg.change_state(4)]
        for req in sequence:
            replies = ask(req, 2 if req.name == "mNEVAChangeState" else 1)
            assert replies and not replies[-1].is_error, req.name
            assert replies[-1].name == req.name and replies[-1].dialect == dialect
        starts = []
        for _ in range(6):
            (reply,) = ask(tg.get_pose_data(1, 2))
            assert reply.value.error_code in (0, 4)
            starts.append(reply.value.scans[0].timestamp_ms)
        steps = [b - a for a, b in pairwise(starts)]
        assert all(120 <= s <= 130 for s in steps), steps  # one revolution per reply, 8 Hz
        sock.close()
    finally:
        server.stop()


def test_recording_in_cola_a(tmp_path: Path) -> None:
    pb = playback_from_scenario("paper-circle", seed=5, duration=20.0)
    r = loopback(pb, tmp_path / "ascii.mcap", seconds=4.0, dialect="ascii")
    assert r.device_poses > 15 and r.log_poses == r.device_poses
    assert r.log_landmarks == r.device_landmarks
    raw = b"".join(base64.b64decode(m.data["data"])
                   for m in LogReader(tmp_path / "ascii.mcap").messages(["/nav350/tx"]))
    assert raw.startswith(b"\x02sMN SetAccessMode 3 F4724744\x03")
