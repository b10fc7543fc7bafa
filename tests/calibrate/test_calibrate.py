"""lgvtool calibrate: the installation errors recovered from simulated drives, the output used
as it is, and bad input refused with one line."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from calibrate_cases import TRUE

from lgvtool.calibrate.calibration_run import calibrate
from lgvtool.config import load_config
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate

# tolerances about three times the 1-sigma these short drives give (docs/calibration.md)
TOLERANCE = {"nav_x": 0.006, "nav_y": 0.006, "nav_yaw": math.radians(0.1), "track": 0.004,
             "wheel_radius_left": 0.075 * 0.001, "wheel_radius_right": 0.075 * 0.001,
             "gyro_scale": 0.001, "nav_time_offset": 0.006}


@pytest.fixture(scope="module")
def result(installed_logs: list[Path]):
    return calibrate([str(p) for p in installed_logs], compare_with=())


def test_installation_errors_recovered(result) -> None:
    for name, true in TRUE.items():
        e = result.estimates[name]
        assert e.status == "estimated"
        assert e.value == pytest.approx(true, abs=TOLERANCE[name]), name
        # the nominal value is far outside the uncertainty: the error was really found
        assert abs(e.start - true) > 3 * e.sigma or name == "nav_y", name


def test_true_values_inside_four_sigma(result) -> None:
    for name, true in TRUE.items():
        e = result.estimates[name]
        assert e.sigma is not None and e.sigma > 0
        assert abs(e.value - true) < 4 * e.sigma, (name, e.value, true, e.sigma)


def test_pose_age_and_output_config(result) -> None:
    # a NAV200 pose is at least its latency (40 ms) and half a revolution old
    assert result.estimates["nav_pose_age"].value > 0.06
    v = result.config.vehicle
    assert v.nav_yaw == result.estimates["nav_yaw"].value
    assert result.config.simulator == {}
    assert result.config.reflectors == result.start_config.reflectors


def test_cli_writes_a_usable_config(installed_logs: list[Path], tmp_path: Path, run_cli) -> None:
    out = tmp_path / "vehicle.toml"
    p = run_cli("calibrate", *installed_logs, "-o", out, "--json", "--compare", "laser,ekf")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    cfg = load_config(out)
    assert cfg.vehicle.nav_x == pytest.approx(doc["estimates"]["nav_x"]["value_si"], rel=1e-12)
    # MCU odometry: no scale priors; only the NAV poses' model, for the estimators that read it
    pose_model = {"pose_age_fit", "pose_latency_s", "pose_skew_fit", "pose_skew_x_m",
                  "pose_skew_y_m", "sigma_pose_xy_m", "sigma_pose_heading_rad"}
    assert set(doc["estimator_settings"]) <= {"ekf", "pf", "pf-paper"}
    assert all(set(t) <= pose_model for t in doc["estimator_settings"].values())
    assert run_cli("config", out).returncode == 0
    rows = {(r["log"], r["estimator"]): r for r in doc["comparison"]}
    # the EKF, which uses every reflector, gains most from the calibration
    assert rows[("all", "ekf")]["after_m"] < 0.7 * rows[("all", "ekf")]["before_m"]
    e = run_cli("evaluate", installed_logs[1], "--config", out, "-e", "laser", "--json")
    assert e.returncode == 0, e.stderr
    r = run_cli("replay", installed_logs[1], "--config", out, "-e", "laser", "-o",
                tmp_path / "replayed.mcap")
    assert r.returncode == 0, r.stderr


def test_cli_text_table(installed_logs: list[Path], tmp_path: Path, run_cli) -> None:
    out = tmp_path / "v.toml"
    p = run_cli("calibrate", *installed_logs, "-o", out, "--compare", "none",
                "--estimate", "nav_x,nav_y,nav_yaw,nav_time_offset")
    assert p.returncode == 0, p.stderr
    assert "nav_yaw" in p.stdout and "estimated" in p.stdout
    assert "track" in p.stdout and "fixed" in p.stdout
    assert load_config(out).vehicle.track == pytest.approx(0.6, rel=1e-12)


def test_output_equal_to_input(installed_logs: list[Path], run_cli) -> None:
    p = run_cli("calibrate", installed_logs[0], "-o", installed_logs[0], "--force")
    assert p.returncode == 2
    assert len(p.stderr.strip().splitlines()) == 1 and "input" in p.stderr


def test_straight_drive_cannot_observe_the_lever_arm(tmp_path: Path, run_cli) -> None:
    # the warehouse's first 15 s: standstill, then the first straight only
    sim = simulate("warehouse", seed=3, duration=15.0, overrides={"sim.paper_scans": True})
    log = tmp_path / "straight.mcap"
    write_log(sim, log)
    p = run_cli("calibrate", log, "-o", tmp_path / "v.toml", "--compare", "none",
                "--estimate", "nav_x,nav_y,nav_yaw")
    assert p.returncode == 2
    assert len(p.stderr.strip().splitlines()) == 1
    assert "nav_x" in p.stderr and "cannot observe" in p.stderr
    assert not (tmp_path / "v.toml").exists()
    p = run_cli("calibrate", log, "-o", tmp_path / "v.toml", "--compare", "none",
                "--estimate", "nav_x,nav_y,nav_yaw", "--allow-unobservable", "--json")
    assert p.returncode == 0, p.stderr
    doc = json.loads(p.stdout)
    assert doc["estimates"]["nav_x"]["status"] == "unobservable"
    assert doc["estimates"]["nav_x"]["value_si"] == pytest.approx(1.0, rel=1e-12)
    assert any("nav_x" in w for w in doc["warnings"])
    p = run_cli("calibrate", log, "-o", tmp_path / "v.toml", "--compare", "none", "--force",
                "--estimate", "nav_x,nav_y,nav_yaw", "--allow-unobservable")
    assert p.returncode == 0, p.stderr
    assert "warning" not in p.stdout
    said = p.stderr.strip().splitlines()
    assert said and all(line.startswith("lgvtool: warning: ") for line in said), said
    assert any("nav_x" in line for line in said)


def test_no_motion_or_no_observations(tmp_path: Path, run_cli) -> None:
    from lgvtool.log import LogReader, LogWriter, topics

    sim = simulate("paper-circle", seed=4, duration=12.0,
                   overrides={"sim.paper_scans": True})
    full = tmp_path / "full.mcap"
    write_log(sim, full)
    for drop, word in ((topics.MCU_FRAME, "motion"), (topics.NAV_REFLECTORS, "observations")):
        part = tmp_path / f"no-{word}.mcap"
        reader = LogReader(full)
        with LogWriter(part, source="test") as w:
            w.write_config(reader.config())
            w.write_map(reader.reflector_map(), 0)
            for m in reader.raw_messages():
                if m.topic == drop or (word == "observations" and m.topic == topics.NAV_POSE):
                    continue
                if m.topic in (topics.MCU_FRAME, topics.NAV_REFLECTORS, topics.NAV_POSE):
                    w.write(m.topic, json.loads(m.data), m.log_time_ns)
        p = run_cli("calibrate", part, "-o", tmp_path / f"{word}.toml", "--compare", "none")
        assert p.returncode == 2, p.stderr
        assert len(p.stderr.strip().splitlines()) == 1 and word in p.stderr


def test_unknown_quantity(installed_logs: list[Path], tmp_path: Path, run_cli) -> None:
    p = run_cli("calibrate", installed_logs[0], "-o", tmp_path / "v.toml",
                "--estimate", "nav_z")
    assert p.returncode == 2 and "nav_z" in p.stderr
    p = run_cli("calibrate", installed_logs[0], "-o", tmp_path / "v.toml",
                "--estimate", "odom_scale_v")
    assert p.returncode == 2 and "odometry" in p.stderr


def test_robust_to_a_false_reflector_and_bad_links(installed_logs: list[Path],
                                                  tmp_path: Path) -> None:
    from calibrate_cases import ERRORS

    # the degraded hall: a shiny object the head takes for reflector 3, occlusions, lost and
    # corrupted frames and replies
    sim = simulate("degraded", seed=13, duration=70.0, overrides=ERRORS)
    assert sim.fault_counts().get("false_reflector_used", 0) > 0
    log = tmp_path / "degraded.mcap"
    write_log(sim, log)
    cal = calibrate([str(log), str(installed_logs[1])], compare_with=())
    for name in ("nav_x", "nav_y", "nav_yaw", "track", "gyro_scale", "nav_time_offset"):
        e = cal.estimates[name]
        assert e.value == pytest.approx(TRUE[name], abs=TOLERANCE[name]), name
    assert cal.residuals["beyond_3_sigma"]["range"] > 0  # the outliers were seen, and held off


def test_poses_of_logs_with_scans_warn_about_the_time_offset(installed_logs: list[Path]) -> None:
    """From the poses of logs that also have reflector scans, the time offset is the poses'
    whole age: a file that would replay the scans that much late says so."""
    cal = calibrate([str(installed_logs[1])], compare_with=(), observations="poses")
    assert cal.estimates["nav_time_offset"].value > 0.1  # the age, not the 30 ms of the scans
    assert any("replay the scans that much late" in w for w in cal.warnings), cal.warnings
    auto = calibrate([str(installed_logs[1])], compare_with=(), fix=["nav_pose_age"])
    assert not any("replay the scans" in w for w in auto.warnings)
