"""``lgvtool evaluate`` end to end on logs built in code: outputs, exit codes, regression checks."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
import types
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from inprocess import run_command

from lgvtool.config import Config, Reference, default_config
from lgvtool.errors import InputError
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.timestamps import stamp

H = 1.2
DELTA = math.radians(60.0)
R = H / math.tan(DELTA)
SPEED = 0.18                     # speed of O, m/s
PERIOD = 2 * math.pi * R / SPEED
CENTRE = (12.0, 9.0)
T0 = 1_700_000_000.0


def circle(dt: float, rotations: float, bias: float = 0.0, sd: float = 0.0,
           seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, rotations * PERIOD, dt)
    a = SPEED / R * t
    r = R + bias + (rng.normal(0.0, sd, t.size) if sd else 0.0)
    return pd.DataFrame({"t": T0 + t, "x": CENTRE[0] + r * np.cos(a),
                         "y": CENTRE[1] + r * np.sin(a), "heading": a + math.pi / 2})


def write_log(path: Path, *, rotations: float = 2.3, estimates: bool = True,
              truth: bool = True, mcu: bool = True, pf_sd: float = 0.008) -> Path:
    """A circle drive: MCU frames (steering 60 deg), truth, and laser/pf estimates."""
    cfg = default_config()
    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        w.write_map(cfg.reflectors, int(T0 * 1e9))
        if mcu:
            for i, t in enumerate(np.arange(0.0, rotations * PERIOD, 0.1)):
                ns = int((T0 + t) * 1e9)
                w.write(topics.MCU_FRAME, {
                    "timestamp": stamp(ns), "version": 1, "seq": i % 65536,
                    "mcu_time_ms": i * 100, "enc_left": i * 10, "enc_right": i * 12,
                    "gyro_raw": 0, "gyro_scale": 0.01, "gyro_rate": 0.26,
                    "steering_angle": DELTA + (0.001 if i % 2 else -0.001),
                    "drive_speed": 0.36, "status": 0}, ns)
        if truth:
            for row in circle(0.05, rotations).itertuples():
                ns = int(row.t * 1e9)
                w.write(topics.TRUTH, pose_in_frame(ns, row.x, row.y, row.heading), ns)
        if estimates:
            for name, df in (("laser", circle(0.45, rotations, 0.05, 0.02, 1)),
                             ("pf", circle(0.1, rotations, 0.0, pf_sd, 2))):
                for row in df.itertuples():
                    ns = int(row.t * 1e9) + 1
                    w.write(topics.estimate_pose(name),
                            pose_in_frame(ns, row.x, row.y, row.heading), ns)
    return path


def run(capsys: pytest.CaptureFixture[str], *args: object) -> tuple[int, str, str]:
    """``lgvtool evaluate ARGS`` in this process: (exit code, stdout, stderr)."""
    return run_command(capsys, "evaluate", *args)


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_log(tmp_path_factory.mktemp("eval") / "drive.mcap")


def test_table_on_the_terminal(capsys, log: Path) -> None:
    code, out, err = run(capsys, log)
    assert code == 0, err
    assert "Rotation" in out and "RMSE" in out and "σ²" in out and "Average" in out
    assert "Partial rotations left out: 1." in out
    assert "Verdict on drive" in out
    assert err == ""
    code, out, err = run(capsys, log, "--wide")
    assert code == 0, err
    assert "laser RMSE (mm)" in out and "pf variance (mm²)" in out and "Average" in out


def test_json_document(capsys, log: Path) -> None:
    code, out, _ = run(capsys, log, "--json")
    assert code == 0
    doc = json.loads(out)
    assert doc["reference"]["steering_source"] == "log"
    assert doc["reference"]["steering_angle_deg"] == pytest.approx(60.0, abs=0.1)
    assert doc["rotations"] == {**doc["rotations"], "complete": 2, "partial": 1}
    assert doc["log"]["source"] == "log" and doc["log"]["ground_truth"]
    pf = doc["estimators"]["pf"]
    assert pf["circle"]["rmse_mm"] == pytest.approx(8.0, abs=1.5)
    assert pf["truth"]["position_rmse_m"] == pytest.approx(0.008, abs=0.002)
    assert doc["estimators"]["laser"]["circle"]["mean_mm"] == pytest.approx(50.0, abs=5.0)
    assert pf["circle"]["improvement_pct"] > 50


class Figures(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.figures: list[str] = []
        self.tables: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if "data-figure" in a:
            self.figures.append(a["data-figure"] or "")
        if tag == "table":
            self.tables.append(a.get("data-table") or "")


def test_output_directory(capsys, log: Path, tmp_path: Path) -> None:
    code, _, err = run(capsys, log, "-o", tmp_path / "out", "--format", "md")
    assert code == 0, err
    out = tmp_path / "out"
    assert sorted(p.name for p in out.iterdir()) == [
        "report.html", "table1.csv", "table1.json", "table1.md", "table1.tex"]
    page = Figures()
    page.feed((out / "report.html").read_text(encoding="utf-8"))
    assert page.figures == ["trajectories", "radial-error", "rotations", "truth-error"]
    assert "table1" in page.tables and "summary" in page.tables
    assert json.loads((out / "table1.json").read_text())["estimators"]["pf"]["circle"]["rows"]


def test_thresholds(capsys, log: Path) -> None:
    code, _, err = run(capsys, log, "--max", "pf.circle.rmse_mm=1000",
                       "--max", "pf.circle.centre_offset_m=0.05",
                       "--min", "rotations.complete=2")
    assert code == 0, err
    code, _, err = run(capsys, log, "--max", "pf.circle.rmse_mm=1",
                       "--max", "laser.truth.position_rmse_m=0.001")
    assert code == 1
    assert "pf.circle.rmse_mm" in err and "laser.truth.position_rmse_m" in err
    # one line per check and a count; a failed check is no error
    assert len(err.strip().splitlines()) == 3 and "error" not in err
    code, _, err = run(capsys, log, "--max", "kf.circle.rmse_mm=3")
    assert code == 2 and "no estimator 'kf'" in err
    code, _, err = run(capsys, log, "--max", "pf.circle.rmse_mm")
    assert code == 2 and "KEY=VALUE" in err


def test_baseline(capsys, log: Path, tmp_path: Path) -> None:
    code, out, _ = run(capsys, log, "--json")
    base = tmp_path / "previous.json"
    base.write_text(out)
    code, _, err = run(capsys, log, "--baseline", base, "--tolerance", "10%")
    assert code == 0, err
    better = json.loads(out)
    better["estimators"]["pf"]["circle"]["rmse_mm"] /= 2
    base.write_text(json.dumps(better))
    code, _, err = run(capsys, log, "--baseline", base, "--tolerance", "10%")
    assert code == 1 and "pf.circle.rmse_mm" in err and "worse" in err
    base.write_text(json.dumps({"rows": [1, 2]}))
    code, _, err = run(capsys, log, "--baseline", base)
    assert code == 2 and "not an lgvtool evaluation" in err
    code, _, err = run(capsys, log, "--baseline", tmp_path / "missing.json")
    assert code == 2 and "baseline not found" in err


def test_png_without_kaleido(capsys, log: Path, tmp_path: Path) -> None:
    if importlib.util.find_spec("kaleido") is not None:
        pytest.skip("kaleido is installed: PNG export works")
    code, _, err = run(capsys, log, "-o", tmp_path, "--png")
    assert code == 2
    assert "kaleido" in err and len(err.strip().splitlines()) == 1


def test_several_logs(capsys, log: Path, tmp_path: Path) -> None:
    other = write_log(tmp_path / "second.mcap", rotations=3.2, pf_sd=0.012)
    code, out, err = run(capsys, log, other, "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert [d["log"]["name"] for d in doc["per_log"]] == ["drive", "second"]
    assert len(doc["estimators"]["pf"]["circle"]["rows"]) == 2 + 3
    assert doc["rotations"] == {"complete": 5, "partial": 2}


def test_less_than_one_rotation_warns(capsys, tmp_path: Path) -> None:
    short = write_log(tmp_path / "short.mcap", rotations=0.5)
    code, out, err = run(capsys, short, "--json")
    assert code == 0
    assert "fewer than one full rotation" in err
    doc = json.loads(out)
    assert doc["estimators"]["pf"]["circle"] is None
    assert doc["estimators"]["pf"]["truth"]["position_rmse_m"] > 0


def test_bad_inputs(capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    code, _, err = run(capsys, tmp_path / "nothing.mcap")
    assert code == 2 and err.startswith("lgvtool: error:")
    bare = write_log(tmp_path / "bare.mcap", estimates=False, truth=False, mcu=False)
    none = Config(reference=Reference(steering_angle_deg=None))
    from lgvtool.app.evaluate_job import evaluate_log

    fake_replay(monkeypatch, circle(0.1, 2.2))
    with pytest.raises(InputError, match="no steering angle"):
        evaluate_log(bare, config=none)


def fake_replay(monkeypatch: pytest.MonkeyPatch, df: pd.DataFrame) -> list[dict]:
    """Stand in for lgvtool.localize.run_replay; returns the list of calls made."""
    calls: list[dict] = []

    def run_replay(reader, names, *, config=None, seed=0, settings=None, progress=None,
                   tap=None, threads=None):
        calls.append({"names": list(names), "seed": seed})
        if tap is not None:  # the log read as load_log reads it, for the tap
            for block in reader.raw_column_chunks(tap.topics):
                tap.add(block)
        trajs = {n: df.assign(x=df["x"] + 0.01 * i) for i, n in enumerate(names)}
        return types.SimpleNamespace(trajectories=trajs, settings={n: {"k": 1} for n in names})

    fake = types.ModuleType("lgvtool.localize")
    fake.run_replay = run_replay  # type: ignore[attr-defined]
    fake.DEFAULT_ESTIMATORS = ("laser", "deadreckoning", "ekf", "pf-paper", "pf")  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "lgvtool.localize", fake)
    return calls


def test_runs_the_estimators_when_the_log_has_no_estimates(
    capsys, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    plain = write_log(tmp_path / "plain.mcap", estimates=False)
    calls = fake_replay(monkeypatch, circle(0.1, 2.3, sd=0.01))
    code, out, err = run(capsys, plain, "--json", "--seed", "7")
    assert code == 0, err
    assert calls == [{"names": ["laser", "deadreckoning", "ekf", "pf-paper", "pf"], "seed": 7}]
    doc = json.loads(out)
    assert doc["log"]["source"] == "replay"
    assert list(doc["estimators"]) == ["laser", "deadreckoning", "ekf", "pf-paper", "pf"]
    assert doc["estimators"]["pf"]["settings"] == {"k": 1}
    code, out, _ = run(capsys, plain, "--json", "-e", "pf,ekf")
    assert calls[-1]["names"] == ["pf", "ekf"]


def test_reference_options(capsys, log: Path) -> None:
    code, out, err = run(capsys, log, "--json", "--shared-centre", "--free-radius", "-e", "pf")
    assert code == 0, err
    doc = json.loads(out)
    ref = doc["reference"]
    assert ref["shared_centre"] and ref["free_radius"]
    assert list(doc["estimators"]) == ["pf"]
    assert ref["circles"]["pf"]["radius_m"] == pytest.approx(R, abs=0.01)
    code, _, err = run(capsys, log, "-e", "ekf")
    assert code == 2 and "no estimates of ekf" in err


def test_a_logs_own_estimates_are_reported_in_the_order_replay_runs_them(
        capsys, tmp_path: Path) -> None:
    path = tmp_path / "replayed.mcap"
    cfg = default_config()
    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        # written in an order of their own (and one name of no lgvtool estimator)
        for k, name in enumerate(("pf", "mine", "pf-paper", "laser")):
            for row in circle(0.2, 2.3, 0.01 * k, 0.0, k).itertuples():
                ns = int(row.t * 1e9) + 1
                w.write(topics.estimate_pose(name), pose_in_frame(ns, row.x, row.y, row.heading),
                        ns)
    code, out, err = run(capsys, path, "--json")
    assert code == 0, err
    assert list(json.loads(out)["estimators"]) == ["laser", "pf-paper", "pf", "mine"]
