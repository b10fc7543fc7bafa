"""``lgvtool replay`` writes what Foxglove draws: frames, the NAV head and its scans, covariance
ellipses, the reference circle; all in the right place (checked against the simulator's
truth and map) and opened by the layout in docs/."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from simlogs import cloud_points

from lgvtool.log import LogReader, topics
from lgvtool.log.messages import yaw_from_quaternion

REPO = Path(__file__).resolve().parent.parent
LAYOUT = REPO / "docs" / "foxglove-layout.json"


def _cli(*args: object) -> None:
    p = subprocess.run([sys.executable, "-m", "lgvtool", *map(str, args)], capture_output=True,
                       text=True, timeout=300, check=False)
    assert p.returncode == 0, p.stderr


@pytest.fixture(scope="module")
def replayed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("view")
    _cli("simulate", "-s", "paper-circle", "--duration", 30, "--set", "sim.paper_scans=true",
         "-o", d / "sim.mcap")
    _cli("replay", d / "sim.mcap", "-o", d / "rep.mcap", "--particles", 200)
    return d / "rep.mcap"


def _msgs(log: LogReader, topic: str) -> list:
    return [m.data for m in log.messages([topic])]


def _truth(log: LogReader) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    rows = [(m.log_time_ns, m.data["pose"]["position"]["x"], m.data["pose"]["position"]["y"],
             yaw_from_quaternion(m.data["pose"]["orientation"]))
            for m in log.messages([topics.TRUTH])]
    t, x, y, h = (np.array(c) for c in zip(*rows, strict=True))
    return t, x, y, h


def test_view_channels_are_written(replayed: Path) -> None:
    log = LogReader(replayed)
    names = set(log.topic_names())
    for t in topics.VIEW_TOPICS:
        assert t in names, t
    for est in ("laser", "deadreckoning", "ekf", "pf-paper", "pf"):
        assert topics.estimate_tf(est) in names and topics.estimate_covariance(est) in names
    counts = log.topics()
    assert counts[topics.NAV_SCAN].count == counts[topics.NAV_REFLECTORS].count
    assert counts[topics.estimate_tf("ekf")].count == counts[topics.estimate_pose("ekf")].count


def test_estimate_frames_follow_the_estimates(replayed: Path) -> None:
    log = LogReader(replayed)
    cfg = log.config()
    poses = _msgs(log, topics.estimate_pose("ekf"))
    tfs = _msgs(log, topics.estimate_tf("ekf"))
    for p, tf in zip(poses[::10], tfs[::10], strict=True):
        world, mount = tf["transforms"]
        assert (world["parent_frame_id"], world["child_frame_id"]) == ("map", "ekf/O")
        assert (mount["parent_frame_id"], mount["child_frame_id"]) == ("ekf/O", "ekf/head")
        assert world["timestamp"] == p["timestamp"]
        assert world["translation"]["x"] == pytest.approx(p["pose"]["position"]["x"], rel=1e-12)
        assert world["rotation"]["z"] == pytest.approx(p["pose"]["orientation"]["z"],
                                                       abs=1e-12)
        assert mount["translation"]["x"] == pytest.approx(cfg.vehicle.nav_x, rel=1e-12)
    states = _msgs(log, topics.estimate_state("ekf"))
    ells = _msgs(log, topics.estimate_covariance("ekf"))
    for s, e in zip(states[5::20], ells[5::20], strict=True):
        (sphere,) = e["entities"][0]["spheres"]
        c = s["covariance"]
        # the ellipse's area is that of the 2-sigma ellipse of the position covariance
        area = sphere["size"]["x"] * sphere["size"]["y"] / 4
        assert area == pytest.approx(4 * math.sqrt(c[0] * c[4] - c[1] ** 2), rel=1e-6)


def test_nav_frames_put_o_near_the_truth(replayed: Path) -> None:
    """map -> nav/O from the NAV's head pose lands on the true O (the NAV's error is a few
    cm; 0.3 m bounds it with a wide margin for a noisier simulator)."""
    log = LogReader(replayed)
    t, x, y, _h = _truth(log)
    n = 0
    for m in log.messages([topics.NAV_TF]):
        world = m.data["transforms"][0]
        assert world["child_frame_id"] == "nav/O"
        i = int(np.argmin(np.abs(t - m.log_time_ns)))
        if abs(t[i] - m.log_time_ns) > 30_000_000:
            continue
        # the NAV reports the head pose somewhat before it is received: allow 0.2 s of travel
        d = math.hypot(world["translation"]["x"] - x[i], world["translation"]["y"] - y[i])
        assert d < 0.3 + 0.2 * 0.4
        n += 1
    assert n > 20


def test_scans_drawn_in_the_head_frame_land_on_the_map(replayed: Path) -> None:
    """Each scan is one foxglove.PointCloud in the head frame at the scan's start: every
    observed reflector, carried to the map by the true head pose at that instant, lies on the
    map's reflector of its id."""
    log = LogReader(replayed)
    assert log.topics()[topics.NAV_SCAN].schema == "foxglove.PointCloud"
    cfg = log.config()
    refl = {r.id: (r.x, r.y) for r in log.reflector_map()}
    t, x, y, h = _truth(log)
    h = np.unwrap(h)
    checked = 0
    for m in log.messages([topics.NAV_SCAN]):
        assert m.data["frame_id"] == "nav/head"
        ns = m.data["timestamp"]["sec"] * 1_000_000_000 + m.data["timestamp"]["nsec"]
        if not t[0] <= ns <= t[-1]:
            continue
        ox, oy, oh = (float(np.interp(ns, t, v)) for v in (x, y, h))
        c, s = math.cos(oh), math.sin(oh)
        hx = ox + c * cfg.vehicle.nav_x - s * cfg.vehicle.nav_y
        hy = oy + s * cfg.vehicle.nav_x + c * cfg.vehicle.nav_y
        for p in cloud_points(m.data):
            mx, my = hx + c * p["x"] - s * p["y"], hy + s * p["x"] + c * p["y"]
            if p["id"] >= 0:
                rx, ry = refl[int(p["id"])]
                # the simulated laser's error is a few cm; 0.3 m leaves room for a noisier one
                assert math.hypot(rx - mx, ry - my) < 0.3
                checked += 1
    assert checked > 50


