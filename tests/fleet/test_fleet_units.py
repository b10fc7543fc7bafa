"""Keys, grids, statistics and tables of the fleet engine, without a cluster."""

from __future__ import annotations

import hashlib
import math
from typing import Any

import pytest

from lgvtool.errors import InputError
from lgvtool.fleet.engine import Outcome
from lgvtool.fleet.keys import HashCache, file_sha256, task_key
from lgvtool.fleet.results import TaskStore, is_final, summary_table, task_record, tidy_table
from lgvtool.fleet.stats import describe
from lgvtool.fleet.tasks import (
    SweepTask,
    TaskMetrics,
    build_tasks,
    document_metrics,
    expand_logs,
    grid_settings,
    missing_files,
    parse_grid,
)
from lgvtool.quantiles import t_quantile


def test_file_hash_is_streamed_sha256(tmp_path):
    data = bytes(range(256)) * 5000
    f = tmp_path / "a.mcap"
    f.write_bytes(data)
    assert file_sha256(f, block=1000) == hashlib.sha256(data).hexdigest()


def test_hash_cache_remembers_until_the_file_changes(tmp_path):
    f = tmp_path / "a.mcap"
    f.write_bytes(b"one")
    cache = HashCache(tmp_path / "logs.json")
    first = cache.hash(f)
    cache.save()
    again = HashCache(tmp_path / "logs.json")
    assert again.lookup(f) == first
    f.write_bytes(b"other")
    assert again.lookup(f) is None
    assert again.hash_many([f]) == [hashlib.sha256(b"other").hexdigest()]


def test_task_key_covers_every_input():
    base: dict[str, Any] = dict(log_sha256="ab" * 32, kind="evaluate", estimators=["pf", "laser"],
                settings={"pf.particles": 100}, seed=1)
    key = task_key(**base)
    assert key == task_key(**{**base, "estimators": ["laser", "pf"]})
    assert len(key) == 64
    change: dict[str, Any]
    for change in ({"seed": 2}, {"settings": {"pf.particles": 200}}, {"log_sha256": "cd" * 32},
                   {"estimators": ["pf"]}, {"kind": "other"}, {"version": "9.9.9"},
                   {"extra": {"config_sha256": "00"}}):
        assert task_key(**{**base, **change}) != key, change


def test_parse_grid_and_product():
    grid = parse_grid(["pf.particles=100,300", "pf.init=uniform,truth", "ekf.gate=true"])
    assert grid == {"pf.particles": [100, 300], "pf.init": ["uniform", "truth"],
                    "ekf.gate": [True]}
    settings = grid_settings(grid, {"laser.sigma_xy_m": 0.02})
    assert len(settings) == 4
    assert settings[0] == {"laser.sigma_xy_m": 0.02, "pf.particles": 100, "pf.init": "uniform",
                           "ekf.gate": True}
    assert grid_settings({}) == [{}]
    for bad in (["pf.particles"], ["=1,2"], ["pf.particles=1,,2"], ["a=1", "a=2"], ["a=1,1"]):
        with pytest.raises(InputError):
            parse_grid(bad)
    with pytest.raises(InputError):
        grid_settings({"a": [1]}, {"a": 2})


def test_expand_logs_searches_directories(tmp_path):
    (tmp_path / "d" / "sub").mkdir(parents=True)
    for name in ("d/b.mcap", "d/sub/a.mcap", "d/notes.txt", "c.mcap"):
        (tmp_path / name).write_bytes(b"x")
    found = expand_logs([tmp_path / "c.mcap", tmp_path / "d", tmp_path / "d" / "b.mcap"])
    assert [p.name for p in found] == ["c.mcap", "b.mcap", "a.mcap"]
    with pytest.raises(InputError):
        expand_logs([tmp_path / "missing.mcap"])
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError):
        expand_logs([tmp_path / "empty"])


