"""Faults during a recording: a link dropped and restored, devices falling silent, garbage on
the line, a NAV200 reset answered with error replies. The recording goes on through all."""

from __future__ import annotations

import signal
import time
from pathlib import Path

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

from lgvtool.log import topics


def _record_whole_run(tmp_path: Path, procs: Procs, transport: str, faults: tuple[str, ...],
                      *extra: object, duration: float = 24.0, speed: float = 8.0):
    server = start_emulator(tmp_path, transport, duration=duration, speed=speed, faults=faults)
    out = tmp_path / "faults.mcap"
    wall = duration / speed
    try:
        p = procs.lgvtool(*record_args(server, out, "--duration", wall + 8, *extra,
                                       speed=speed))
        assert wait_for(server.finished.is_set, wall + 6.0), "the run was not played to its end"
        time.sleep(0.3)
        _, stderr, _ = stop_process(p, signal.SIGINT)
    finally:
        server.stop()
    assert p.returncode == 0, stderr
    return server, out


def _kinds(diags: list[dict], source: str) -> list[str]:
    return [d["kind"] for d in diags if d["source"] == source]


@pytest.mark.parametrize("transport", ["pty", "tcp"])
def test_link_dropped_and_restored(tmp_path: Path, procs: Procs, transport: str) -> None:
    """Both ports vanish 4 s into the run for 10 s (1.25 s of wall time)."""
    server, out = _record_whole_run(tmp_path, procs, transport, ("drop:all:4:10",))
    diags = diagnostics(out)
    for source in ("mcu", "nav200"):
        kinds = _kinds(diags, source)
        assert "link_down" in kinds and "link_up" in kinds, (source, kinds)
        ups = [d for d in diags if d["source"] == source and d["kind"] == "link_up"]
        assert len(ups) == 1, [(d["source"], d["kind"], d["message"]) for d in diags]
        up = ups[0]
        assert up["details"]["gap_s"] >= 0.8
        assert up["details"]["attempts"] >= 1
    # the frames sent while the port was gone are missing, and said so
    gaps = [d for d in diags if d["kind"] == "seq_gap"]
    assert gaps and sum(d["details"]["missing_frames"] for d in gaps) >= 10
    frames = messages(out, topics.MCU_FRAME)
    up_ns = max(m.log_time_ns for m in messages(out, topics.DIAGNOSTICS)
                if m.data["kind"] == "link_up")
    after = [m for m in frames if m.log_time_ns > up_ns]
    assert len(after) > 15 and frames[-1].data["seq"] == len(server.playback.mcu) - 1
    poses_after = [m for m in messages(out, topics.NAV_POSE) if m.log_time_ns > up_ns]
    assert len(poses_after) > 5 and all(m.data["valid"] for m in poses_after)
    # the session went through its sequence again and is positioning
    assert _kinds(diags, "nav200").count("positioning") == 2


def test_silent_devices_are_retried_and_their_gap_logged(tmp_path: Path, procs: Procs) -> None:
    """Both devices stop talking (link up) 4 s into the run for 12 s (1.5 s of wall time)."""
    _, out = _record_whole_run(tmp_path, procs, "tcp", ("silent:all:4:12",),
                               "--reply-timeout", 0.2)
    diags = diagnostics(out)
    for source in ("mcu", "nav200"):
        kinds = _kinds(diags, source)
        assert "device_silent" in kinds and "device_back" in kinds, (source, kinds)
        back = next(d for d in diags if d["source"] == source and d["kind"] == "device_back")
        assert back["details"]["gap_s"] >= 1.2
    back_ns = {m.data["source"]: m.log_time_ns for m in messages(out, topics.DIAGNOSTICS)
               if m.data["kind"] == "device_back"}
    assert sum(m.log_time_ns > back_ns["nav200"] for m in messages(out, topics.NAV_POSE)) > 3
    assert sum(m.log_time_ns > back_ns["mcu"] for m in messages(out, topics.MCU_FRAME)) > 20


def test_garbage_on_the_lines(tmp_path: Path, procs: Procs) -> None:
    """300 random bytes on the MCU line and 40 on the NAV200 line: logged raw, skipped by the
    decoders (and said so), every real frame still decoded."""
    server, out = _record_whole_run(tmp_path, procs, "pty",
                                    ("garbage:mcu:3:300", "garbage:nav200:6:40"))
    sent = server.sent("mcu")
    assert raw_stream(out, topics.MCU_RX) == sent
    assert len(sent) == len(server.playback.mcu_bytes()) + 300
    frames = messages(out, topics.MCU_FRAME)
    assert [m.data["seq"] for m in frames] == list(range(len(server.playback.mcu)))
    diags = diagnostics(out)
    skipped = [d for d in diags if d["source"] == "mcu" and d["kind"] == "bytes_skipped"]
    assert sum(d["details"]["skipped_bytes"] for d in skipped) == 300
    assert "bytes_skipped" in _kinds(diags, "nav200")
    nav_sent, nav_rx = server.sent("nav200"), raw_stream(out, topics.NAV_RX)
    assert nav_sent.startswith(nav_rx)
    garbage_at = next(e.t_ns for e in server.transcript
                      if e.device == "nav200" and len(e.data) == 40)
    assert sum(m.log_time_ns > garbage_at and m.data["valid"]
               for m in messages(out, topics.NAV_POSE)) > 5


def test_nav200_reset_error_reply_path(tmp_path: Path, procs: Procs) -> None:
    """The NAV200 restarts 5 s into the run: it is in standby, so the next pose request gets an
    'E' reply; the recorder logs it decoded and takes the device back into positioning."""
    server, out = _record_whole_run(tmp_path, procs, "tcp", ("reset:nav200:5",))
    diags = diagnostics(out)
    errors = [d for d in diags if d["source"] == "nav200" and d["kind"] == "device_error"]
    assert errors, _kinds(diags, "nav200")
    e = errors[0]
    assert (e["details"]["rejected_function"], e["details"]["error_class"],
            e["details"]["group"], e["details"]["detail"]) == ("P", 1, 2, 3)
    assert e["level"] == 4 and "wrong command" in e["message"]
    kinds = _kinds(diags, "nav200")
    assert "positioning_lost" in kinds and kinds.count("positioning") == 2
    # after the restart the reflector map is read from the device again and compared
    assert kinds.count("map_uploaded") == 2 and "map_verified" in kinds
    assert kinds.index("map_verified") > kinds.index("positioning_lost")
    assert server.emulators["nav200"].mode == "positioning"
    lost_ns = next(m.log_time_ns for m in messages(out, topics.DIAGNOSTICS)
                   if m.data["kind"] == "positioning_lost")
    assert sum(m.log_time_ns > lost_ns and m.data["valid"]
               for m in messages(out, topics.NAV_POSE)) > 10
    # the error reply itself is in the raw channel
    assert b"\x02\x09PEP\x01\x02\x03" in raw_stream(out, topics.NAV_RX)
