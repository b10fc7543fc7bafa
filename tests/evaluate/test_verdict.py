"""The verdict that ends ``lgvtool evaluate`` (lgvtool.evaluate.verdict), its tables' widths,
and evaluate's small frictions: an output that is the input, the checks listed, --tolerance
without --baseline."""

from __future__ import annotations

import contextlib
import io
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from evaluate_synth import DELTA, PERIOD, SPEED, T0, H, circle_drive
from inprocess import run_command

from lgvtool.cli import main
from lgvtool.config import default_config
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.table import build_table, to_text
from lgvtool.evaluate.verdict import (
    MAX_LINES,
    EstimatorVerdict,
    Verdict,
    format_verdict,
    summary_line,
    verdict_dict,
    verdict_of,
)
from lgvtool.json_types import as_list, member
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.timestamps import stamp

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "paper-circle.mcap"


def run(capsys: pytest.CaptureFixture[str], *args: object) -> tuple[int, str, str]:
    """``lgvtool evaluate ARGS`` in this process: (exit code, stdout, stderr)."""
    return run_command(capsys, "evaluate", *args)


def verdict_block(out: str) -> list[str]:
    """The lines from 'Verdict on' to the end of the output."""
    lines = out.rstrip("\n").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Verdict on"))
    return lines[start:]


@pytest.fixture(scope="module")
def sample_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, Path]:
    """``lgvtool evaluate sample_logs/paper-circle.mcap -o DIR``: (stdout, DIR)."""
    outdir = tmp_path_factory.mktemp("verdict") / "rep"
    code = 0
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(["evaluate", str(SAMPLE), "-o", str(outdir), "--no-progress"])
        except SystemExit as exc:
            code = int(exc.code or 0)
    assert code == 0, err.getvalue()
    return out.getvalue(), outdir


# ------------------------------------------------------------------------- the sample log


def test_the_sample_logs_verdict(sample_run: tuple[str, Path]) -> None:
    out, outdir = sample_run
    lines = verdict_block(out)
    assert 1 < len(lines) <= MAX_LINES
    assert all(len(line) <= 100 for line in lines), [len(x) for x in lines]
    assert "ground truth" in lines[0] and "lower is better" in lines[0]
    assert str(outdir / "report.html") in lines[-1]
    text = "\n".join(lines)
    for name in ("laser", "deadreckoning", "ekf", "pf-paper", "pf"):
        assert any(line.split()[:1] == [name] for line in lines), name
    assert "x the laser" in text and "odometry only" in text
    assert "NAV200 scans (the paper's setup)" in text
    # pf-paper's note (its error in the rotations, after its uniform start) is kept: the
    # parenthesis of its observations gives way to it
    pf_paper = next(line for line in lines if line.split()[:1] == ["pf-paper"])
    assert "NAV200 scans at NAV polls; " in pf_paper and "mm in the rotations" in pf_paper
    # the paper's own figures, labelled as the paper's, beside this log's
    paper = next(line for line in lines if "paper's Table 1" in line)
    assert "56.9" in paper and "20.4" in paper
    # dead reckoning: fine on the circle, worse than the laser on the truth
    assert any("Warning" in line and "deadreckoning" in line for line in lines)


def test_the_sample_logs_verdict_in_the_document(sample_run: tuple[str, Path]) -> None:
    out, outdir = sample_run
    doc = json.loads((outdir / "table1.json").read_text(encoding="utf-8"))
    v = doc["verdict"]
    assert v["reference"] == "truth"
    assert v["paths"][0] == str(outdir / "report.html")
    by_name = {e["name"]: e for e in v["estimators"]}
    laser_true = doc["estimators"]["laser"]["truth"]["position_rmse_m"]
    dr_true = doc["estimators"]["deadreckoning"]["truth"]["position_rmse_m"]
    assert by_name["laser"]["ratio_to_laser"] == pytest.approx(1.0)
    assert by_name["deadreckoning"]["error_m"] == pytest.approx(dr_true, rel=1e-9)
    assert by_name["deadreckoning"]["ratio_to_laser"] == pytest.approx(dr_true / laser_true,
                                                                       rel=1e-9)
    assert by_name["laser"]["observations"] == "NAV poses (the laser itself)"
    assert v["lines"] == verdict_block(out)
    assert doc["checks"] == []


