"""``lgvtool decode``: raw traffic of a log re-decoded into fresh channels."""

from __future__ import annotations

import json
import math
from pathlib import Path

import jsonschema
import pytest

from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.nav200.nav200_replies import build_error_reply, build_pose_reply
from lgvtool.devices.nav200.nav200_requests import request_pose_with_speed
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.timestamps import stamp

T0 = 1_700_000_000_000_000_000
SCHEMAS = Path(__file__).resolve().parent.parent / "schemas"


def mcu_bytes(seq: int) -> bytes:
    return McuFrame(
        seq=seq,
        mcu_time_ms=seq * 100,
        enc_left=seq * 10,
        enc_right=seq * 11,
        gyro_raw=100,
        steering_cdeg=6000,
        drive_speed_mm_s=360,
        status=1,
    ).encode()


def build_log(path: Path) -> None:
    """20 MCU frames (seq 3-5 lost, one corrupted copy, garbage, odd chunking), 10 NAV200
    pose polls (one error reply, one garbage burst), a stale decoded frame, a recorder event,
    and a truth pose."""
    with LogWriter(path, source="test") as w:
        w.add_metadata("simulator", {"seed": 1})
        stream = bytearray()
        for seq in [s for s in range(20) if s not in (3, 4, 5)]:
            if seq == 8:
                bad = bytearray(mcu_bytes(99))
                bad[12] ^= 0x10
                stream += bad + b"\x00\xa5\x17"
            stream += mcu_bytes(seq)
        chunks = [stream[i : i + 7] for i in range(0, len(stream), 7)]
        for i, chunk in enumerate(chunks):
            w.write_raw("mcu", "rx", bytes(chunk), T0 + i * 10_000_000)
        # A stale decoded frame and a stale decoder diagnostic, both to be replaced.
        w.write(
            topics.MCU_FRAME,
            {
                "timestamp": stamp(T0),
                "version": 1,
                "seq": 999,
                "mcu_time_ms": 0,
                "enc_left": 0,
                "enc_right": 0,
                "gyro_raw": 0,
                "gyro_scale": 0.010986,
                "gyro_rate": 0.0,
                "steering_angle": 0.0,
                "drive_speed": 0.0,
                "status": 0,
            },
            T0,
        )
        w.write_diagnostic("mcu", "bad_checksum", "stale", T0)
        w.write_diagnostic("nav200", "unanswered", "stale", T0)
        w.write_diagnostic("recorder", "link_down", "NAV200 link lost", T0 + 1)
        # the recorder's own events of a device, which no decoding of its bytes gives again
        w.write_diagnostic("nav200", "link_down", "link lost", T0 + 2)
        w.write_diagnostic("nav200", "device_silent", "no reply for 2.0 s", T0 + 3)
        w.write_diagnostic("mcu", "link_up", "link back", T0 + 4)
        w.write(topics.TRUTH, pose_in_frame(T0, 1.0, 2.0, 0.5), T0)
        for k in range(10):
            t = T0 + k * 200_000_000
            request = request_pose_with_speed(0.36, 0.0, 0.26)
            w.write_raw("nav200", "tx", request.encode(), t)
            if k == 4:
                reply = build_error_reply(request, 1, 7, 9)
            else:
                reply = build_pose_reply(k * 0.1, -1.0, math.pi / 4, 90, 6)
            if k == 6:
                reply = b"\x02\x11\x50" + reply
            w.write_raw("nav200", "rx", reply[:5], t + 50_000_000)
            w.write_raw("nav200", "rx", reply[5:], t + 60_000_000)


def test_decode_rebuilds_channels(tmp_path: Path) -> None:
    from lgvtool.app.decode_job import decode_log

    src, out = tmp_path / "in.mcap", tmp_path / "out.mcap"
    build_log(src)
    report = decode_log(LogReader(src), out)
    assert report.mcu_frames == 17
    assert report.mcu_stats["bad_checksum"] >= 1
    assert report.mcu_stats["seq_gaps"] == 1
    assert report.mcu_stats["frames_missing"] == 3
    assert report.nav_requests == 10
    assert report.nav_replies == 10
    assert report.nav_poses == 9
    assert report.nav_stats["error_replies"] == 1
    assert report.nav_stats["bytes_skipped"] == 3

    reader = LogReader(out)
    frames = [m.data for m in reader.messages([topics.MCU_FRAME])]
    assert [f["seq"] for f in frames] == [s for s in range(20) if s not in (3, 4, 5)]
    mcu_schema = json.loads((SCHEMAS / "lgvtool.McuFrame.json").read_text())
    for f in frames:
        jsonschema.validate(f, mcu_schema)
    assert frames[1]["steering_angle"] == pytest.approx(math.radians(60))
    poses = [m.data for m in reader.messages([topics.NAV_POSE])]
    assert len(poses) == 9
    assert poses[0]["heading"] == pytest.approx(math.pi / 4, abs=1e-4)
    diags = [m.data for m in reader.messages([topics.DIAGNOSTICS])]
    kinds = {(d["source"], d["kind"]) for d in diags}
    assert ("mcu", "seq_gap") in kinds
    assert ("nav200", "device_error") in kinds
    assert ("recorder", "link_down") in kinds
    assert {("nav200", "link_down"), ("nav200", "device_silent"), ("mcu", "link_up")} <= kinds
    assert all(d["message"] != "stale" for d in diags)
    mirrored = [m.data["message"] for m in reader.messages([topics.DIAGNOSTICS_LOG])]
    assert len(mirrored) == len(diags)
    assert "[device_silent] no reply for 2.0 s" in mirrored
    assert all("stale" not in text for text in mirrored)
    gap = next(d for d in diags if d["kind"] == "seq_gap")
    assert gap["details"]["first_missing_seq"] == 3 and gap["count"] == 3
    assert reader.topics()[topics.TRUTH].count == 1
    assert reader.topics()[topics.MCU_RX].count == LogReader(src).topics()[topics.MCU_RX].count
    assert reader.metadata["simulator"] == {"seed": 1}
    assert reader.metadata["decode"]["mcu"]["frames"] == 17


def test_decode_cli_json_and_text(tmp_path: Path, run_cli) -> None:
    src = tmp_path / "in.mcap"
    build_log(src)
    proc = run_cli("decode", src, "-o", tmp_path / "out.mcap", "--json")
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert report["mcu"]["frames"] == 17
    assert report["nav200"]["poses"] == 9
    assert report["mcu"]["stats"]["frames_missing"] == 3
    proc = run_cli("decode", src, "-o", tmp_path / "out2.mcap")
    assert proc.returncode == 0, proc.stderr
    assert "mcu: 17 frames" in proc.stdout
    assert "seq_gaps 1" in proc.stdout


def test_decode_bad_input(tmp_path: Path, run_cli) -> None:
    empty = tmp_path / "empty.mcap"
    with LogWriter(empty, source="test") as w:
        w.write(topics.TRUTH, pose_in_frame(T0, 0.0, 0.0, 0.0), T0)
    proc = run_cli("decode", empty, "-o", tmp_path / "out.mcap")
    assert proc.returncode == 2
    assert "no raw device traffic" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    proc = run_cli("decode", empty, "-o", empty)
    assert proc.returncode == 2
    proc = run_cli("decode", tmp_path / "missing.mcap", "-o", tmp_path / "out.mcap")
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
