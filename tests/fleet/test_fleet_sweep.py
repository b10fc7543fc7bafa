"""``lgvtool sweep`` on simulated logs with a local cluster: tables, re-runs, failing logs."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from fleet_logs import make_corrupt_log, make_log

from lgvtool.config import default_config
from lgvtool.log import LogWriter

GRID = ["-e", "laser,pf", "--grid", "pf.particles=20,40", "--set", "pf.init=laser", "--seeds", "2"]


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("fleet_logs")
    good = d / "good"
    good.mkdir()
    out = {"a": make_log(good / "a.mcap", seed=1), "b": make_log(good / "b.mcap", seed=2),
           "corrupt": make_corrupt_log(d / "corrupt.mcap"), "dir": good}
    nomotion = d / "nomotion.mcap"
    with LogWriter(nomotion, source="test") as w:
        w.write_config(default_config())
        w.write_map(default_config().reflectors, 1_000_000_000)
    out["nomotion"] = nomotion
    return out


@pytest.fixture(scope="module")
def first_sweep(logs, tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "out"
    proc = subprocess.run([sys.executable, "-m", "lgvtool", "sweep", str(logs["dir"]), *GRID,
                           "--workers", "2", "-o", str(out)],
                          capture_output=True, text=True, timeout=400)
    return proc, out


def test_small_grid_gives_one_row_per_task_and_estimator(first_sweep):
    proc, out = first_sweep
    assert proc.returncode == 0, proc.stderr
    assert "8 task(s): 8 run now, 0 already done, 0 failed" in proc.stdout
    assert "sweep [" in proc.stderr and "8/8" in proc.stderr
    tidy = pd.read_parquet(out / "results.parquet")
    assert len(tidy) == 2 * 2 * 2 * 2
    assert len(pd.read_csv(out / "results.csv")) == len(tidy)
    for col in ("key", "log", "log_sha256", "setting", "pf.particles", "seed", "estimator",
                "status", "error", "truth.position_rmse_m", "truth.heading_rmse_deg",
                "rotations.complete", "log.duration_s"):
        assert col in tidy.columns, col
    assert (tidy["status"] == "ok").all()
    assert "pf.init" in tidy.columns and set(tidy["pf.init"]) == {"laser"}
    assert set(tidy["pf.particles"]) == {20, 40}
    assert set(tidy["estimator"]) == {"laser", "pf"}
    assert not tidy.duplicated(["log", "pf.particles", "seed", "estimator"]).any()
    assert tidy["truth.position_rmse_m"].notna().all()
    assert len(list((out / "tasks").glob("*.json"))) == 8

    summary = pd.read_parquet(out / "summary.parquet")
    assert len(summary) == 2 * 2 * 2
    assert (summary["tasks"] == 2).all() and (summary["failed"] == 0).all()
    for stat in ("mean", "std", "ci95_low", "ci95_high", "n"):
        assert f"truth.position_rmse_m.{stat}" in summary.columns
    row = summary.iloc[0]
    assert row["truth.position_rmse_m.ci95_low"] <= row["truth.position_rmse_m.mean"]

    html = (out / "report.html").read_text(encoding="utf-8")
    assert html.count("plotly.js v") == 1
    assert "truth.position_rmse_m against pf.particles" in html
    manifest = json.loads((out / "sweep.json").read_text(encoding="utf-8"))
    assert manifest["tasks"] == 8 and len(manifest["keys"]) == 8


def test_same_sweep_again_does_no_new_work(first_sweep, run_cli):
    proc, out = first_sweep
    assert proc.returncode == 0, proc.stderr
    before = {p.name: p.stat().st_mtime_ns for p in (out / "tasks").glob("*.json")}
    again = run_cli("sweep", _dir_of(out), *GRID,
                    "--workers", "2", "-o", out, "--force", timeout=400)
    assert again.returncode == 0, again.stderr
    assert "8 task(s): 0 run now, 8 already done, 0 failed" in again.stdout
    assert "sweep [" not in again.stderr
    after = {p.name: p.stat().st_mtime_ns for p in (out / "tasks").glob("*.json")}
    assert after == before
    tidy = pd.read_parquet(out / "results.parquet")
    assert len(tidy) == 16


def _dir_of(out: Path) -> str:
    manifest = json.loads((out / "sweep.json").read_text(encoding="utf-8"))
    return str(Path(manifest["logs"][0]["path"]).parent)


def test_interrupted_sweep_resumes(first_sweep, run_cli, tmp_path):
    proc, out = first_sweep
    assert proc.returncode == 0, proc.stderr
    copy = tmp_path / "out"
    shutil.copytree(out, copy)
    lost = sorted((copy / "tasks").glob("*.json"))[:3]
    for p in lost:
        p.unlink()
    (copy / "results.parquet").unlink()
    again = run_cli("sweep", _dir_of(out), *GRID, "--workers", "1", "--no-progress", "--json",
                    "-o", copy, "--force", timeout=400)
    assert again.returncode == 0, again.stderr
    facts = json.loads(again.stdout)
    assert (facts["tasks"], facts["ran"], facts["reused"], facts["failed"]) == (8, 3, 5, 0)
    assert all(p.exists() for p in lost)
    old = pd.read_parquet(out / "results.parquet").set_index(["key", "estimator"]).sort_index()
    new = pd.read_parquet(copy / "results.parquet").set_index(["key", "estimator"]).sort_index()
    pd.testing.assert_series_equal(old["truth.position_rmse_m"], new["truth.position_rmse_m"])


def test_failing_logs_are_reported_and_the_others_finish(logs, run_cli, tmp_path):
    out = tmp_path / "out"
    whole = logs["a"].read_bytes()
    cut = tmp_path / "cut.mcap"  # salvaged when read: runs, with a warning
    cut.write_bytes(whole[:len(whole) * 6 // 10])
    args = ("sweep", logs["a"], logs["corrupt"], logs["nomotion"], logs["b"], cut,
            "-e", "laser", "--workers", "2", "-o", out)
    proc = run_cli(*args, timeout=400)
    assert proc.returncode == 0, proc.stderr
    assert "5 task(s): 5 run now, 0 already done, 2 failed" in proc.stdout
    assert "corrupt.mcap (default, seed 0): LogFormatError" in proc.stderr
    assert "nomotion.mcap (default, seed 0): MissingDataError" in proc.stderr
    said = [line for line in proc.stderr.splitlines()
            if line.startswith(f"lgvtool: warning: sweep: {cut}: ")]
    assert len(said) == 1 and "salvaged" in said[0]
    # the log named once, as given (the reader's own naming of it is left out)
    assert said[0].startswith(f"lgvtool: warning: sweep: {cut}: incomplete log (")
    assert said[0].count(cut.name) == 1
    manifest = json.loads((out / "sweep.json").read_text())
    assert "salvaged" in manifest["warnings"][str(cut)]
    tidy = pd.read_csv(out / "results.csv")
    assert tidy.loc[tidy["log"] == str(cut), "warnings"].str.contains("salvaged").all()
    summary = pd.read_csv(out / "summary.csv").set_index("log_name")
    assert summary.loc["a", "ok"] == 1 and summary.loc["b", "ok"] == 1
    assert summary.loc["corrupt", "failed"] == 1
    assert "not an MCAP file" in summary.loc["corrupt", "error"]
    assert summary.loc["nomotion", "failed"] == 1
    assert pd.notna(summary.loc["a", "truth.position_rmse_m.mean"])
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "corrupt.mcap" in html and "not an MCAP file" in html
    refused = run_cli(*args, timeout=400)
    assert refused.returncode == 2 and "pass --force" in refused.stderr
    again = run_cli(*args, "--force", timeout=400)
    assert "0 run now, 5 already done, 2 failed" in again.stdout
    assert f"lgvtool: warning: sweep: {cut}: " in again.stderr  # also when reused


def test_bad_usage_is_one_line(logs, run_cli, tmp_path):
    for extra, needle in ((["--grid", "pf.nosuch=1,2"], "pf.nosuch"),
                          (["-e", "laser", "--grid", "pf.particles=1,2"], "not run"),
                          (["--scheduler", "tcp://127.0.0.1:1", "--workers", "2"], "not both"),
                          (["-e", "nosuch"], "unknown estimator")):
        proc = run_cli("sweep", logs["a"], *extra, "-o", tmp_path / "x", timeout=60)
        assert proc.returncode == 2, (extra, proc.stderr)
        assert needle in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