def test_default_tables_fit_120_columns_and_wide_spells_them_out(
        sample_run: tuple[str, Path], capsys: pytest.CaptureFixture[str]) -> None:
    out, _ = sample_run
    assert max(len(line) for line in out.splitlines()) <= 120
    code, wide, err = run(capsys, SAMPLE, "--wide", "--no-progress")
    assert code == 0, err
    assert max(len(line) for line in wide.splitlines()) > 120
    assert "laser RMSE (mm)" in wide and "deadreckoning variance (mm²)" in wide
    assert "less error than laser (%)" in wide and "vs laser" not in wide


def test_help_explains_every_column(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "--help")
    assert code == 0
    for column in ("Rotation / Number", "σ² / variance", "bias", "max|e|", "centre",
                   "x laser", "in rot.", "p95", "heading", "--wide"):
        assert column in out, column


# --------------------------------------------------------------- circle and truth disagree


def _lagging(df: pd.DataFrame, lag_s: float) -> pd.DataFrame:
    """``df`` where each pose is reported ``lag_s`` late: on the circle, behind the vehicle."""
    return df.assign(t=df["t"] + lag_s)


def test_circle_and_truth_ranking_differently_warns() -> None:
    truth = circle_drive(rotations=3.2, dt=0.05)
    lag = 0.6                                        # 0.6 s late: 108 mm behind, on the circle
    result = evaluate_trajectories(
        {"laser": circle_drive(rotations=3.2, dt=0.45, bias=0.05, sd=0.01, seed=1),
         "lagging": _lagging(circle_drive(rotations=3.2, dt=0.1), lag),
         "pf": circle_drive(rotations=3.2, dt=0.1, sd=0.005, seed=2)},
        truth=truth, steering_angle=DELTA, h=H, name="lag")
    v = verdict_of(result, paths=["out/report.html"])
    assert v.reference == "truth"
    est = {e.name: e for e in v.estimators}
    # the truth sees the lag (about SPEED * lag), the circle does not
    assert est["lagging"].error_m == pytest.approx(SPEED * lag, rel=0.1)
    assert est["lagging"].ratio_to_laser is not None and est["lagging"].ratio_to_laser > 1.5
    circle_ratio = (result.estimators["lagging"].average.rmse
                    / result.estimators["laser"].average.rmse)
    assert circle_ratio < 0.2
    assert len(v.warnings) == 1 and "lagging" in v.warnings[0]
    assert "the circle ranks lagging 1st" in v.warnings[0]
    lines = format_verdict(v)
    assert len(lines) <= MAX_LINES and all(len(line) <= 100 for line in lines)
    assert any(line.strip().startswith("Warning: the circle ranks lagging") for line in lines)
    assert v.paper is None                          # no MCU speed: not the paper's experiment


def test_a_near_tie_does_not_warn() -> None:
    truth = circle_drive(rotations=3.2, dt=0.05)
    result = evaluate_trajectories(
        {"laser": circle_drive(rotations=3.2, dt=0.45, bias=0.05, sd=0.01, seed=1),
         "a": circle_drive(rotations=3.2, dt=0.1, sd=0.005, seed=2),
         "b": circle_drive(rotations=3.2, dt=0.1, sd=0.005, seed=3)},
        truth=truth, steering_angle=DELTA, h=H)
    assert verdict_of(result).warnings == ()


def test_the_circle_is_the_reference_without_truth() -> None:
    result = evaluate_trajectories(
        {"laser": circle_drive(rotations=3.2, dt=0.45, bias=0.05, sd=0.01, seed=1),
         "pf": circle_drive(rotations=3.2, dt=0.1, sd=0.005, seed=2)},
        steering_angle=DELTA, h=H, name="nocirc")
    result.observations = {"laser": "NAV poses (the laser itself)", "pf": "reflector scans"}
    v = verdict_of(result)
    assert v.reference == "circle" and "circle" in v.reference_text
    est = {e.name: e for e in v.estimators}
    assert est["pf"].error_m == pytest.approx(result.estimators["pf"].average.rmse,
                                              rel=1e-12)
    assert est["pf"].observations == "reflector scans"
    lines = format_verdict(v)
    assert "Nothing written" in lines[-1] and "-o DIR" in lines[-1]


# ----------------------------------------------------------------------------- no reference


