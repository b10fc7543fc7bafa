"""The audit over many logs: the KPI table (one row per vehicle and day), ``--resume`` from the
evidence kept per log, and a damaged kept file refused."""

from __future__ import annotations

import csv
import json
import math
import re
from pathlib import Path

import pytest
from inprocess import run_command
from simlogs import simulate_log

from lgvtool.app.audit_job import AuditOptions, audit_logs
from lgvtool.audit.fleet_table import KPI_COLUMNS, LOGS_DIR, kpi_table, vehicle_of
from lgvtool.json_types import JSON

TOLERANCE = 1e-9
"""Relative and absolute tolerance of two audit.json floats (the evidence is the same)."""


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Four short drives of one site; the second with invalid NAV replies (dropouts)."""
    d = tmp_path_factory.mktemp("fleet")
    return [simulate_log(d / "l1.mcap", 15.0, 1),
            simulate_log(d / "l2.mcap", 15.0, 2, sets=["faults.nav_invalid_rate=0.15"]),
            simulate_log(d / "l3.mcap", 15.0, 3),
            simulate_log(d / "l4.mcap", 15.0, 4)]


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _close(a: JSON, b: JSON, where: str = "") -> None:
    """``a`` equals ``b``, floats within :data:`TOLERANCE`."""
    if isinstance(a, float) or isinstance(b, float):
        assert isinstance(a, int | float) and isinstance(b, int | float), where
        assert math.isclose(a, b, rel_tol=TOLERANCE, abs_tol=TOLERANCE), where
    elif isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for k in a:
            _close(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _close(x, y, f"{where}[{i}]")
    else:
        assert a == b, where


def test_three_logs_give_one_row_each_and_resume_runs_only_the_new_one(
        logs: list[Path], tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = audit_logs(AuditOptions(tuple(str(p) for p in logs[:3]), str(out),
                                  show_progress=False))
    rows = _rows(out / "kpis.csv")
    assert len(rows) == 3
    assert tuple(rows[0].keys()) == KPI_COLUMNS
    assert [r["vehicle"] for r in rows] == ["l1", "l2", "l3"]  # no vehicle in the metadata
    assert all(re.fullmatch(r"\d{4}-\d{2}-\d{2}", r["day"]) for r in rows)
    layout = len(run.document["layout"])  # type: ignore[arg-type]
    nav = run.document["navigation"]
    assert isinstance(nav, dict) and isinstance(nav["logs"], list)
    for row, part in zip(rows, nav["logs"], strict=True):
        assert isinstance(part, dict) and isinstance(part["dropouts"], list)
        assert int(row["logs"]) == 1
        assert sum(int(row[f"reflectors_{s}"]) for s in
                   ("ok", "missing", "moved", "weak", "ambiguous")) == layout
        assert int(row["dropouts"]) == len(part["dropouts"])
        assert float(row["dropout_time_s"]) == pytest.approx(part["dropout_time_s"], abs=2e-3)
        assert int(row["pose_jumps"]) == len(part["pose_jumps"])  # type: ignore[arg-type]
        assert 0.0 <= float(row["share_in_navigation"]) <= 1.0
        assert float(row["visible_median"]) > 0.0
    assert int(rows[1]["dropouts"]) > 0  # the faulty drive
    assert float(rows[1]["share_in_navigation"]) < float(rows[0]["share_in_navigation"])
    pytest.importorskip("pyarrow")
    import pandas as pd

    frame = pd.read_parquet(out / "kpis.parquet")
    assert list(frame.columns) == list(KPI_COLUMNS) and len(frame) == 3

    kept = {p.name: (p.stat().st_mtime_ns, p.read_bytes())
            for p in (out / LOGS_DIR).glob("*.pkl")}
    assert len(kept) == 3
    audit_logs(AuditOptions(tuple(str(p) for p in logs), str(out), resume=True,
                            show_progress=False))
    now = {p.name: (p.stat().st_mtime_ns, p.read_bytes()) for p in (out / LOGS_DIR).glob("*.pkl")}
    assert len(now) == 4
    assert {k: now[k] for k in kept} == kept  # the three kept ones were not run again
    again = _rows(out / "kpis.csv")
    assert [r["vehicle"] for r in again] == ["l1", "l2", "l3", "l4"]
    assert [r["elapsed_s"] for r in again[:3]] == [r["elapsed_s"] for r in rows]

    fresh = tmp_path / "fresh"
    audit_logs(AuditOptions(tuple(str(p) for p in logs), str(fresh), show_progress=False))
    _close(json.loads((out / "audit.json").read_text(encoding="utf-8")),
           json.loads((fresh / "audit.json").read_text(encoding="utf-8")))


def test_a_damaged_kept_file_is_refused_with_one_line(
        logs: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    code, _, _ = run_command(capsys, "audit", logs[0], "-o", out, "--no-progress")
    assert code == 0
    (kept,) = (out / LOGS_DIR).glob("*.pkl")
    kept.write_bytes(kept.read_bytes()[:100])
    code, _, err = run_command(capsys, "audit", logs[0], "-o", out, "--no-progress",
                               "--resume")
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "not a readable audit evidence" in err
    code, _, _ = run_command(capsys, "audit", logs[0], "-o", out, "--no-progress", "--force")
    assert code == 0  # --force runs the log again and keeps its evidence anew


def test_the_table_groups_the_logs_of_one_vehicle_and_day() -> None:
    base: dict[str, float | str] = {c: 0.0 for c in KPI_COLUMNS}
    a: dict[str, float | str] = {**base, "vehicle": "agv7", "day": "2026-01-02", "duration_s": 100.0,
         "dropouts": 2.0, "share_in_navigation": 0.9, "gdop_median": 1.0}
    b: dict[str, float | str] = {**base, "vehicle": "agv7", "day": "2026-01-02", "duration_s": 300.0,
         "dropouts": 1.0, "share_in_navigation": 1.0, "gdop_median": math.nan}
    c: dict[str, float | str] = {**base, "vehicle": "agv2", "day": "2026-01-02", "duration_s": 50.0}
    table = kpi_table([a, b, c])
    assert [(r["vehicle"], r["logs"]) for r in table] == [("agv2", 1.0), ("agv7", 2.0)]
    row = table[1]
    assert row["duration_s"] == pytest.approx(400.0, abs=1e-9)
    assert row["dropouts"] == pytest.approx(3.0, abs=1e-9)
    assert row["share_in_navigation"] == pytest.approx(0.975, abs=1e-9)  # by duration
    assert row["gdop_median"] == pytest.approx(1.0, abs=1e-9)  # NaN left out


def test_the_station_deviation_pools_over_the_visits() -> None:
    base: dict[str, float | str] = {c: 0.0 for c in KPI_COLUMNS}
    a: dict[str, float | str] = {**base, "vehicle": "agv7", "day": "2026-01-02",
                                 "duration_s": 100.0, "station_visits": 3.0,
                                 "station_visits_outside": 1.0,
                                 "station_deviation_rms_m": 0.01}
    b: dict[str, float | str] = {**base, "vehicle": "agv7", "day": "2026-01-02",
                                 "duration_s": 900.0, "station_visits": 1.0,
                                 "station_visits_outside": math.nan,
                                 "station_deviation_rms_m": 0.03}
    (row,) = kpi_table([a, b])
    assert row["station_visits"] == pytest.approx(4.0, abs=1e-9)
    assert row["station_visits_outside"] == pytest.approx(1.0, abs=1e-9)
    # the mean square of the four visits, not a mean by duration
    assert row["station_deviation_rms_m"] == pytest.approx(
        math.sqrt((3 * 0.01**2 + 0.03**2) / 4), abs=1e-12)


def test_the_vehicle_is_the_metadata_s_else_the_file_s() -> None:
    assert vehicle_of({"vehicle": {"name": "agv7"}, "recorder": {"host": "pc"}}, "a") == "agv7"
    assert vehicle_of({"recorder": {"host": "pc"}}, "a") == "pc"
    assert vehicle_of({"recorder": {"host": ""}}, "a") == "a"


class _Shell:
    """A pickle that asks the unpickler to call ``os.mkdir(where)`` when loaded."""

    def __init__(self, where: Path) -> None:
        self.where = where

    def __reduce__(self) -> tuple[object, tuple[str]]:
        import os

        return (os.mkdir, (str(self.where),))


def test_a_crafted_evidence_file_cannot_run_code(tmp_path: Path) -> None:
    import pickle

    from lgvtool.audit.fleet_table import load_audited
    from lgvtool.errors import InputError

    made = tmp_path / "made-by-the-pickle"
    path = tmp_path / "crafted.pkl"
    path.write_bytes(pickle.dumps({"format": "x", "log": _Shell(made)}))
    with pytest.raises(InputError, match="not a readable audit evidence file"):
        load_audited(path, "key")
    assert not made.exists()
