"""The estimator profile an MRCLAM log carries, and ``lgvtool evaluate --start-at-truth``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.cli import main
from lgvtool.importers.mrclam_log import import_robot
from lgvtool.importers.mrclam_profile import (
    ESTIMATOR_PROFILE,
    PROFILE_NAME,
    estimator_profile,
)
from lgvtool.localize import run_replay
from lgvtool.localize.registry import resolve_params
from lgvtool.log import LogReader, LogWriter, topics


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run the command line in-process: exit code, stdout, stderr."""
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture
def log(synthetic: Any, tmp_path: Path) -> Path:
    """The synthetic robot 1 imported into a log."""
    out = tmp_path / "robot1.mcap"
    import_robot(synthetic.root, 1, out)
    return out


def test_every_profile_setting_is_a_parameter_of_its_estimator() -> None:
    for name, values in ESTIMATOR_PROFILE.items():
        params = resolve_params(name, ESTIMATOR_PROFILE, None)
        for key, value in values.items():
            assert getattr(params, key) == value, f"{name}.{key}"
    fresh = estimator_profile()
    fresh["ekf"]["sigma_range_m"] = 99.0
    assert ESTIMATOR_PROFILE["ekf"]["sigma_range_m"] != 99.0


def test_the_log_carries_the_profile_and_no_reference_circle(log: Path) -> None:
    reader = LogReader(log)
    cfg = reader.config()
    assert {k: dict(v) for k, v in cfg.estimators.items()} == ESTIMATOR_PROFILE
    assert cfg.reference.steering_angle_deg is None
    assert reader.metadata["importer"]["estimator_profile"] == PROFILE_NAME


def test_replay_uses_the_profile_without_flags_and_set_overrides_it(log: Path) -> None:
    reader = LogReader(log)
    out = run_replay(reader, ["ekf", "pf"], seed=1)
    for name in ("ekf", "pf"):
        for key, value in ESTIMATOR_PROFILE[name].items():
            assert out.settings[name][key] == value, f"{name}.{key}"
    out = run_replay(reader, ["ekf"], seed=1, settings={"ekf.sigma_bearing_rad": 0.05})
    assert out.settings["ekf"]["sigma_bearing_rad"] == 0.05
    assert out.settings["ekf"]["noise_rot"] == ESTIMATOR_PROFILE["ekf"]["noise_rot"]


def test_import_summary_names_the_profile(synthetic: Any, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    code, text, _ = run(["import", "mrclam", str(synthetic.root), "-r", "1", "-o",
                         str(tmp_path / "r1.mcap")], capsys)
    assert code == 0
    assert f"profile   {PROFILE_NAME}" in text
    code, text, _ = run(["import", "mrclam", str(synthetic.root), "-r", "1", "-o",
                         str(tmp_path / "r1.mcap"), "--json", "--force"], capsys)
    assert json.loads(text)["estimator_profile"] == PROFILE_NAME


def _truth_rmse(text: str, name: str) -> float:
    return float(json.loads(text)["estimators"][name]["truth"]["position_rmse_m"])


def test_evaluate_start_at_truth(log: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, text, err = run(["evaluate", str(log), "-e", "ekf", "--start-at-truth", "--json"],
                          capsys)
    assert code == 0, err
    doc = json.loads(text)
    assert doc["reference"]["circle_drive"] is False
    # the synthetic robot drives straight at the commanded speed: started at the truth, the
    # filter stays on it (one odometry row commands twice the speed for 50 ms: 5 mm)
    assert _truth_rmse(text, "ekf") < 0.02
    # without the flag the EKF starts from its own landmark fix; the synthetic excerpt has
    # one frame with two landmarks, whose fix the profile refuses as too uncertain: no
    # estimate, one line, exit 2
    code, _, err = run(["evaluate", str(log), "-e", "ekf", "--json"], capsys)
    assert code == 2
    assert "no estimator produced poses" in err and len(err.strip().splitlines()) == 1
    # taking the first fix whatever its uncertainty, it starts a few cm to dm off
    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    reader = LogReader(log)
    own = run_replay(reader, ["ekf"], settings={"ekf.init_max_sigma_xy_m": 0.0},
                     cloud_size=0).trajectories["ekf"]
    truth = reader.dataframe(topics.TRUTH)
    tx = np.interp(own.t, truth["t"], truth["x"])
    ty = np.interp(own.t, truth["t"], truth["y"])
    own_rmse = float(np.sqrt(np.mean((own.x - tx) ** 2 + (own.y - ty) ** 2)))
    assert own_rmse > 2 * _truth_rmse(text, "ekf")


def test_evaluate_start_at_truth_on_a_log_with_estimates_warns(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    replayed = tmp_path / "replayed.mcap"
    # the first fix of the synthetic excerpt is too uncertain for the profile: take it
    code, _, err = run(["replay", str(log), "-o", str(replayed), "-e", "ekf", "--set",
                        "ekf.init_max_sigma_xy_m=0"], capsys)
    assert code == 0, err
    code, _, err = run(["evaluate", str(replayed), "--start-at-truth"], capsys)
    assert code == 0
    assert "--start-at-truth has no effect" in err


def test_evaluate_start_at_truth_needs_ground_truth(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bare = tmp_path / "no_truth.mcap"
    with LogWriter(bare, chunk_seconds=None, source="test") as w:
        w.copy_from(LogReader(log), skip_topics=frozenset({topics.TRUTH}))
    code, _, err = run(["evaluate", str(bare), "-e", "ekf", "--start-at-truth"], capsys)
    assert code == 2
    assert "truth" in err and len(err.strip().splitlines()) == 1