def _route(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 10 m x 6 m rectangular route at 0.5 m/s (no circle): x, y (m) and heading (rad)."""
    s = (0.5 * t) % 32.0
    x = np.select([s < 10, s < 16, s < 26], [s, 10.0 + 0 * s, 10.0 - (s - 16)], 0.0 * s)
    y = np.select([s < 10, s < 16, s < 26], [0 * s, s - 10.0, 6.0 + 0 * s], 6.0 - (s - 26))
    h = np.select([s < 10, s < 16, s < 26], [0 * s, 0 * s + math.pi / 2, 0 * s + math.pi],
                  0 * s - math.pi / 2)
    return 5.0 + x, 4.0 + y, h


OFFSET = 0.03
"""The pf estimate lies this far (m) beside the laser's everywhere."""


def _route_log(path: Path) -> Path:
    """A drive along a rectangle without ground truth: MCU frames (steering 60 deg), NAV poses
    (3 of 140 without a position) and the log's own laser and pf estimates, OFFSET apart."""
    cfg = default_config()
    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        for i, t in enumerate(np.arange(0.0, 64.0, 0.1)):
            ns = int((T0 + t) * 1e9)
            w.write(topics.MCU_FRAME, {
                "timestamp": stamp(ns), "version": 1, "seq": i, "mcu_time_ms": i * 100,
                "enc_left": i * 10, "enc_right": i * 10, "gyro_raw": 0, "gyro_scale": 0.01,
                "gyro_rate": 0.0, "steering_angle": DELTA, "drive_speed": 0.5, "status": 0}, ns)
        for k, t in enumerate(np.arange(0.0, 63.0, 0.45)):
            ns = int((T0 + t) * 1e9)
            valid = k not in (10, 11, 50)
            x, y, h = (float(v[0]) for v in _route(np.array([t])))
            w.write(topics.NAV_POSE, {"timestamp": stamp(ns), "x": x, "y": y, "heading": h,
                                      "quality": 90 if valid else 255,
                                      "reflectors_used": 8 if valid else 0, "valid": valid}, ns)
        times = np.arange(0.0, 63.0, 0.45)
        xs, ys, hs = _route(times)
        for name, dy in (("laser", 0.0), ("pf", OFFSET)):
            for ti, xi, yi, hi in zip(times, xs, ys, hs, strict=True):
                ns = int((T0 + ti) * 1e9) + 1
                w.write(topics.estimate_pose(name),
                        pose_in_frame(ns, float(xi), float(yi) + dy, float(hi)), ns)
    return path


def test_no_reference_says_so_and_gives_the_disagreement(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    log = _route_log(tmp_path / "route.mcap")
    code, out, err = run(capsys, log, "--no-progress")
    assert code == 0, err
    lines = verdict_block(out)
    assert len(lines) <= MAX_LINES and all(len(line) <= 100 for line in lines)
    text = "\n".join(lines)
    assert "no reference" in lines[0]
    assert "30.0 mm RMS from the laser" in text
    assert "not a circle" in text and "no ground truth" in text
    assert "NAV: 140 replies, 3 without a position" in text
    code, out, err = run(capsys, log, "--json")
    assert code == 0, err
    v = json.loads(out)["verdict"]
    assert v["reference"] == "none"
    pf = next(e for e in v["estimators"] if e["name"] == "pf")
    assert pf["error_m"] is None and pf["ratio_to_laser"] is None
    assert pf["disagreement_m"] == pytest.approx(OFFSET, abs=1e-6)
    assert pf["observations"].startswith("unknown")


# ------------------------------------------------------------------------ the formatting


def _many(n: int) -> Verdict:
    rows = tuple(EstimatorVerdict(f"estimator-{k}", 0.001 * (k + 1), 0.1 * (k + 1),
                                  "reflector scans", "") for k in range(n))
    return Verdict("many", "truth", "position RMSE against the ground truth, whole drive",
                   rows, None, ("one", "two", "three"), ("r/report.html", "r/table1.md"), None)


def test_format_keeps_ten_lines_and_the_width_whatever_the_estimators() -> None:
    for n in (1, 5, 12, 40):
        for width in (60, 100):
            lines = format_verdict(_many(n), width)
            assert len(lines) <= MAX_LINES and all(len(line) <= width for line in lines)
            assert "r/report.html" in lines[-1]
    d = verdict_dict(_many(3))
    assert member(as_list(d["estimators"])[0], "error_m") == pytest.approx(0.001)
    assert d["lines"] == format_verdict(_many(3))


def test_summary_line_is_one_line_over_several_logs() -> None:
    line = summary_line([_many(5), _many(3)])
    assert "\n" not in line and len(line) <= 100
    assert line.startswith("2 logs (truth 2)")
    assert "estimator-0 0.10" in line                # median of 0.1 and 0.1


def test_wide_tables_wrap_into_blocks_of_120_columns() -> None:
    trajs = {"laser": circle_drive(rotations=2.2, dt=0.45, bias=0.05, sd=0.01, seed=1)}
    for k in range(8):
        trajs[f"a-long-estimator-{k}"] = circle_drive(rotations=2.2, sd=0.002 * (k + 1),
                                                      seed=k + 2)
    result = evaluate_trajectories(trajs, truth=circle_drive(rotations=2.2, dt=0.05),
                                   steering_angle=DELTA, h=H)
    text = to_text(build_table([result]))
    assert max(len(line) for line in text.splitlines()) <= 120
    assert all(f"a-long-estimator-{k}" in text for k in range(8))


def test_paper_experiment_shows_the_papers_figures_beside_this_logs() -> None:
    trajs = {"laser": circle_drive(rotations=2.2, dt=0.45, bias=0.05, sd=0.01, seed=1),
             "pf-paper": circle_drive(rotations=2.2, sd=0.01, seed=2)}
    result = evaluate_trajectories(trajs, steering_angle=DELTA, h=H)
    assert verdict_of(result).paper is None          # speed unknown
    result.drive_speed = 0.36
    paper = verdict_of(result).paper
    assert paper is not None and "56.9" in paper and "20.4" in paper
    mine = result.estimators["pf-paper"].average.rmse
    assert f"pf-paper {mine * 1e3:.1f} mm" in paper
    result.drive_speed = 0.72                        # the 'fast' scenario: not the paper's
    assert verdict_of(result).paper is None


# --------------------------------------------------------------------------- the frictions


def test_an_output_that_is_the_input_is_refused(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    log = tmp_path / "wh.mcap"
    shutil.copyfile(SAMPLE, log)
    before = log.read_bytes()
    code, _, err = run(capsys, log, "-o", log)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "is the input" in err
    assert "is a file" not in err
    assert log.read_bytes() == before


def test_every_check_is_listed_and_a_failure_exits_1(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    log = _circle_log(tmp_path / "circle.mcap")
    code, out, err = run(capsys, log, "--max", "pf.circle.rmse_mm=1000",
                         "--max", "laser.circle.rmse_mm=1", "--min", "rotations.complete=2")
    assert code == 1
    lines = err.strip().splitlines()
    assert lines[0].startswith("check  pass  pf.circle.rmse_mm")
    assert lines[1].startswith("check  FAIL  laser.circle.rmse_mm")
    assert lines[2].startswith("check  pass  rotations.complete")
    assert lines[3] == "checks: 1 of 3 FAILED"
    assert "error" not in err
    code, out, err = run(capsys, log, "--max", "pf.circle.rmse_mm=1000", "--json")
    assert code == 0
    checks = json.loads(out)["checks"]
    assert [(c["key"], c["passed"]) for c in checks] == [("pf.circle.rmse_mm", True)]
    assert err.strip().splitlines() == ["check  pass  " + checks[0]["text"],
                                        "checks: the one check passed"]


def test_tolerance_without_a_baseline_is_refused(capsys: pytest.CaptureFixture[str],
                                                 tmp_path: Path) -> None:
    log = _circle_log(tmp_path / "circle.mcap")
    code, out, err = run(capsys, log, "--tolerance", "10%")
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "--tolerance needs --baseline" in err
    assert out == ""


def _circle_log(path: Path) -> Path:
    """A circle drive with the log's own laser and pf estimates (2.3 rotations)."""
    cfg = default_config()
    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        for i, t in enumerate(np.arange(0.0, 2.3 * PERIOD, 0.1)):
            ns = int((T0 + t) * 1e9)
            w.write(topics.MCU_FRAME, {
                "timestamp": stamp(ns), "version": 1, "seq": i % 65536, "mcu_time_ms": i * 100,
                "enc_left": i * 10, "enc_right": i * 12, "gyro_raw": 0, "gyro_scale": 0.01,
                "gyro_rate": 0.26, "steering_angle": DELTA, "drive_speed": 0.36, "status": 0},
                ns)
        for name, df in (("laser", circle_drive(rotations=2.3, dt=0.45, bias=0.05, sd=0.02,
                                                seed=1)),
                         ("pf", circle_drive(rotations=2.3, dt=0.1, sd=0.008, seed=2))):
            for row in df.itertuples():
                ns = int(float(row.t) * 1e9) + 1
                w.write(topics.estimate_pose(name),
                        pose_in_frame(ns, float(row.x), float(row.y), float(row.heading)), ns)
    return path
