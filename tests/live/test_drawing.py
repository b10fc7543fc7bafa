"""The live feed's drawing: what replay draws from a log's own data (the NAV, its scans, the
ground truth's frames), made one message at a time as a recording arrives
(lgvtool.live.drawing)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import orjson
import pytest
from simlogs import cloud_points

from lgvtool.live.drawing import LiveDrawing
from lgvtool.log import LogReader, topics
from lgvtool.log.foxglove import mounting_of


@pytest.fixture(scope="module")
def replayed(circle_log: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("navview") / "rep.mcap"
    subprocess.run([sys.executable, "-m", "lgvtool", "replay", str(circle_log), "-o", str(out),
                    "-e", "laser"], check=True, capture_output=True, timeout=300)
    return out


def _live(log: Path, scans_on: str = "nav") -> dict[str, list[tuple[int, bytes]]]:
    """The drawing of ``log``'s raw messages fed one at a time, in log-time order."""
    reader = LogReader(log)
    view = LiveDrawing(mounting_of(reader.config().vehicle), scans_on)
    out: dict[str, list[tuple[int, bytes]]] = {}
    for m in reader.messages([topics.NAV_POSE, topics.NAV_REFLECTORS, topics.TRUTH]):
        for e in view.feed(m.topic, orjson.dumps(m.data), m.log_time_ns):
            out.setdefault(e.topic, []).append((m.log_time_ns, e.data))
    return out


def _close(a: object, b: object) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return list(a) == list(b) and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) or isinstance(b, float):
        return abs(float(a) - float(b)) <= 1e-9  # type: ignore[arg-type]
    return a == b


def test_the_live_drawing_draws_what_replay_draws(circle_log: Path, replayed: Path) -> None:
    live = _live(circle_log)
    rep = LogReader(replayed)
    for topic in (topics.NAV_HEAD, topics.NAV_TF, topics.TRUTH_TF):
        want = [(m.log_time_ns, m.data) for m in rep.messages([topic])]
        got = [(t, orjson.loads(d)) for t, d in live[topic]]
        assert len(got) == len(want) > 50
        assert all(tg == tw and _close(g, w) for (tg, g), (tw, w) in zip(got, want, strict=True))
    want_scans = [(m.log_time_ns, m.data) for m in rep.messages([topics.NAV_SCAN])]
    got_scans = [(t, orjson.loads(d)) for t, d in live[topics.NAV_SCAN]]
    assert len(got_scans) == len(want_scans) > 100
    same = 0
    gaps = []
    for (tg, g), (tw, w) in zip(got_scans, want_scans, strict=True):
        assert tg == tw and g["timestamp"] == w["timestamp"] and g["frame_id"] == "nav/head"
        pg, pw = cloud_points(g), cloud_points(w)
        assert pg["id"].tolist() == pw["id"].tolist()
        gap = float(np.hypot(pg["x"] - pw["x"], pg["y"] - pw["y"]).max())
        gaps.append(gap)
        same += gap < 1e-4
    # live knows the head's poses up to now only and continues the last two past it: on the
    # circle that is close to replay's poses on both sides (measured: median 0.04 m, max 0.27)
    assert max(gaps) < 0.4 and float(np.median(gaps)) < 0.1
    # where the NAV poses around every observation have arrived, the point is replay's
    assert same > 10


def test_a_log_without_nav_poses_has_its_scans_drawn_on_the_truth_s_head(circle_log: Path
                                                                          ) -> None:
    """As replay draws an imported dataset's scans: on the ground truth's head, each point
    carried along the truth's head poses (here close to where the true head saw it)."""
    reader = LogReader(circle_log)
    cfg = reader.config()
    refl = {r.id: (r.x, r.y) for r in reader.reflector_map()}
    view = LiveDrawing(mounting_of(cfg.vehicle), "truth")
    truth: list[tuple[int, float, float, float]] = []
    checked = 0
    for m in reader.messages([topics.TRUTH, topics.NAV_REFLECTORS]):  # no NAV pose fed
        if m.topic == topics.TRUTH:
            view.feed(m.topic, orjson.dumps(m.data), m.log_time_ns)
            p, q = m.data["pose"]["position"], m.data["pose"]["orientation"]
            truth.append((m.log_time_ns, p["x"], p["y"], 2.0 * np.arctan2(q["z"], q["w"])))
            continue
        (cloud,) = view.feed(m.topic, orjson.dumps(m.data), m.log_time_ns)
        msg = orjson.loads(cloud.data)
        assert msg["frame_id"] == "truth/head"
        ns = msg["timestamp"]["sec"] * 1_000_000_000 + msg["timestamp"]["nsec"]
        if len(truth) < 2 or not truth[0][0] <= ns <= truth[-1][0]:
            continue
        # the true head at the scan's start (the truth received so far brackets it)
        t, x, y, h = (np.array(c) for c in zip(*truth, strict=True))
        ox, oy, oh = (float(np.interp(ns, t, v)) for v in (x, y, np.unwrap(h)))
        c, s = np.cos(oh), np.sin(oh)
        hx = ox + c * cfg.vehicle.nav_x - s * cfg.vehicle.nav_y
        hy = oy + s * cfg.vehicle.nav_x + c * cfg.vehicle.nav_y
        for pt in cloud_points(msg):
            if pt["id"] >= 0:
                mx, my = hx + c * pt["x"] - s * pt["y"], hy + s * pt["x"] + c * pt["y"]
                rx, ry = refl[int(pt["id"])]
                assert np.hypot(rx - mx, ry - my) < 0.3
                checked += 1
    assert checked > 100


def test_invalid_poses_and_empty_scans_draw_nothing() -> None:
    view = LiveDrawing(mounting_of(_vehicle()))
    bad = orjson.dumps({"timestamp": {"sec": 1, "nsec": 0}, "x": 1.0, "y": 2.0, "heading": 0.1,
                        "valid": False})
    assert view.feed(topics.NAV_POSE, bad, 1_000_000_000) == []
    empty = orjson.dumps({"timestamp": {"sec": 1, "nsec": 0}, "scan_period": 0.125,
                          "observations": []})
    assert view.feed(topics.NAV_REFLECTORS, empty, 1_000_000_000) == []
    assert view.feed(topics.MCU_FRAME, b"{}", 1) == []
    with pytest.raises(ValueError):
        LiveDrawing(mounting_of(_vehicle()), "pf")


def _vehicle() -> object:
    from lgvtool.config import default_config

    return default_config().vehicle
