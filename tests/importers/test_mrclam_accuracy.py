"""Accuracy on real data: ``ekf`` with the log's profile meets the target (at most 0.8 x the
dataset's reference EKF) on every robot, from the truth and from its own start, ``pf`` (the
profile's marginal filter, odometry scales per particle) at most 0.9 x on every robot, the
default ``pf`` on one full MRCLAM robot stays under its bound through ``evaluate``, and the
metric of the accuracy benchmark (estimates carried through the odometry to every odometry
step, with the estimator's odometry scales when it has them) is exact on constructed cases.

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", IJRR 30(8):969-974, 2011.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType

import numpy as np
import pandas as pd
import pytest
from benchmark_modules import benchmark

from lgvtool.json_types import as_number, member

ROBOT = 3
"""The robot of the regression test (Dataset 6)."""
REFERENCE_EKF_M = 0.193
"""The dataset's reference EKF position RMSE for that robot, m."""
PF_BOUND_M = 0.25
"""Bound on ``pf``'s position RMSE at every odometry step and at its estimate times, from the
ground truth and from its own start, m: 1.3 x the reference EKF. Measured with seeds 0-2:
0.148-0.149 m at odometry steps, 0.105-0.106 m at estimate times (docs/mrclam.md, "Accuracy")."""


REFERENCE_EKF_ALL_M = {1: 0.214, 2: 0.233, 3: 0.193, 4: 0.322, 5: 0.185}
"""The dataset's reference EKF position RMSE per robot, m (its README)."""
TARGET_RATIO = {"ekf": 0.8, "pf": 0.9}
"""The targets: the recommended estimator (``ekf``) at most 0.8 times the reference EKF, and
``pf`` at most 0.9 times, on every robot."""


def _metrics() -> ModuleType:
    """``benchmarks/mrclam_metrics.py``, the metric of the accuracy table."""
    return _benchmark("mrclam_metrics")


def _benchmark(name: str) -> ModuleType:
    """The module ``benchmarks/<name>.py``."""
    return benchmark(name)


# ------------------------------------------------------------------ the metric, constructed cases


def test_an_estimate_is_carried_along_the_commanded_arc() -> None:
    m = _metrics()
    t = np.arange(0.0, 10.0001, 0.01)
    v, w = 0.2, 0.1
    odo = pd.DataFrame({"t": t, "v": np.full(len(t), v), "omega": np.full(len(t), w)})
    # one estimate at t = 1.005 s (between two odometry stamps) at (1, 2), heading 0.3
    est = pd.DataFrame({"t": [1.005], "x": [1.0], "y": [2.0], "heading": [0.3]})
    out = m.estimates_at_odometry(est, odo)
    assert out["t"].iloc[0] == pytest.approx(1.01)
    assert out["t"].iloc[-1] == pytest.approx(10.0)
    # the last odometry row holds no motion after it: the arc ends at t = 10 s
    dt = out["t"].to_numpy() - 1.005
    r = v / w
    th = 0.3 + w * dt
    x = 1.0 + r * (np.sin(th) - math.sin(0.3))
    y = 2.0 - r * (np.cos(th) - math.cos(0.3))
    np.testing.assert_allclose(out["x"], x, atol=1e-9)
    np.testing.assert_allclose(out["y"], y, atol=1e-9)
    np.testing.assert_allclose(out["heading"], np.remainder(th + math.pi, 2 * math.pi) - math.pi,
                               atol=1e-9)


