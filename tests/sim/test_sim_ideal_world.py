"""``sim.world = "ideal"`` reproduces the kind world of model 1 (a kinematic path, true reflector
ids, the NAV200's scans logged): the old sample log's figures, and the world's version recorded
in every log."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from inprocess import run_command

#: the laser's figures on sample_logs/paper-circle.mcap as it was made by world model 1
#: (``lgvtool simulate --scenario paper-circle --seed 1``, 202.65 s, 11842 messages), from
#: ``lgvtool evaluate --json``: Table 1's Average row, mm and mm^2, and the truth RMSE, m
MODEL_1_LASER = {"rmse_mm": 62.028, "variance_mm2": 479.549, "truth_rmse_m": 0.086258}


def test_the_ideal_world_reproduces_the_old_sample(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "ideal.mcap"
    code, _, err = run_command(capsys, "simulate", "-s", "paper-circle", "--seed", "1", "--set",
                               "sim.world=ideal", "-o", log)
    assert code == 0, err
    code, out, err = run_command(capsys, "evaluate", log, "-e", "laser", "--json")
    assert code == 0, err
    doc = json.loads(out)
    laser = doc["estimators"]["laser"]
    # to 0.1 %: the same messages up to the last bits of numpy's vectorised trigonometry
    assert laser["circle"]["rmse_mm"] == pytest.approx(MODEL_1_LASER["rmse_mm"], rel=1e-3)
    assert laser["circle"]["variance_mm2"] == pytest.approx(MODEL_1_LASER["variance_mm2"],
                                                            rel=1e-3)
    assert laser["truth"]["position_rmse_m"] == pytest.approx(MODEL_1_LASER["truth_rmse_m"],
                                                              rel=1e-3)
    assert doc["truth_path"]["rmse_mm"] < 1e-3  # a kinematic circle


def test_the_world_is_recorded_and_the_site_is_the_default(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for world in ("site", "ideal"):
        log = tmp_path / f"{world}.mcap"
        args = ["simulate", "-s", "warehouse", "--duration", "20", "--seed", "3", "-o", log]
        if world == "ideal":
            args += ["--set", "sim.world=ideal"]
        code, _, err = run_command(capsys, *args)
        assert code == 0, err
        code, out, err = run_command(capsys, "info", log, "--json")
        assert code == 0, err
        meta = json.loads(out)["metadata"]["simulator"]
        assert meta["world"] == {"model": 2, "preset": world}
        assert meta["observations"] == ("paper-scans" if world == "ideal" else "none")