def test_missing_files_lists_what_a_worker_lacks(tmp_path):
    (tmp_path / "here.mcap").write_bytes(b"x")
    paths = [str(tmp_path / n) for n in ("here.mcap", "gone1.mcap", "gone2.mcap", "gone3.mcap")]
    assert missing_files(paths, limit=2) == paths[1:3]
    assert missing_files(paths[:1]) == []


def test_identical_logs_give_one_task_each(tmp_path):
    tasks = build_tasks([(tmp_path / "a.mcap", "11"), (tmp_path / "b.mcap", "11")],
                        [{"pf.particles": 1}, {"pf.particles": 2}], [0, 1])
    assert len(tasks) == 4
    assert len({t.key for t in tasks}) == 4


def test_student_t_quantiles_match_tables():
    for df, expected in ((1, 12.7062047), (2, 4.3026527), (4, 2.7764451), (9, 2.2621572),
                         (30, 2.0422725)):
        assert t_quantile(0.975, df) == pytest.approx(expected, abs=1e-6)
    assert t_quantile(0.025, 9) == pytest.approx(-2.2621572, abs=1e-6)
    s = describe([1.0, 2.0, 3.0, 4.0, None, math.nan])
    assert s.n == 4 and s.mean == 2.5
    assert s.std == pytest.approx(math.sqrt(5 / 3))
    half = 3.1824463 * s.std / 2.0
    assert (s.ci_low, s.ci_high) == pytest.approx((2.5 - half, 2.5 + half), abs=1e-6)
    assert math.isnan(describe([7.0]).ci_low)


def _doc(rmse_mm: float, pos_m: float) -> dict:
    circle = {"rmse_mm": rmse_mm, "variance_mm2": 4.0, "mean_mm": 0.5, "max_abs_mm": 9.0,
              "samples": 100, "rotations": 2, "improvement_pct": None,
              "rows": [{"log": "x", "rmse_mm": 1.0}]}
    truth = {"position_rmse_m": pos_m, "heading_rmse_deg": 1.0, "samples": 90}
    return {"log": {"name": "x", "duration_s": 30.0, "ground_truth": True},
            "reference": {"kinematic_radius_m": 0.69, "circle_drive": True},
            "rotations": {"complete": 2, "partial": 1, "direction": "ccw", "boundaries_s": [1, 2]},
            "truth_path": None,
            "estimators": {"laser": {"circle": circle, "truth": truth},
                           "pf": {"circle": None, "truth": truth, "settings": {"particles": 5}}},
            "warnings": ["w"]}


def test_document_metrics_flattens_with_dotted_keys():
    m = document_metrics(_doc(10.0, 0.02))
    assert m["metrics"]["laser"]["circle.rmse_mm"] == 10.0
    assert m["metrics"]["laser"]["circle.improvement_pct"] is None
    assert m["metrics"]["laser"]["truth.position_rmse_m"] == 0.02
    assert not any(k.startswith(("circle", "settings")) for k in m["metrics"]["pf"])
    assert "circle.rows" not in m["metrics"]["laser"]
    assert m["log_metrics"] == {"rotations.complete": 2, "rotations.partial": 1,
                                "log.duration_s": 30.0, "reference.kinematic_radius_m": 0.69}
    assert m["settings"] == {"pf": {"particles": 5}}


