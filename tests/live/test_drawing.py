"""The live feed's drawing: what replay draws from a log's own data (the NAV, its scans, the
ground truth's frames), made one message at a time as a recording arrives
(lgvtool.live.drawing)."""

from __future__ import annotations

import itertools
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import orjson
import pytest
from simlogs import cloud_points

from lgvtool.config import Vehicle
from lgvtool.live.drawing import CIRCLE_PERIOD_NS, LiveDrawing, Thinned, drawing_of
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


def _circles(log: Path, *, truth: bool = True, mcu: bool = True
             ) -> list[tuple[int, dict[str, Any]]]:
    """The /reference/circle messages of the drawing of ``log`` (with its vehicle's steering
    geometry), fed its NAV poses and, as asked, its ground truth and MCU frames."""
    reader = LogReader(log)
    view = drawing_of(reader.config())
    wanted = [topics.NAV_POSE, topics.NAV_REFLECTORS] + [topics.TRUTH] * truth \
        + [topics.MCU_FRAME] * mcu
    out = []
    for m in reader.messages(wanted):
        for e in view.feed(m.topic, orjson.dumps(m.data), m.log_time_ns):
            if e.topic == topics.REFERENCE:
                out.append((m.log_time_ns, orjson.loads(e.data)))
    return out


def _circle_of(msg: dict[str, Any]) -> tuple[float, float, float, str]:
    """Centre (m), radius (m) and label text of a reference-circle scene update."""
    (entity,) = msg["entities"]
    pts = np.array([(p["x"], p["y"]) for p in entity["lines"][0]["points"]])
    cx, cy = pts.mean(axis=0)
    return float(cx), float(cy), float(np.hypot(*(pts[0] - (cx, cy)))), entity["texts"][0]["text"]


@pytest.fixture(scope="module")
def minute(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """60 s of the paper's circle drive (two and a half laps) and its replay."""
    from simlogs import simulate_log

    folder = tmp_path_factory.mktemp("minute")
    log = simulate_log(folder / "circle.mcap", 60.0, 5)
    out = folder / "rep.mcap"
    subprocess.run([sys.executable, "-m", "lgvtool", "replay", str(log), "-o", str(out),
                    "-e", "laser"], check=True, capture_output=True, timeout=300)
    return log, out


def test_the_live_drawing_draws_replay_s_reference_circle(minute: tuple[Path, Path]) -> None:
    """Fitted to the ground truth as it arrives, every 5 s of log time once the drive has gone
    3/4 of the way round, with the radius from the logged steering: by the end of the drive it
    is replay's circle (fitted to the whole truth once)."""
    log, replayed = minute
    live = _circles(log)
    (want,) = [m.data for m in LogReader(replayed).messages([topics.REFERENCE])]
    wx, wy, wr, wtext = _circle_of(want)
    times = [t for t, _ in live]
    start = next(iter(LogReader(log).messages([topics.TRUTH]))).log_time_ns
    # the first lap takes about 25 s (from the start at 5 s): first drawn then, then every 5 s
    assert len(live) >= 6 and times[0] - start <= 35_000_000_000
    assert all(b - a >= CIRCLE_PERIOD_NS for a, b in itertools.pairwise(times))
    gx, gy, gr, gtext = _circle_of(live[-1][1])
    assert gtext == wtext and "reference (truth)" in gtext
    # the kinematic radius of the median steering; live, of the median of the MCU frames
    # kept (at most 2000, evenly spread): measured 0.1 mm apart
    assert abs(gr - wr) < 1e-3
    assert np.hypot(gx - wx, gy - wy) < 0.005
    # stamped when it is drawn, not at the start of the drive
    stamp = live[-1][1]["entities"][0]["timestamp"]
    assert stamp["sec"] * 1_000_000_000 + stamp["nsec"] == times[-1]


def test_without_truth_the_circle_is_fitted_to_the_nav_and_without_mcu_frames_configured(
        minute: tuple[Path, Path]) -> None:
    """A recording (no ground truth): the circle through O's positions from the NAV poses; with
    no MCU frame either, of the configured steering angle's radius."""
    log, _ = minute
    cfg = LogReader(log).config()
    live = _circles(log, truth=False, mcu=False)
    assert len(live) >= 5
    gx, gy, gr, text = _circle_of(live[-1][1])
    assert "reference (nav)" in text
    from lgvtool.circle import kinematic_radius

    want_r = kinematic_radius(cfg.vehicle.h, np.radians(cfg.reference.steering_angle_deg))
    assert abs(gr - want_r) < 1e-6
    with_truth = _circle_of(_circles(log, mcu=False)[-1][1])
    assert np.hypot(gx - with_truth[0], gy - with_truth[1]) < 0.1


def test_a_drive_that_is_no_circle_draws_none(tmp_path: Path) -> None:
    from simlogs import simulate_log

    """A warehouse route's gentle curves fit circles of kilometres that the route does not go
    round: replay draws none (it drew one of 1964 m before the coverage rule), nor does the
    live drawing."""
    log = simulate_log(tmp_path / "wh.mcap", 120.0, 3, scenario="warehouse")
    assert _circles(log) == []
    out = tmp_path / "rep.mcap"
    subprocess.run([sys.executable, "-m", "lgvtool", "replay", str(log), "-o", str(out),
                    "-e", "laser"], check=True, capture_output=True, timeout=300)
    assert list(LogReader(out).messages([topics.REFERENCE])) == []


def test_the_drawing_without_the_steering_geometry_draws_no_circle(circle_log: Path) -> None:
    """``LiveDrawing`` without ``h`` (as the tests above feed it) draws no circle."""
    assert topics.REFERENCE not in _live(circle_log)


def test_thinned_keeps_a_bounded_even_spread() -> None:
    kept = Thinned(2, limit=100)
    for i in range(10_000):
        kept.offer(float(i), -float(i))
    a, b = kept.columns()
    assert 50 <= len(a) < 100 and (b == -a).all()
    gaps = np.diff(a)
    assert (gaps == gaps[0]).all() and a[0] == 0.0 and a[-1] > 9_000
    with pytest.raises(ValueError):
        Thinned(1, limit=1)


def test_invalid_poses_and_empty_scans_draw_nothing() -> None:
    view = LiveDrawing(mounting_of(_vehicle()))
    bad = orjson.dumps({"timestamp": {"sec": 1, "nsec": 0}, "x": 1.0, "y": 2.0, "heading": 0.1,
                        "valid": False})
    assert view.feed(topics.NAV_POSE, bad, 1_000_000_000) == []
    far = orjson.dumps({"timestamp": {"sec": 1, "nsec": 0}, "x": 1e308, "y": 2.0,
                        "heading": 0.1, "valid": True})  # a corrupt reply, as replay's view
    assert view.feed(topics.NAV_POSE, far, 1_000_000_000) == []
    empty = orjson.dumps({"timestamp": {"sec": 1, "nsec": 0}, "scan_period": 0.125,
                          "observations": []})
    assert view.feed(topics.NAV_REFLECTORS, empty, 1_000_000_000) == []
    assert view.feed(topics.MCU_FRAME, b"{}", 1) == []
    with pytest.raises(ValueError):
        LiveDrawing(mounting_of(_vehicle()), "pf")


def _vehicle() -> Vehicle:
    from lgvtool.config import default_config

    return default_config().vehicle
