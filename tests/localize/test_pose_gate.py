"""The plausibility gate on NAV poses: corrupt poses that pass the NAV200's XOR are left out,
good ones are kept; the gate can be switched off; replay reports what it left out."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from simlogs import simulate_log

from lgvtool.devices.nav200.nav200_commands import Reply
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.devices.nav200.nav200_replies import build_pose_reply
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder
from lgvtool.localize.gate import gate_poses
from lgvtool.localize.logdata import load_log
from lgvtool.localize.replay_driver import apply_pose_gate, replay_data
from lgvtool.log import LogReader, topics


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_log(tmp_path_factory.mktemp("gate") / "run.mcap", 120, 4)


def read(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(path)
    cfg = reader.config()
    return reader, cfg, load_log(reader, cfg.reflectors or None)


def corrupt(x: float, y: float, h: float, flips: tuple[int, int]) -> tuple[float, float, float]:
    """The pose delivered from the PP reply of ``(x, y, h)`` with bits ``flips`` flipped (two
    bits at the same position of two bytes pass the XOR)."""
    raw = bytearray(build_pose_reply(x, y, h, 90, 8))
    for bit in flips:
        raw[bit // 8] ^= 1 << (bit % 8)
    frames = Nav200ReplyDecoder().feed(bytes(raw))
    assert len(frames) == 1 and isinstance(frames[0], Reply)
    p = frames[0].payload
    assert isinstance(p, Pose)
    return p.x, p.y, p.heading


def test_good_poses_pass_and_corrupt_ones_are_caught(log: Path) -> None:
    _, cfg, data = read(log)
    nav = data.nav
    assert nav is not None
    assert apply_pose_gate(data, cfg.vehicle) == []
    assert bool(np.all(nav["gate"]))
    # x's second byte bit 1 (512 mm) with the same bit of the BCC; y's third byte bit 0
    # (65.5 m) with the BCC; the heading's high byte bit 2 (22.5 deg) with quality's bit 2
    cases = {40: (4 * 8 + 8 + 1, 16 * 8 + 1), 80: (8 * 8 + 16, 16 * 8),
             120: (12 * 8 + 8 + 2, 14 * 8 + 2)}
    x, y, h = nav["x"].copy(), nav["y"].copy(), nav["heading"].copy()
    for k, flips in cases.items():
        cx, cy, ch = corrupt(float(x[k]), float(y[k]), float(h[k]), flips)
        assert (cx, cy, ch) != pytest.approx((x[k], y[k], h[k]), abs=1e-3)
        x[k], y[k], h[k] = cx, cy, ch
    from lgvtool.localize.motion import MotionSettings, MotionTrack

    ms = MotionSettings()
    odo = MotionTrack(data.increments(ms, cfg.vehicle), ms.step_form).poses_at(nav["t"])
    verdict = gate_poses(nav["t"], x, y, h, nav["valid"], odo, cfg.vehicle.nav_x,
                         cfg.vehicle.nav_y)
    assert sorted(k for k, *_ in verdict.rejected) == sorted(cases)
    # without odometry nothing can be judged: every valid pose passes
    blind = gate_poses(nav["t"], x, y, h, nav["valid"], None, 1.0, 0.0)
    assert bool(np.all(blind.accepted == nav["valid"]))


def test_a_jump_is_left_out_by_default_and_kept_when_switched_off(log: Path,
                                                                  tmp_path: Path) -> None:
    _, cfg, data = read(log)
    nav = data.nav
    assert nav is not None
    k = int(np.nonzero(nav["valid"])[0][30])
    nav["x"][k] += 3.0
    gated = replay_data(data, ["laser"], config=cfg, seed=0)
    assert len(gated.gated) == 1 and "left out" in gated.gated[0][1]
    t_k = data.t0_ns + round(float(nav["t"][k]) * 1e9)
    assert not np.any(np.abs(gated.estimates["laser"].t_ns - t_k) < 1000)
    kept = replay_data(data, ["laser"], config=cfg, seed=0,
                       settings={"laser.pose_gate": False})
    assert len(kept.estimates["laser"].x) == len(gated.estimates["laser"].x) + 1
    assert float(np.max(np.abs(np.diff(kept.estimates["laser"].x)))) > 2.0
    assert float(np.max(np.abs(np.diff(gated.estimates["laser"].x)))) < 1.0


def test_replay_flags_left_out_poses_in_diagnostics(log: Path, tmp_path: Path,
                                                    run_cli) -> None:
    """The pose the gate leaves out is an event of the output, beside every event the input
    had (none lost), and a replay of that output does not repeat it."""
    from lgvtool.log import LogWriter
    from lgvtool.log.messages import diagnostic_message

    bad = tmp_path / "jump.mcap"
    reader, _, _ = read(log)
    poses = 0
    with LogWriter(bad, source="test") as w:
        for name, record in reader.metadata.items():
            if name != "lgvtool":
                w.add_metadata(name, record)
        for m in reader.messages():
            if m.topic == topics.NAV_POSE and m.data["valid"]:
                poses += 1
                if poses == 50:
                    m.data["y"] += 5.0
                    w.write(topics.DIAGNOSTICS, diagnostic_message(
                        m.log_time_ns, "mcu", "seq_gap", "a recorded event"), m.log_time_ns)
            w.write(m.topic, m.data, m.log_time_ns)

    def events(path: Path) -> list[dict[str, object]]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return [m.data for m in LogReader(path).messages([topics.DIAGNOSTICS])]

    out = tmp_path / "out.mcap"
    res = run_cli("replay", bad, "-o", out, "-e", "laser")
    assert res.returncode == 0, res.stderr
    diags = [d for d in events(out) if d.get("kind") == "pose_implausible"]
    assert len(diags) == 1
    assert diags[0]["source"] == "nav200" and "left out" in str(diags[0]["message"])
    assert isinstance(diags[0]["timestamp"], dict)
    assert math.isfinite(float(diags[0]["timestamp"]["sec"]))
    recorded = events(bad)
    assert recorded and all(d in events(out) for d in recorded)
    assert len(events(out)) == len(recorded) + 1
    again = tmp_path / "again.mcap"
    assert run_cli("replay", out, "-o", again, "-e", "laser").returncode == 0
    assert len(events(again)) == len(events(out))
