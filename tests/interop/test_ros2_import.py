"""``lgvtool import ros2``: bags written in code from a simulated drive, imported, replayed and
evaluated like any log; bad bags and options refused with one line."""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from ros2_bags import Bag, bag_from_log

from lgvtool.app.evaluate_job import evaluate_log
from lgvtool.config import to_toml
from lgvtool.interop.ros2_import import import_bag
from lgvtool.log import LogReader, topics

CLI = Callable[..., tuple[int, str, str]]


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("ros2")


@pytest.fixture(scope="module")
def hall(sim_log: Path, folder: Path) -> Path:
    """The drive's vehicle and reflector map, with a wrong mounting (the bag's /tf wins)."""
    d = LogReader(sim_log).config().to_dict()
    d.pop("simulator")
    d["vehicle"]["nav_x"] = 0.3
    path = folder / "hall.toml"
    path.write_text(to_toml(d))
    return path


@pytest.fixture(scope="module")
def mcap_bag(sim_log: Path, folder: Path) -> Path:
    return bag_from_log(sim_log, folder / "drive_bag")


@pytest.fixture(scope="module")
def imported(mcap_bag: Path, hall: Path, folder: Path) -> Path:
    out = folder / "imported.mcap"
    import_bag(mcap_bag, out, config=hall)
    return out


def test_an_imported_bag_evaluates_like_the_simulated_log(sim_log: Path, imported: Path) -> None:
    original = evaluate_log(sim_log, estimators=["laser"])
    result = evaluate_log(imported, estimators=["laser", "ekf", "pf"])
    laser = result.estimators["laser"].truth
    reference = original.estimators["laser"].truth
    assert laser is not None and reference is not None
    # the same NAV poses, rounded to mm and mdeg by the NAV350 messages
    assert laser.samples == reference.samples
    assert laser.position_rmse == pytest.approx(reference.position_rmse, abs=1e-3)
    for name in ("ekf", "pf"):
        truth = result.estimators[name].truth
        assert truth is not None and truth.samples > 100
        assert truth.position_rmse < laser.position_rmse, name


def test_the_log_holds_the_contract_channels_and_the_mounting_of_tf(imported: Path,
                                                                    sim_log: Path) -> None:
    reader = LogReader(imported)
    names = set(reader.topic_names())
    assert {topics.ODOM, topics.NAV_POSE, topics.NAV_REFLECTORS, topics.TRUTH,
            topics.MAP} <= names
    cfg = reader.config()
    assert cfg.vehicle.nav_x == pytest.approx(LogReader(sim_log).config().vehicle.nav_x,
                                              abs=1e-9)
    assert len(cfg.reflectors) == len(LogReader(sim_log).config().reflectors)
    record = reader.metadata["importer"]
    assert record["importer"] == "ros2" and record["mounting"]["source"].startswith("tf")
    scans = reader.dataframe(topics.NAV_REFLECTORS)
    original = LogReader(sim_log).dataframe(topics.NAV_REFLECTORS)
    assert len(scans) == len(original)
    assert np.allclose(scans["range"], original["range"], atol=6e-4)
    assert (scans["id"].to_numpy() == original["id"].to_numpy()).all()
    from mcap.reader import make_reader

    with open(imported, "rb") as f:
        assert sum(1 for _ in make_reader(f).iter_messages()) > 0


def test_every_imported_message_validates_against_its_schema(imported: Path) -> None:
    import json

    import jsonschema

    from lgvtool.log.schemas import schema_json

    validators: dict[str, jsonschema.Draft202012Validator] = {}
    for m in LogReader(imported).raw_messages():
        if m.schema not in validators:
            validators[m.schema] = jsonschema.Draft202012Validator(schema_json(m.schema))
        validators[m.schema].validate(json.loads(m.data))
    assert {"lgvtool.Odometry", "lgvtool.NavPose", "lgvtool.ReflectorScan",
            "foxglove.PoseInFrame"} <= set(validators)


def _yaw_rate_ratio(log: Path) -> float:
    """Median of the logged yaw rate over the true one while turning."""
    reader = LogReader(log)
    odom = reader.dataframe(topics.ODOM)
    truth = reader.dataframe(topics.TRUTH)
    h = np.unwrap(truth["heading"].to_numpy())
    rate = np.diff(h) / np.diff(truth["t"].to_numpy())
    true_at = np.interp(odom["t"].to_numpy(), truth["t"].to_numpy()[:-1], rate)
    turning = np.abs(true_at) > 0.1
    return float(np.median(odom["omega"].to_numpy()[turning] / true_at[turning]))


