"""``lgvtool record`` end to end against the emulators: a clean run byte for byte, splitting,
SIGTERM, kill -9 and recover, a full disk. Over pseudo-terminals and loopback TCP only."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import re
import resource
import signal
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import pytest
from devices_helpers import (
    Procs,
    diagnostics,
    messages,
    raw_stream,
    record_args,
    start_emulator,
    stop_process,
    wait_for,
)

from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.log import LogReader, topics

POSE_TELEGRAM = 17
POSE_REQUEST = 11


def _reader(path: Path) -> LogReader:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return LogReader(path)


def test_record_a_run_byte_for_byte_and_evaluate(tmp_path: Path, procs: Procs) -> None:
    """25 s of the circle drive at 8x over pseudo-terminals: every byte both devices sent is
    in the raw channels, every frame decoded, the log complete and evaluable."""
    server = start_emulator(tmp_path, "pty", duration=25.0, speed=8.0)
    out = tmp_path / "run.mcap"
    try:
        p = procs.lgvtool(*record_args(server, out, "--duration", 6, "--speed-input",
                                       speed=8.0))
        assert wait_for(server.finished.is_set, 10.0), "the run was not played to its end"
        stdout, stderr = p.communicate(timeout=15)
    finally:
        server.stop()
    assert p.returncode == 0, stderr
    assert "recorded" in stdout and str(out) in stdout
    r = _reader(out)
    assert r.complete
    # the MCU: byte for byte, every frame decoded
    sent = server.sent("mcu")
    assert raw_stream(out, topics.MCU_RX) == sent
    frames = messages(out, topics.MCU_FRAME)
    assert len(frames) == len(server.playback.mcu) == len(McuStreamDecoder().feed(sent))
    assert [m.data["seq"] for m in frames] == list(range(len(frames)))
    # the NAV200: what it sent is in /nav200/rx (but for a reply in flight at the stop),
    # what it received is in /nav200/tx (but for a request in flight)
    nav_sent, nav_rx = server.sent("nav200"), raw_stream(out, topics.NAV_RX)
    assert nav_sent.startswith(nav_rx) and len(nav_sent) - len(nav_rx) <= POSE_TELEGRAM
    nav_got, nav_tx = server.received("nav200"), raw_stream(out, topics.NAV_TX)
    assert nav_tx.startswith(nav_got) and len(nav_tx) - len(nav_got) <= POSE_REQUEST
    poses = messages(out, topics.NAV_POSE)
    # requests before the run's clock started get "no valid position" (quality 0xFF); after
    # the first valid pose, every pose is valid
    valid = [m.data["valid"] for m in poses]
    assert sum(valid) > 30 and all(valid[valid.index(True):])
    (refl,) = messages(out, topics.MAP)
    assert len(refl.data["reflectors"]) == len(server.playback.reflectors)
    assert r.metadata["device.nav200"]["serial"] == 20417
    assert r.metadata["device.nav200"]["version"] == "2.4.1"
    assert r.metadata["device.mcu"]["frame_version"] == 1
    assert r.metadata["recorder"]["mcu_url"] == server.urls["mcu"]
    (stopped,) = [d for d in diagnostics(out) if d["kind"] == "stopped"]
    assert stopped["details"]["reason"] == "duration reached"
    assert not [d for d in diagnostics(out) if d["level"] >= 3 and d["source"] == "nav200"]
    # speed input: Pw with the head's vehicle-frame velocity from the MCU odometry, mm/s, and
    # the yaw rate in 65536 units per revolution per s
    nav200 = server.emulators["nav200"]
    inputs = [payload for _, code, payload in nav200.speed_inputs if code == "Pw"]
    assert len(inputs) > 20 and r.metadata["device.nav200"]["settings"]["speed_input"] == "Pw"
    v, w = 0.36 * math.cos(math.radians(60)), 0.36 * math.sin(math.radians(60)) / 1.2
    last = inputs[-1]
    # one encoder count in 0.1 s is 4.7 mm/s of speed
    assert abs(last.vx_mm_s - v * 1000) <= 6 and abs(last.vy_mm_s - w * 1000) <= 2
    assert abs(last.omega_raw - w * 32768 / math.pi) <= 15
    # the reference checker's checks (tests/log/mcap_doctor.py): no error, no warning
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "log"))
    from mcap_doctor import assert_reference_clean, schema_errors

    assert_reference_clean(out)
    assert schema_errors(out) == []
    if importlib.util.find_spec("lgvtool.commands.evaluate") is not None:
        ev = procs.lgvtool("evaluate", out, "-e", "laser", "-o", tmp_path / "report", "--json")
        ev_out, ev_err = ev.communicate(timeout=60)
        assert ev.returncode == 0, ev_err
        assert "laser" in json.loads(ev_out)["estimators"] or ev_out


def test_sigterm_finishes_the_file_within_two_seconds(tmp_path: Path, procs: Procs) -> None:
    server = start_emulator(tmp_path, "tcp", duration=60.0, speed=2.0)
    out = tmp_path / "term.mcap"
    try:
        p = procs.lgvtool(*record_args(server, out, speed=2.0))
        assert wait_for(lambda: len(server.sent("mcu")) > 30 * 20, 10.0)
        _, stderr, took = stop_process(p, signal.SIGTERM)
    finally:
        server.stop()
    assert p.returncode == 0, stderr
    assert took < 2.0, f"finishing took {took:.2f} s"
    r = _reader(out)
    assert r.complete and not r.warnings
    info = r.topics()
    assert info[topics.MCU_FRAME].count >= 20 and info[topics.NAV_POSE].count >= 3


def test_kill_9_then_recover_loses_at_most_about_a_second(tmp_path: Path, procs: Procs) -> None:
    server = start_emulator(tmp_path, "pty", duration=60.0, speed=1.0)
    out, fixed = tmp_path / "crash.mcap", tmp_path / "fixed.mcap"
    try:
        p = procs.lgvtool(*record_args(server, out, speed=1.0))
        assert wait_for(lambda: len(server.sent("mcu")) > 30 * 25, 10.0)
        killed_ns = time.time_ns()
        p.kill()
        p.communicate(timeout=5)
    finally:
        server.stop()
    broken = _reader(out)
    assert not broken.complete
    rec = procs.lgvtool("recover", out, "-o", fixed)
    rec_out, rec_err = rec.communicate(timeout=30)
    assert rec.returncode == 0, rec_err
    assert "recovered" in rec_out and "the input was cut off" in rec_out
    r = _reader(fixed)
    assert r.complete
    last_ns = max(m.log_time_ns for m in r.messages([topics.MCU_FRAME]))
    lost_s = (killed_ns - last_ns) / 1e9
    assert 0.0 <= lost_s < 1.6, f"{lost_s:.2f} s of data lost"
    # what survived is exactly the start of what was sent
    assert server.sent("mcu").startswith(raw_stream(fixed, topics.MCU_RX))
    assert r.topics()[topics.NAV_POSE].count > 3
    assert r.metadata["device.nav200"]["serial"] == 20417


def test_split_files_lose_nothing(tmp_path: Path, procs: Procs) -> None:
    server = start_emulator(tmp_path, "tcp", duration=20.0, speed=8.0)
    out = tmp_path / "shift.mcap"
    try:
        p = procs.lgvtool(*record_args(server, out, "--split-duration", 0.8, speed=8.0))
        assert wait_for(server.finished.is_set, 12.0)
        time.sleep(0.3)
        _, stderr, _ = stop_process(p, signal.SIGINT)
    finally:
        server.stop()
    assert p.returncode == 0, stderr
    files = list(tmp_path.glob("shift-*.mcap"))
    assert not out.exists() and len(files) >= 3
    assert all(re.fullmatch(r"shift-\d{8}T\d{6}Z(-\d+)?\.mcap", f.name) for f in files)
    readers = sorted((_reader(f) for f in files), key=lambda r: r.metadata["split"]["index"])
    assert all(r.complete for r in readers)
    # later files repeat the map and the device identity
    for r in readers[1:]:
        assert r.topics()[topics.MAP].count == 1
        assert r.metadata["device.nav200"]["serial"] == 20417
    joined = b"".join(raw_stream(r.path, topics.MCU_RX) for r in readers)
    assert joined == server.sent("mcu")
    # every part passes the reference checker's checks (tests/log/mcap_doctor.py)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "log"))
    from mcap_doctor import assert_reference_clean

    for f in files:
        assert_reference_clean(f)


def _limit_file_size() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (32_000, 32_000))


def _record_until_full(tmp_path: Path, procs: Procs, out: Path, *extra: str,
                       **popen: Any) -> tuple[int, str, list[str]]:
    """Record from the emulator into ``out`` until the write fails: exit code, stderr and its
    error lines."""
    server = start_emulator(tmp_path, "tcp", duration=60.0, speed=5.0)
    try:
        p = procs.lgvtool(*record_args(server, out, *extra), **popen)
        _, stderr = p.communicate(timeout=20)
    finally:
        server.stop()
    lines = [line for line in stderr.splitlines() if line.startswith("lgvtool: error:")]
    return p.returncode, stderr, lines


def test_full_disk_stops_with_a_clear_message(tmp_path: Path, procs: Procs) -> None:
    out = tmp_path / "full.mcap"
    code, _, lines = _record_until_full(tmp_path, procs, out, preexec_fn=_limit_file_size)
    assert code == 2
    assert len(lines) == 1 and "disk full while writing" in lines[0]
    assert "lgvtool recover" in lines[0]
    r = _reader(out)
    assert r.topics()[topics.MCU_FRAME].count > 10


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full on this system")
def test_no_space_left_on_device_stops_with_a_clear_message(tmp_path: Path,
                                                             procs: Procs) -> None:
    # /dev/full accepts the open and fails every write with ENOSPC, as a full disk does
    code, stderr, lines = _record_until_full(tmp_path, procs, Path("/dev/full"), "--force")
    assert code == 2
    assert len(lines) == 1 and "disk full while writing /dev/full" in lines[0]
    assert "No space left on device" in lines[0] and "Traceback" not in stderr
