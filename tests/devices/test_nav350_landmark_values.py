"""The NAV350's per-landmark values reach ``/nav/reflectors``: quality, hit count and mean echo
as the device reports them, and the simulated device's mean echo follows the head model's
echo (a weak reflector and a far one echo weaker)."""

from __future__ import annotations

import math
from pathlib import Path

import jsonschema
from simlogs import simulate_log

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_device import ECHO_FULL
from lgvtool.log.messages import nav350_scan_message
from lgvtool.log.reader import LogReader
from lgvtool.log.schemas import schema_json


def test_the_scan_message_carries_each_landmarks_quality_hits_and_echo() -> None:
    marks = (tg.Landmark(None, (5000, 90000), tg.LandmarkInfo(0, 7, 1, 1, 88, 1000, 80, 6, 321,
                                                                 10, 15)),
             tg.Landmark(None, (9000, 180000), tg.LandmarkInfo(1, 8, 1, 1, 61, 1010, 80, 3,
                                                                  65535, 700, 702)),
             tg.Landmark(None, (4000, 0), None))
    data = tg.PoseData(landmarks=tg.LandmarkData(1, marks))
    msg = nav350_scan_message(data, 2_000_000_000, lambda tick: None)
    assert msg is not None
    jsonschema.Draft202012Validator(schema_json("lgvtool.ReflectorScan")).validate(msg)
    obs = msg["observations"]
    assert isinstance(obs, list)
    got = [(o.get("quality"), o.get("hit_count"), o.get("mean_echo")) for o in obs
           if isinstance(o, dict)]
    assert got == [(88, 6, 321), (61, 3, 65535), (None, None, None)]


def test_the_simulated_nav350_echoes_weaker_from_a_weak_reflector(tmp_path: Path) -> None:
    cfg = tmp_path / "weak.toml"
    cfg.write_text("[[simulator.site.weak]]\nid = 5\ndetection = 0.3\n", encoding="utf-8")
    log = simulate_log(tmp_path / "w.mcap", 30.0, 4, scenario="warehouse",
                       sets=["sim.nav_device=nav350"], config=cfg)
    clean: list[tuple[float, int]] = []
    weak: list[tuple[float, int]] = []
    for m in LogReader(log).messages(["/nav/reflectors"]):
        for o in m.data["observations"]:
            assert 1 <= o["mean_echo"] <= ECHO_FULL and o["hit_count"] >= 1
            (weak if o["id"] == 5 else clean).append((o["range"], o["mean_echo"]))
    assert weak and clean
    near = [e for r, e in clean if r <= 11.5]  # within the full range (12 m): no fall-off
    far = [e for r, e in clean if r >= 20.0]
    assert near and all(e == ECHO_FULL for e in near)
    assert far and max(far) < ECHO_FULL * (12.0 / 19.5) ** 2
    # 0.3 of the clean reflectors' 0.9: a third of the echo, less beyond the full range
    assert all(e <= math.ceil(ECHO_FULL / 3) for _, e in weak)