def test_the_gyro_gives_the_yaw_rate(mcap_bag: Path, imported: Path, folder: Path) -> None:
    """The bag's wheel odometry overstates the yaw rate by 10 %, its gyro is exact."""
    assert _yaw_rate_ratio(imported) == pytest.approx(1.0, abs=1e-3)
    without = folder / "no_gyro.mcap"
    summary = import_bag(mcap_bag, without, topic_options=["gyro=none"])
    assert summary.yaw_rate == "odometry"
    assert _yaw_rate_ratio(without) == pytest.approx(1.1, abs=1e-3)


def test_a_single_sqlite_file_with_twist_odometry(sim_log: Path, hall: Path, folder: Path,
                                                  cli: CLI) -> None:
    bag = bag_from_log(sim_log, folder / "sqlite_bag", storage="sqlite3", odometry="twist")
    db3 = next(bag.glob("*.db3"))
    before = {p.name: p.read_bytes() for p in bag.iterdir()}
    out = folder / "from_db3.mcap"
    code, text, err = cli("import", "ros2", db3, "-o", out, "--config", hall, "--json")
    assert code == 0, err
    assert {p.name: p.read_bytes() for p in bag.iterdir()} == before  # the bag is untouched
    assert '"odom"' in text and "TwistStamped" in text
    result = evaluate_log(out, estimators=["laser", "ekf"])
    assert result.estimators["ekf"].truth is not None
    code, _, err = cli("replay", out, "-e", "ekf", "-o", folder / "replayed.mcap")
    assert code == 0, err


# ----------------------------------------------------------------------- bad input


WHEELS = "acme_msgs/msg/WheelSpeeds"


def _tiny(path: Path, *, odom: int = 1, nav: bool = True, storage: str = "mcap",
          write_extra: bool = False) -> Path:
    """A few messages: ``odom`` Odometry topics, a PoseStamped NAV pose and, with
    ``write_extra``, a vendor's message type on /wheels."""
    from rosbags.typesys import get_types_from_msg

    with Bag(path, storage) as bag:
        if write_extra:
            bag.store.register(get_types_from_msg("float64 left\nfloat64 right\n", WHEELS))
        for k in range(20):
            if write_extra:
                ns = 1_700_000_000_000_000_000 + k * 100_000_000
                bag.write("/wheels", WHEELS, bag.T[WHEELS](left=0.2, right=0.21), ns)
            ns = 1_700_000_000_000_000_000 + k * 100_000_000
            for i in range(odom):
                bag.write(f"/odom{i or ''}", "nav_msgs/msg/Odometry", bag.odometry(ns, 0.2, 0.1),
                          ns)
            if nav:
                bag.write("/nav_pose", "geometry_msgs/msg/PoseStamped",
                          bag.pose_stamped(ns, 5.0 + 0.02 * k, 5.0, 0.01 * k), ns)
    return path


@pytest.mark.parametrize(("kwargs", "options", "expected"), [
    ({"odom": 0}, [], "no usable odometry"),
    ({"nav": False}, [], "no observation topic"),
    ({"odom": 2}, [], "choose one with --topic odom=/name"),
    ({}, ["--topic", "wheels=/odom"], "no role 'wheels'"),
    ({}, ["--topic", "gyro=/odom"], "nav_msgs/Odometry is not a type the gyro role reads"),
    ({}, ["--topic", "truth=/vicon"], "no such topic"),
    ({}, ["--topic", "odom"], "ROLE=/name"),
])
def test_bad_bags_and_options(tmp_path: Path, cli: CLI,
                              kwargs: dict[str, object], options: list[str],
                              expected: str) -> None:
    bag = _tiny(tmp_path / "bag", **kwargs)  # type: ignore[arg-type]
    code, _, err = cli("import", "ros2", bag, "-o", tmp_path / "out.mcap", *options)
    assert code == 2
    assert expected in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out.mcap").exists()


def test_a_custom_message_type_on_a_chosen_topic(tmp_path: Path, cli: CLI) -> None:
    """A type defined only in the bag (here a vendor's wheel message) plays no role."""
    bag_path = _tiny(tmp_path / "bag", write_extra=True)
    code, _, err = cli("import", "ros2", bag_path, "-o", tmp_path / "o.mcap", "--topic",
                       "odom=/wheels")
    assert code == 2 and "acme_msgs/WheelSpeeds is not a type the odom role reads" in err
    code, _, err = cli("import", "ros2", bag_path, "-o", tmp_path / "o.mcap")
    assert code == 0, err