def test_reference_circle_is_the_kinematic_one(replayed: Path) -> None:
    log = LogReader(replayed)
    cfg = log.config()
    (msg,) = _msgs(log, topics.REFERENCE)
    pts = msg["entities"][0]["lines"][0]["points"]
    cx = float(np.mean([p["x"] for p in pts]))
    cy = float(np.mean([p["y"] for p in pts]))
    r = float(np.mean([math.hypot(p["x"] - cx, p["y"] - cy) for p in pts]))
    assert r == pytest.approx(cfg.vehicle.h / math.tan(math.radians(60)), rel=0.02)
    _t, x, y, _h = _truth(log)
    radial = np.hypot(x - cx, y - cy) - r
    moving = np.abs(radial) < 0.2  # the drive, not the lead-in at standstill
    assert moving.mean() > 0.5
    assert float(np.sqrt(np.mean(radial[moving] ** 2))) < 0.05


def test_replaying_a_replayed_log_replaces_the_view(replayed: Path, tmp_path: Path) -> None:
    out = tmp_path / "again.mcap"
    _cli("replay", replayed, "-o", out, "-e", "ekf")
    a, b = LogReader(replayed).topics(), LogReader(out).topics()
    assert b[topics.NAV_SCAN].count == a[topics.NAV_SCAN].count
    assert b[topics.REFERENCE].count == 1
    sys.path.insert(0, str(REPO / "tests" / "log"))
    from mcap_doctor import assert_reference_clean

    assert_reference_clean(out)


def test_no_view_leaves_them_out(replayed: Path, tmp_path: Path) -> None:
    src = tmp_path / "sim.mcap"
    _cli("simulate", "-s", "paper-circle", "--duration", 12, "--set", "sim.paper_scans=true",
         "-o", src)
    out = tmp_path / "plain.mcap"
    _cli("replay", src, "-o", out, "-e", "ekf", "--no-view")
    names = set(LogReader(out).topic_names())
    assert not names & set(topics.VIEW_TOPICS)
    assert topics.estimate_tf("ekf") not in names and topics.estimate_pose("ekf") in names


def test_layout_opens_every_view_channel(replayed: Path) -> None:
    """The Foxglove layout in docs/ is a layout document whose panels name only topics a
    replayed log has, and whose 3D panel shows every drawable one."""
    layout = json.loads(LAYOUT.read_text())
    assert {"configById", "layout", "globalVariables", "userNodes"} <= set(layout)
    names = set(LogReader(replayed).topic_names())
    panels = layout["configById"]
    three_d = [c for k, c in panels.items() if k.startswith("3D!")]
    assert len(three_d) == 1
    shown = {t for t, v in three_d[0]["topics"].items() if v.get("visible")}
    assert shown <= names
    drawable = {n for n in names if LogReader(replayed).topics()[n].schema in (
        "foxglove.SceneUpdate", "foxglove.PoseInFrame", "foxglove.PosesInFrame",
        "foxglove.PointCloud")}
    assert drawable <= shown
    logs = [c for k, c in panels.items() if k.startswith("RosOut!") or k.startswith("Log!")]
    assert logs and all(c["topicToRender"] == topics.DIAGNOSTICS_LOG for c in logs)
    text = json.dumps(layout)
    for key, cfg in panels.items():
        if key.startswith("Plot!"):
            for p in cfg["paths"]:
                assert p["value"].split(".")[0] in names, p["value"]
    assert "/work" not in text