def test_tidy_and_summary_tables(tmp_path):
    tasks = build_tasks([(tmp_path / "good.mcap", "aa"), (tmp_path / "bad.mcap", "bb")],
                        [{"pf.particles": 10}, {"pf.particles": 20}], [0, 1, 2],
                        estimators=["laser", "pf"])
    store = TaskStore(tmp_path / "out")
    records = {}
    out: Outcome[Any, Any]
    for i, t in enumerate(tasks):
        if t.label.endswith("bad.mcap"):
            out = Outcome(i, t, None, "LogFormatError: not an MCAP file", input_error=True)
        else:
            out = Outcome(i, t, document_metrics(_doc(10.0 + t.seed, 0.01 * (t.seed + 1))))
        rec = task_record(t, out, "evaluate")
        store.save(rec)
        records[t.key] = store.load(t.key)
        assert is_final(records[t.key])
    assert not is_final(records[tasks[-1].key], retry_failed=True)
    tidy = tidy_table(tasks, records, grid_keys=["pf.particles"])
    assert len(tidy) == len(tasks) * 2
    assert list(tidy.columns[:12]) == ["key", "log", "log_name", "log_sha256", "setting",
                                       "pf.particles", "seed", "estimator", "status", "error",
                                       "elapsed_s", "cpu_s"]
    assert {"circle.rmse_mm", "truth.position_rmse_m", "rotations.complete"} <= set(tidy.columns)
    bad = tidy[tidy["log_name"] == "bad"]
    assert (bad["status"] == "error").all() and bad["circle.rmse_mm"].isna().all()
    assert set(bad["estimator"]) == {"laser", "pf"}

    summary = summary_table(tidy, grid_keys=["pf.particles"])
    assert len(summary) == 2 * 2 * 2
    row = summary[(summary["log_name"] == "good") & (summary["estimator"] == "laser")].iloc[0]
    assert row["tasks"] == 3 and row["ok"] == 3 and row["failed"] == 0
    assert row["circle.rmse_mm.mean"] == pytest.approx(11.0)
    assert row["circle.rmse_mm.std"] == pytest.approx(1.0)
    assert row["circle.rmse_mm.ci95_high"] == pytest.approx(11.0 + 4.3026527 / math.sqrt(3),
                                                            abs=1e-6)
    assert row["circle.rmse_mm.n"] == 3
    failed = summary[summary["log_name"] == "bad"]
    assert (failed["failed"] == 3).all()
    assert failed["error"].str.contains("not an MCAP file").all()


def test_sweep_task_is_small_to_ship(tmp_path):
    import pickle

    t = SweepTask(log=str(tmp_path / "a.mcap"), log_sha256="a" * 64, settings={"pf.x": 1}, seed=0)
    assert len(pickle.dumps(t)) < 1000


def test_report_draws_each_varying_figure_against_each_swept_parameter(tmp_path):
    from lgvtool.fleet.results import metric_columns
    from lgvtool.fleet.sweep_report import render_report

    tasks = build_tasks([(tmp_path / "a.mcap", "aa"), (tmp_path / "b.mcap", "bb")],
                        [{"pf.particles": p, "pf.init": i} for p in (10, 20, 40)
                         for i in ("uniform", "laser")], [0, 1, 2], estimators=["laser", "pf"])
    records = {}
    for i, t in enumerate(tasks):
        bad = t.label.endswith("b.mcap") and t.seed == 2
        out: Outcome[SweepTask, TaskMetrics] = (
            Outcome(i, t, None, "MissingDataError: no <motion>", input_error=True) if bad else
            Outcome(i, t, document_metrics(_doc(t.settings["pf.particles"] + t.seed, 0.01))))
        records[t.key] = task_record(t, out, "evaluate")
    grid: dict[str, list[Any]] = {"pf.particles": [10, 20, 40], "pf.init": ["uniform", "laser"]}
    tidy = tidy_table(tasks, records, grid_keys=list(grid))
    page = render_report(tidy, grid=grid, metrics=metric_columns(tidy, list(grid)),
                         facts={"tasks": len(tasks)})
    assert page.count("plotly.js v") == 1
    body = page.split("</head>", 1)[1]                 # the page's own, not plotly.js's
    assert body.count("Plotly.newPlot(") == 2          # circle.rmse_mm against both parameters
    assert "circle.rmse_mm against pf.particles" in page
    assert "circle.rmse_mm against pf.init" in page
    assert "rotations.complete against" not in page    # the same for every task of a log
    assert "no &lt;motion&gt;" in page and "6 task(s) failed" in page
    assert "NaN" not in page.split("</head>", 1)[1]