def test_a_good_tiny_bag_and_the_overwrite_policy(tmp_path: Path,
                                                  cli: CLI) -> None:
    bag = _tiny(tmp_path / "bag")
    out = tmp_path / "out.mcap"
    code, text, err = cli("import", "ros2", bag, "-o", out)
    assert code == 0, err
    assert "/nav_pose" in text and "no --config" in text
    before = out.read_bytes()
    code, _, err = cli("import", "ros2", bag, "-o", out)
    assert code == 2 and "--force" in err and out.read_bytes() == before
    assert cli("import", "ros2", bag, "-o", out, "--force")[0] == 0
    code, _, err = cli("import", "ros2", bag, "-o", bag / "inside.mcap")
    assert code == 2 and "inside the input" in err
    nav = LogReader(out).dataframe(topics.NAV_POSE)
    assert len(nav) == 20 and nav["heading"].iloc[-1] == pytest.approx(0.19, abs=1e-9)
    # a PoseStamped in map is base_link's pose (REP 105): stored as the head's, 1 m ahead with
    # the default mounting, which the laser baseline's conversion to O takes off again
    assert math.isclose(nav["x"].iloc[1], 5.02 + math.cos(0.01), abs_tol=1e-9)
    assert math.isclose(nav["y"].iloc[1], 5.0 + math.sin(0.01), abs_tol=1e-9)


def test_files_that_are_not_bags(tmp_path: Path, imported: Path,
                                 cli: CLI) -> None:
    cases = [
        (imported, "not a readable rosbag2 bag"),    # an lgvtool log: JSON, not CDR
        (tmp_path / "empty", "without metadata.yaml"),
        (tmp_path / "missing", "no such file"),
        (tmp_path / "notes.txt", "not a rosbag2 bag"),
    ]
    (tmp_path / "notes.txt").write_text("hello")
    (tmp_path / "empty").mkdir()
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 40)
    cases.append((broken, "not a readable rosbag2 bag"))
    for path, expected in cases:
        code, _, err = cli("import", "ros2", path, "-o", tmp_path / "o.mcap")
        assert code == 2 and expected in err, (path, err)
        assert len(err.strip().splitlines()) == 1


def test_without_rosbags_the_extra_is_named(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                            cli: CLI) -> None:
    bag = _tiny(tmp_path / "bag")
    monkeypatch.setitem(sys.modules, "rosbags", None)
    code, _, err = cli("import", "ros2", bag, "-o", tmp_path / "o.mcap")
    assert code == 2 and "[ros2]'" in err


def test_the_mounting_follows_a_chain_of_transforms() -> None:
    from lgvtool.interop.ros2_bag import BagContent
    from lgvtool.interop.ros2_import import mounting

    content = BagContent(transforms={"laser": ("mount", 0.1, 0.0, 0.0),
                                     "mount": ("base_link", 0.9, 0.2, math.pi / 2),
                                     "base_link": ("odom", 5.0, 5.0, 0.0)},
                         vehicle_frames=["base_link"], sensor_frames=["laser"])
    found = mounting(content, None)
    assert found is not None
    x, y, yaw, chain = found
    assert (x, y, yaw) == pytest.approx((0.9, 0.3, math.pi / 2), abs=1e-12)
    assert chain == "base_link->laser"
    assert mounting(content, "elsewhere") is None


def test_the_gyro_mean_over_each_odometry_interval() -> None:
    from lgvtool.interop.ros2_import import fused_yaw_rate

    odom_t = np.array([0.0, 1.0, 2.0, 3.0])
    gyro_t = np.array([0.2, 0.4, 1.5, 3.2])
    gyro_w = np.array([1.0, 3.0, 5.0, 7.0])
    got = fused_yaw_rate(odom_t, np.full(4, -1.0), gyro_t, gyro_w)
    # [0,1): mean 2; [1,2): 5; [2,3): none, interpolated at 2.5 between 5 and 7; [3,4): 7
    assert got == pytest.approx([2.0, 5.0, 5.0 + 2.0 * (1.0 / 1.7), 7.0], abs=1e-12)


