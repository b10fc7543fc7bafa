"""Installation errors in the simulator, and their corrections applied before the estimators."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from lgvtool.config import Vehicle, config_from_dict
from lgvtool.errors import ConfigError
from lgvtool.localize.installation import apply_installation, is_nominal
from lgvtool.localize.logdata import LogData, load_log
from lgvtool.localize.observations import RawScan
from lgvtool.log import LogReader
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate

QUIET = {"sim.noise": False, "nav.skew": False, "sim.paper_scans": True}


def _log(tmp_path, name: str, **overrides: float):
    sim = simulate("paper-circle", seed=7, duration=14.0, overrides={**QUIET, **overrides})
    path = tmp_path / f"{name}.mcap"
    write_log(sim, path)
    return sim, LogReader(path)


def test_the_log_keeps_the_nominal_vehicle(tmp_path) -> None:
    sim, reader = _log(tmp_path, "a", **{"install.nav_dx_mm": 20.0, "install.nav_dy_mm": -10.0,
                                        "install.nav_yaw_deg": 0.5,
                                        "install.track_error_mm": 5.0})
    stored = reader.config().vehicle
    assert (stored.nav_x, stored.nav_y, stored.nav_yaw, stored.track) == (1.0, 0.0, 0.0, 0.6)
    true = sim.vehicle
    assert true.nav_x == pytest.approx(1.02, rel=1e-12)
    assert true.nav_y == pytest.approx(-0.01, rel=1e-12)
    assert true.nav_yaw == pytest.approx(math.radians(0.5), rel=1e-12)
    assert true.track == pytest.approx(0.605, rel=1e-12)
    assert reader.metadata["simulator"]["settings"]["install"]["nav_dx_mm"] == 20.0
    assert "install" not in reader.config().simulator  # the host's configuration: nominal


def test_time_offset_and_mounting_yaw_in_the_nav_data(tmp_path) -> None:
    _, plain = _log(tmp_path, "plain")
    _, late = _log(tmp_path, "late", **{"install.nav_time_offset_ms": 30.0,
                                        "install.nav_yaw_deg": 0.5})
    a, b = load_log(plain), load_log(late)
    assert a.t0_ns == b.t0_ns
    sa, sb = a.scans.batch(), b.scans.batch()  # type: ignore[attr-defined]
    assert sb.t - sa.t == pytest.approx(np.full(len(sa.t), 0.030), abs=1e-9)
    # without skew every reflector is measured at mid-revolution: the bearings turn by -yaw
    turn = np.remainder(sb.bearings - sa.bearings + math.pi, 2 * math.pi) - math.pi
    assert turn == pytest.approx(np.full(len(turn), -math.radians(0.5)), abs=1e-9)
    assert a.nav is not None and b.nav is not None
    assert b.nav["t"] - a.nav["t"] == pytest.approx(np.full(len(a.nav["t"]), 0.030), abs=1e-6)
    # the head reports the heading of its own axis
    dh = np.remainder(b.nav["heading"] - a.nav["heading"] + math.pi, 2 * math.pi) - math.pi
    assert np.median(dh) == pytest.approx(math.radians(0.5), abs=1e-4)
    # corrected with the true installation, the late log's NAV data is the plain one's
    fixed = apply_installation(b, replace(Vehicle(), nav_yaw=math.radians(0.5),
                                          nav_time_offset=0.030))
    sf = fixed.scans.batch()  # type: ignore[attr-defined]
    assert sf.t == pytest.approx(sa.t, abs=1e-9)
    assert np.cos(sf.bearings - sa.bearings) == pytest.approx(np.ones(len(sa.bearings)), abs=1e-12)
    assert fixed.nav is not None
    assert fixed.nav["t"] == pytest.approx(a.nav["t"], abs=1e-6)


def test_corrections_of_motion_and_poses() -> None:
    data = LogData(0, (),
                   mcu={"t": np.array([0.0, 0.1]), "gyro_rate": np.array([0.1, 0.2])},
                   twist={"t": np.array([0.0, 0.1]), "v": np.array([1.0, 2.0]),
                          "omega": np.array([0.5, -0.5])},
                   nav={"t": np.array([1.0]), "x": np.array([2.0]), "y": np.array([3.0]),
                        "heading": np.array([0.3]), "valid": np.array([True])},
                   scans=[RawScan(1.0, 0.125, np.array([5.0]), np.array([0.2]),
                                  np.array([0.05]), np.array([4]))])
    assert apply_installation(data, Vehicle()) is data
    assert is_nominal(Vehicle())
    v = replace(Vehicle(), gyro_scale=1.01, gyro_bias=0.01, odom_scale_v=0.9,
                odom_scale_w=1.1, nav_yaw=0.02, nav_time_offset=0.03, nav_pose_age=0.1)
    out = apply_installation(data, v)
    assert out.mcu is not None and out.twist is not None and out.nav is not None
    assert out.mcu["gyro_rate"] == pytest.approx((np.array([0.1, 0.2]) - 0.01) / 1.01)
    assert out.twist["v"] == pytest.approx([0.9, 1.8])
    assert out.twist["omega"] == pytest.approx([0.55, -0.55])
    assert out.nav["t"] == pytest.approx([0.87])
    assert out.nav["heading"] == pytest.approx([0.28])
    scan = out.scans[0]
    assert scan.t == pytest.approx(0.97) and scan.bearings == pytest.approx([0.22])
    assert data.mcu is not None and data.mcu["gyro_rate"][0] == 0.1  # the input is unchanged


def test_vehicle_checks() -> None:
    with pytest.raises(ConfigError, match="gyro_scale"):
        config_from_dict({"vehicle": {"gyro_scale": 0.0}})
    with pytest.raises(ConfigError, match="nav_pose_age"):
        config_from_dict({"vehicle": {"nav_pose_age": -0.1}})
    assert config_from_dict({"vehicle": {"nav_yaw": -0.01}}).vehicle.nav_yaw == -0.01


def test_simulate_list_shows_the_installation_errors(run_cli) -> None:
    p = run_cli("simulate", "--list")
    assert p.returncode == 0
    for key in ("install.nav_dx_mm", "install.nav_yaw_deg", "install.track_error_mm",
                "install.nav_time_offset_ms", "mcu.gyro_scale_error",
                "mcu.wheel_radius_error_left"):
        assert key in p.stdout
    doc = json.loads(run_cli("simulate", "--list", "--json").stdout)
    assert doc["installation"]["install.nav_yaw_deg"]["default"] == 0.0
    bad = run_cli("simulate", "-s", "paper-circle", "--set", "install.nav_z_mm=1", "-o", "x")
    assert bad.returncode == 2 and "install" in bad.stderr
