"""``lgvtool simulate serve``, the playback sources and fault specifications."""

from __future__ import annotations

import json
import queue
import threading
import time
from pathlib import Path

import pytest
from devices_helpers import Procs, circle_playback, messages, raw_stream

from lgvtool.errors import InputError
from lgvtool.log import LogWriter, topics
from lgvtool.log.reader import LogWarning
from lgvtool.sim.emulate import (
    Fault,
    parse_fault,
    playback_from_log,
    playback_from_scenario,
)
from lgvtool.sim.emulate.mcu.mcu_emulator import VirtualMcu
from lgvtool.timestamps import stamp


def _lines(stream, out: queue.Queue[str]) -> None:
    for line in stream:
        out.put(line)


def test_serve_prints_its_ports_and_record_uses_them(tmp_path: Path, procs: Procs) -> None:
    ports = tmp_path / "ports"
    ports.mkdir()
    serve = procs.lgvtool("simulate", "serve", "--scenario", "paper-circle", "--duration", 12,
                          "--speed", 6, "--pty-dir", ports, "--exit-after", 0.5,
                          "--transcript", tmp_path / "sent.jsonl")
    lines: queue.Queue[str] = queue.Queue()
    threading.Thread(target=_lines, args=(serve.stdout, lines), daemon=True).start()
    urls: dict[str, str] = {}
    deadline = time.monotonic() + 20
    while len(urls) < 2 and time.monotonic() < deadline:
        try:
            line = lines.get(timeout=0.5)
        except queue.Empty:
            assert serve.poll() is None, serve.stderr.read() if serve.stderr else ""
            continue
        name, _, url = line.strip().partition(": ")
        if name in ("nav200", "mcu"):
            urls[name] = url
    assert urls["nav200"] == f"serial://{ports}/nav200"
    assert urls["mcu"] == f"serial://{ports}/mcu"
    out = tmp_path / "served.mcap"
    rec = procs.lgvtool("record", "--nav", urls["nav200"], "--mcu", urls["mcu"], "-o", out,
                        "--duration", 4, "--poll-period", 0.075, "--no-status")
    _, rec_err = rec.communicate(timeout=30)
    serve.wait(timeout=30)
    assert rec.returncode == 0, rec_err
    assert serve.returncode == 0
    rest = []
    while not lines.empty():
        rest.append(lines.get())
    assert any("sent" in line and "connection" in line for line in rest)
    assert len(messages(out, topics.MCU_FRAME)) >= 100
    assert len(messages(out, topics.NAV_POSE)) >= 10
    sent = b"".join(bytes.fromhex(e["hex"]) for e in map(json.loads, (tmp_path / "sent.jsonl")
                                                         .read_text().splitlines())
                    if e["device"] == "mcu" and e["direction"] == "sent")
    assert raw_stream(out, topics.MCU_RX) == sent
    assert not list(ports.iterdir())  # the links are gone with the server


def test_playback_from_a_log_plays_what_was_logged(tmp_path: Path) -> None:
    pb = circle_playback(3.0)
    log = tmp_path / "source.mcap"
    t0 = 1_700_000_000_000_000_000
    with LogWriter(log, source="test") as w:
        w.write_map(pb.reflectors, t0)
        for c in pb.mcu:
            w.write_raw("mcu", "rx", c.data, t0 + round(c.t * 1e9))
        for p in pb.poses:
            ns = t0 + round(p.t * 1e9)
            w.write(topics.NAV_POSE, {"timestamp": stamp(ns), "x": p.x, "y": p.y,
                                      "heading": p.heading, "quality": p.quality,
                                      "reflectors_used": p.reflectors_used, "valid": p.valid},
                    ns)
    back = playback_from_log(log)
    assert back.mcu_bytes() == pb.mcu_bytes()
    # times count from the first message played (the first MCU chunk)
    assert [c.t for c in back.mcu] == pytest.approx([c.t - pb.mcu[0].t for c in pb.mcu])
    assert len(back.poses) == len(pb.poses) and back.reflectors == pb.reflectors
    fix = back.pose_at(1.0)
    assert fix is not None and fix.valid
    mcu = VirtualMcu(back)
    assert b"".join(mcu.due(back.duration + 1)) == pb.mcu_bytes() and mcu.finished
    # a log cut off is served from what is salvaged, and said so as every reader does
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(log.read_bytes()[: log.stat().st_size * 2 // 3])
    with pytest.warns(LogWarning, match="incomplete log"):
        salvaged = playback_from_log(cut)
    assert 0 < len(salvaged.mcu) <= len(pb.mcu)


def test_playback_from_a_scenario() -> None:
    pb = playback_from_scenario("paper-circle", seed=3, duration=12.0)
    assert pb.duration == pytest.approx(12.0)
    assert len(pb.mcu) >= 110 and pb.poses and len(pb.reflectors) == 20
    assert pb.pose_at(-1.0) is None and pb.pose_at(11.9) is not None


def test_virtual_mcu_loops() -> None:
    pb = circle_playback(1.0)
    mcu = VirtualMcu(pb, loop=True)
    first = mcu.due(pb.duration + 0.05)
    assert b"".join(first[:len(pb.mcu)]) == pb.mcu_bytes()
    assert not mcu.finished and mcu.next_time() is not None


def test_fault_specifications() -> None:
    assert parse_fault("drop:all:5:2.5") == Fault("drop", "all", 5.0, 2.5)
    assert parse_fault("garbage:mcu:3:64").arg == 64
    assert parse_fault("reset:nav200:10") == Fault("reset", "nav200", 10.0)
    assert parse_fault("silent:nav200:1:1").devices() == ("nav200",)
    for bad in ("drop:all:5", "boom:mcu:1:1", "drop:gps:1:1", "reset:mcu:3", "drop:all:x:1",
                "garbage:mcu:1:0", "reset:nav200:1:2"):
        with pytest.raises(InputError):
            parse_fault(bad)