def test_reflector_times_across_the_tick_counter_wrap(tmp_path: Path) -> None:
    from lgvtool.interop.ros2_bag import BagContent, _read_reflectors

    bag = Bag(tmp_path / "unused")
    ns = 1_700_000_000_000_000_000
    msg = bag.landmarks(ns, [{"range": 5.0, "bearing": 0.5, "id": 3, "time_in_scan": 0.0},
                             {"range": 6.0, "bearing": -0.5, "id": -1, "time_in_scan": 0.04}])
    msg.reflectors[0].timestamp = 2**32 - 10     # 10 ms before the counter wraps
    msg.reflectors[1].timestamp = 30             # 30 ms after it
    content = BagContent()
    _read_reflectors(content, msg, "", ns)
    (_t, period, obs), = content.scans
    assert [o["time_in_scan"] for o in obs] == pytest.approx([0.0, 0.04], abs=1e-12)
    assert [o["id"] for o in obs] == [3, 0] and period == pytest.approx(0.125)
    assert obs[1]["bearing"] == pytest.approx(-0.5, abs=1e-5)


def test_an_imported_bag_passes_the_reference_checker(imported: Path) -> None:
    """The reference checker's checks (tests/log/mcap_doctor.py, through the ``mcap``
    package's reader): no error, no avoidable warning, Statistics matching the messages, and
    every message valid against the schema embedded with it."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "log"))
    from mcap_doctor import assert_reference_clean, schema_errors

    assert_reference_clean(imported)
    assert schema_errors(imported) == []


@pytest.fixture(scope="module")
def nav350_pair(folder: Path) -> tuple[Path, Path]:
    """A simulated NAV350 drive and its import from the bag sick_scan_xd would have recorded
    (NAVPoseData and NAVLandmarkData with their optional blocks)."""
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    log = folder / "nav350.mcap"
    write_log(simulate("warehouse", seed=5, duration=60.0,
                       overrides={"sim.nav_device": "nav350"}), log)
    d = LogReader(log).config().to_dict()
    d.pop("simulator")
    hall = folder / "nav350-hall.toml"
    hall.write_text(to_toml(d))
    out = folder / "nav350-imported.mcap"
    import_bag(bag_from_log(log, folder / "nav350_bag"), out, config=hall)
    return log, out


def test_a_nav350_bag_keeps_what_the_device_says(nav350_pair: tuple[Path, Path]) -> None:
    """meanDev, navMode, infoState and the tick of every pose, and each reflector's ids,
    quality, hit count, mean echo and tick: as the recorded NAV350 log has them."""
    log, imported = nav350_pair
    poses = [[m.data.get(k) for m in LogReader(p).messages([topics.NAV_POSE])]
             for p in (log, imported) for k in ("device_time_ms", "mean_dev", "nav_mode",
                                                "info_state", "quality", "valid")]
    assert all(None not in column for column in poses)
    assert poses[:6] == poses[6:]
    keys = ("global_id", "quality", "hit_count", "mean_echo", "device_time_ms")
    scans = [[tuple(o.get(k) for k in keys) for m in LogReader(p).messages(
        [topics.NAV_REFLECTORS]) for o in m.data["observations"]] for p in (log, imported)]
    assert len(scans[0]) > 1000 and scans[0] == scans[1]


def test_a_nav350_bag_audits_as_the_recorded_log(nav350_pair: tuple[Path, Path],
                                                 tmp_path: Path, cli: CLI) -> None:
    """The navigation health of the import: the device, meanDev and its clock as recorded,
    and no localisation score made up from a pose that carries no quality."""
    import json

    docs = []
    for k, path in enumerate(nav350_pair):
        out = tmp_path / f"audit{k}"
        code, _, err = cli("audit", path, "-o", out, "-e", "ekf", "--no-progress")
        assert code == 0, err
        docs.append(json.loads((out / "audit.json").read_text())["navigation"]["logs"][0])
    recorded, imported = docs
    assert imported["device"] == recorded["device"] == "nav350"
    assert imported["mean_dev"] == recorded["mean_dev"] and recorded["mean_dev"]["p50"] > 0
    assert imported["nav_mode"] == recorded["nav_mode"]
    assert imported["clock_jumps"] == recorded["clock_jumps"] == []
    assert imported["clock_drift_ppm"] == pytest.approx(recorded["clock_drift_ppm"], abs=1.0)
    assert imported["vda5050"]["localizationScore"] is None
