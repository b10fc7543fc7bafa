"""``benchmarks/mrclam_calibrated_halves.py`` (docs/mrclam.md "Calibrated on one half, scored on
the other"): the cut of a robot's files to a span of log time, and a log replayed with a
calibrated file, on the synthetic dataset of ``conftest.py`` (no real data needed)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from benchmark_modules import benchmark


def _module() -> ModuleType:
    """``benchmarks/mrclam_calibrated_halves.py``."""
    return benchmark("mrclam_calibrated_halves")


def _rows(path: Path) -> list[float]:
    """The time stamps of the rows of a dataset file (s), comments and broken rows left out."""
    out = []
    for line in path.read_text().splitlines():
        try:
            out.append(float(line.split()[0]))
        except (ValueError, IndexError):
            continue
    return out


def test_the_cut_keeps_the_span_in_log_time(synthetic: Any, tmp_path: Path) -> None:
    m = _module()
    root = synthetic.root
    odo = _rows(root / "Robot1_Odometry.dat")
    start, end, delay = odo[0] + 3.0, odo[0] + 6.0, 0.2
    cut = m.cut_dataset(root, 1, start, end, delay, tmp_path / "cut")
    assert cut.name == root.name
    assert (cut / "Barcodes.dat").read_bytes() == (root / "Barcodes.dat").read_bytes()
    kept = _rows(cut / "Robot1_Odometry.dat")
    # an odometry row's log time is its stamp plus the delay
    assert kept == [t for t in odo if start <= t + delay < end]
    for kind in ("Measurement", "Groundtruth"):
        rows = _rows(root / f"Robot1_{kind}.dat")
        assert _rows(cut / f"Robot1_{kind}.dat") == [t for t in rows if start <= t < end]
    # the headers stay, so that the cut reads as the dataset
    assert (cut / "Robot1_Odometry.dat").read_text().startswith("#")


def test_a_calibrated_log_carries_the_corrected_odometry(synthetic: Any,
                                                         tmp_path: Path) -> None:
    from lgvtool.importers.mrclam_log import import_robot

    m = _module()
    halves = benchmark("mrclam_halves")
    out = tmp_path / "r1.mcap"
    import_robot(synthetic.root, 1, out)
    log = halves.RobotLog.read(out)
    vehicle = replace(log.config.vehicle, odom_scale_v=0.9, odom_scale_w=0.8,
                      odom_yaw_per_m=-0.05)
    estimators = {**log.config.estimators, "ekf": {**log.config.estimators["ekf"],
                                                   "scale_sigma_v": 0.01}}
    calibrated = m.with_calibration(log, replace(log.config, vehicle=vehicle,
                                                 estimators=estimators))
    v, w = log.odometry["v"].to_numpy(), log.odometry["omega"].to_numpy()
    np.testing.assert_allclose(calibrated.odometry["v"], 0.9 * v)
    np.testing.assert_allclose(calibrated.odometry["omega"], 0.8 * w - 0.05 * v)
    # the replay's data say the same as the table the estimate is carried by
    np.testing.assert_allclose(calibrated.data.twist["v"],
                               0.9 * np.asarray(log.data.twist["v"]))
    assert calibrated.config.estimators["ekf"]["scale_sigma_v"] == pytest.approx(0.01)
    # the log itself is not changed
    np.testing.assert_allclose(log.odometry["v"], v)
    assert log.config.vehicle.odom_scale_v == 1.0


@pytest.mark.mrclam
@pytest.mark.slow
def test_the_calibrated_ekf_meets_the_target_on_every_half(mrclam_data: Path,
                                                           tmp_path: Path) -> None:
    """#45's held-out target on real data: the stored profile's ``ekf`` on odometry calibrated
    from the camera of the robot's other half, at most 0.8 x the apportioned reference EKF on
    all ten halves of Dataset 6 (docs/mrclam.md, "Calibrated on one half, scored on the
    other"); the calibrations are the robots' own (speed and turn 4-15 % less than commanded,
    a drift to the right)."""
    m = _module()
    res = m.run(mrclam_data, [1, 2, 3, 4, 5], tmp_path / "cache", 0)
    rows = res["rows"]
    assert len(rows) == 10
    ratios = {(r["robot"], r["half"]): r["calibrated_m"] / r["reference_m"] for r in rows}
    assert max(ratios.values()) <= 0.8, ratios
    for r in rows:
        e = r["estimates"]
        assert 0.85 <= e["odom_scale_v"]["value"] <= 1.0
        assert 0.85 <= e["odom_scale_w"]["value"] <= 1.0
        assert -0.08 <= e["odom_yaw_per_m"]["value"] <= 0.0
        assert all(q["sigma"] is not None and q["sigma"] > 0.0 for q in e.values())