def test_view_draws_the_scans_the_estimators_decoded_as_its_own_reading_would() -> None:
    """replay hands the view the scans the estimators decoded; the view's rows are then those of
    its own reading of the log, array for array (and nothing is shared before a decode)."""
    from lgvtool.localize.installation import correct_scans
    from lgvtool.localize.logdata import LazyScans, load_log, scan_batch
    from lgvtool.log.view_channels import LogRows

    reader = LogReader(REPO / "sample_logs" / "degraded.mcap")
    scans = load_log(reader).scans
    assert isinstance(scans, LazyScans)
    assert scans.decoded_columns() is None
    scan_batch(correct_scans(scans, 0.03, 0.01), [0])  # an estimator with an installation fix
    shared = scans.decoded_columns()
    assert shared is not None
    own_t, own = LogRows(reader).columns(topics.NAV_REFLECTORS)
    t, cols = LogRows(reader, shared).columns(topics.NAV_REFLECTORS)
    np.testing.assert_array_equal(t, own_t)
    assert len(cols) == len(own) == 6
    for a, b in zip(cols, own, strict=True):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)


def test_replay_reads_its_input_once_for_the_estimators_and_the_view(
        tmp_path: Path, chunk_passes: list[list[str]]) -> None:
    """The view's rows (NAV poses, truth, MCU frames) are gathered in the estimators' reading
    of the log (a tap of load_log): one pass over the chunks before the copy, and the rows are
    those of the view's own reading, topic for topic, array for array."""
    from lgvtool.app.replay_job import ReplayOptions, replay_log
    from lgvtool.localize.logdata import LazyScans, load_log
    from lgvtool.log.view_channels import LogRows, RowCollector

    log = REPO / "sample_logs" / "degraded.mcap"
    replay_log(ReplayOptions(str(log), str(tmp_path / "out.mcap"), estimators=("laser", "ekf"),
                             show_progress=False))
    assert len(chunk_passes) == 1 and {topics.TRUTH, topics.MCU_FRAME} <= set(chunk_passes[0])
    chunk_passes.clear()

    reader = LogReader(log)
    collector = RowCollector(reader, skip_scans=True)
    data = load_log(reader, tap=collector)
    assert topics.NAV_REFLECTORS not in collector.topics
    scans = data.scans
    assert isinstance(scans, LazyScans)
    scans.decoded()
    gathered = LogRows(reader, scans.decoded_columns(), collector)
    own = LogRows(reader)
    for topic in (topics.NAV_POSE, topics.TRUTH, topics.MCU_FRAME, topics.NAV_REFLECTORS):
        t, cols = gathered.columns(topic)
        own_t, own_cols = own.columns(topic)
        assert len(own_t) > 100
        np.testing.assert_array_equal(t, own_t)
        for a, b in zip(cols, own_cols, strict=True):
            assert a.dtype == b.dtype
            np.testing.assert_array_equal(a, b)


def test_a_view_row_that_does_not_match_the_contract_is_one_error_naming_its_topic() -> None:
    """Gathered for the view in the estimators' reading, a truth pose without a pose is one
    LogFormatError naming the log, the topic and its schema (it was an internal error)."""
    from lgvtool.errors import LogFormatError
    from lgvtool.log.view_channels import RowCollector

    collector = RowCollector(LogReader(REPO / "sample_logs" / "degraded.mcap"), skip_scans=True)
    ns = np.array([1_704_067_200_000_000_000], dtype=np.int64)
    with pytest.raises(LogFormatError,
                       match=r"degraded\.mcap: topic /truth/pose: .*PoseInFrame.*KeyError"):
        collector.add({topics.TRUTH: (ns, [b'{"x": 1}'])})


def test_a_replay_whose_estimators_use_no_scan_decodes_them_for_the_view_in_its_one_read(
        tmp_path: Path, chunk_passes: list[list[str]]) -> None:
    """With only the laser baseline (NAV poses), no estimator uses the scans, but the view
    draws them: they are decoded in the one pass over the log, not read again after it."""
    from lgvtool.app.replay_job import ReplayOptions, replay_log

    replay_log(ReplayOptions(str(REPO / "sample_logs" / "degraded.mcap"),
                             str(tmp_path / "out.mcap"), estimators=("laser",),
                             show_progress=False))
    assert len(chunk_passes) == 1 and topics.NAV_REFLECTORS in chunk_passes[0]
    assert len(_msgs(LogReader(tmp_path / "out.mcap"), topics.NAV_SCAN)) > 100