def test_each_odometry_step_follows_the_latest_estimate() -> None:
    m = _metrics()
    t = np.arange(0.0, 4.0001, 0.5)
    odo = pd.DataFrame({"t": t, "v": np.full(len(t), 1.0), "omega": np.zeros(len(t))})
    est = pd.DataFrame({"t": [1.0, 2.0], "x": [0.0, 5.0], "y": [0.0, 0.0],
                        "heading": [0.0, math.pi / 2]})
    out = m.estimates_at_odometry(est, odo)
    assert out["t"].tolist() == [1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
    assert out["x"].tolist() == pytest.approx([0.0, 0.5, 5.0, 5.0, 5.0, 5.0, 5.0])
    assert out["y"].tolist() == pytest.approx([0.0, 0.0, 0.0, 0.5, 1.0, 1.5, 2.0])


def test_the_estimators_odometry_scales_carry_the_estimate() -> None:
    m = _metrics()
    t = np.arange(0.0, 10.0001, 0.01)
    v, w = 0.2, 0.1
    odo = pd.DataFrame({"t": t, "v": np.full(len(t), v), "omega": np.full(len(t), w)})
    # two estimates; from the second one on the commands are scaled by (0.9, 0.8)
    est = pd.DataFrame({"t": [1.005, 4.0], "x": [1.0, 3.0], "y": [2.0, 0.0],
                        "heading": [0.3, -0.5], "scale_v": [1.0, 0.9],
                        "scale_w": [1.0, 0.8]})
    out = m.estimates_at_odometry(est, odo)
    plain = m.estimates_at_odometry(est[["t", "x", "y", "heading"]], odo)
    before = out["t"] < 4.0
    np.testing.assert_allclose(out[before][["x", "y"]], plain[before][["x", "y"]], atol=1e-12)
    after = out[~before]
    dt = after["t"].to_numpy() - 4.0
    vs, ws = 0.9 * v, 0.8 * w
    th = -0.5 + ws * dt
    np.testing.assert_allclose(after["x"], 3.0 + vs / ws * (np.sin(th) - math.sin(-0.5)),
                               atol=1e-9)
    np.testing.assert_allclose(after["y"], -vs / ws * (np.cos(th) - math.cos(-0.5)), atol=1e-9)
    np.testing.assert_allclose(after["heading"], th, atol=1e-9)


def test_rmse_only_where_the_ground_truth_exists() -> None:
    m = _metrics()
    truth = pd.DataFrame({"t": [0.0, 1.0, 2.0, 5.0, 6.0], "x": [0.0, 1.0, 2.0, 5.0, 6.0],
                          "y": np.zeros(5)})
    est = pd.DataFrame({"t": [0.5, 1.5, 3.0, 5.5, 7.0], "x": [0.5, 1.5, 9.0, 5.5, 9.0],
                        "y": [0.3, 0.4, 0.0, 0.0, 0.0]})
    # t = 3.0 lies in a 3 s ground-truth gap, t = 7.0 after its end: both left out
    rmse, n = m.position_rmse(est, truth, max_gap_s=1.5)
    assert n == 3
    assert rmse == pytest.approx(math.sqrt((0.09 + 0.16 + 0.0) / 3))
    # with the default 0.5 s the 1 s sampling itself counts as gaps
    assert m.position_rmse(est, truth)[1] == 0


# ------------------------------------------------------------------ the real robots


@pytest.mark.mrclam
@pytest.mark.slow
@pytest.mark.parametrize("start", ["truth", None], ids=["from-truth", "own-start"])
@pytest.mark.parametrize("name", ["ekf", "pf"])
def test_the_estimator_meets_its_target_on_every_robot(mrclam_data: Path, tmp_path: Path,
                                                       start: str | None, name: str) -> None:
    """``ekf`` (and ``pf``) with the profile the importer stores (odometry scales in the
    state, odometry delayed as the camera shows, a weighted landmark fix to start from),
    started at the ground truth or from its own start (no truth used), at most 0.8 x (``pf``:
    0.9 x) the reference EKF at every odometry step on all five robots of Dataset 6."""
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    m = _metrics()
    acc = _benchmark("mrclam_accuracy")
    ratios = {}
    for robot, reference in REFERENCE_EKF_ALL_M.items():
        log = tmp_path / f"robot{robot}.mcap"
        summary = import_robot(mrclam_data, robot, log)
        assert 0.15 <= summary.timing["odometry_delay_s"] <= 0.3
        reader = LogReader(log)
        cfg = reader.config()
        assert cfg.estimators[name]["odometry_scales"] is True
        truth = reader.dataframe(topics.TRUTH)[["t", "x", "y", "heading"]]
        odometry = reader.dataframe(topics.ODOM)[["t", "v", "omega"]]
        assert cfg.estimators[name]["init_fix"] == "weighted"
        out = run_replay(reader, [name], seed=0, initial_pose=start, cloud_size=0)
        traj = acc.calibrated_trajectory(reader, name, out.trajectories[name], config=cfg,
                                         seed=0, settings={}, initial_pose=start)
        assert {"scale_v", "scale_w"} <= set(traj.columns)
        # the weighted mean of the pf's turn scales wanders further (Robot2: 0.73-1.25, the
        # EKF's within 0.8-1.2) while few landmarks are in view: two sigma of its prior
        low, high = (0.8, 1.2) if name == "ekf" else (0.7, 1.3)
        assert traj["scale_v"].between(0.8, 1.1).all() and traj["scale_w"].between(low, high).all()
        rmse, steps = m.position_rmse(m.estimates_at_odometry(traj, odometry), truth)
        assert steps > 0.75 * len(odometry)
        # the own start comes within seconds of the first camera frame except on Robot4,
        # whose first 48 s of camera frames hold one landmark each
        first_frame = float(reader.dataframe(topics.NAV_REFLECTORS)["t"].iloc[0])
        assert traj["t"].iloc[0] - first_frame <= (60.0 if robot == 4 else 15.0)
        ratios[robot] = rmse / reference
    assert max(ratios.values()) <= TARGET_RATIO[name], ratios


@pytest.mark.mrclam
@pytest.mark.slow
def test_pf_on_one_full_robot_stays_under_its_bound(mrclam_data: Path, tmp_path: Path) -> None:
    from lgvtool.app.evaluate_job import evaluate_log
    from lgvtool.evaluate.document import build_document
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    m = _metrics()
    log = tmp_path / f"robot{ROBOT}.mcap"
    import_robot(mrclam_data, ROBOT, log)
    reader = LogReader(log)
    truth = reader.dataframe(topics.TRUTH)[["t", "x", "y", "heading"]]
    odometry = reader.dataframe(topics.ODOM)[["t", "v", "omega"]]
    figures = {}
    for start in ("truth", None):
        # the default pf with the settings the log carries, exactly as replay runs it
        out = run_replay(reader, ["pf"], seed=0, initial_pose=start, cloud_size=0)
        traj = out.trajectories["pf"].to_frame()
        at_odometry, steps = m.position_rmse(m.estimates_at_odometry(traj, odometry), truth)
        at_estimates, _ = m.position_rmse(traj, truth)
        assert steps > 0.95 * len(odometry)
        figures[start or "own"] = (at_odometry, at_estimates)
    for start, (at_odometry, at_estimates) in figures.items():
        assert at_odometry <= PF_BOUND_M, f"pf from {start}: {at_odometry:.3f} m at odometry steps"
        assert at_estimates <= PF_BOUND_M, f"pf from {start}: {at_estimates:.3f} m at estimates"
    assert PF_BOUND_M <= 1.3 * REFERENCE_EKF_M + 1e-9
    # evaluate runs the same estimator from the same log and reports the ground-truth metrics
    result = evaluate_log(log, estimators=["pf"], start_at_truth=True)
    doc = build_document([result])
    assert member(doc["reference"], "circle_drive") is False
    truth_figures = member(member(doc["estimators"], "pf"), "truth")
    assert as_number(member(truth_figures, "position_rmse_m")) <= PF_BOUND_M
    assert member(truth_figures, "position_rmse_m") == pytest.approx(figures["truth"][1], rel=0.05)
