"""Sweep results: one JSON file per task, the tidy table and the summary across seeds.

Files in the sweep's output directory:

- ``tasks/<key>.json``: one per finished task (see :func:`task_record`), written atomically
  as soon as the task ends, so an interrupted sweep keeps everything it had finished;
- ``results.parquet`` / ``results.csv``: the tidy table, one row per log x setting x seed x
  estimator, every figure of the evaluation as a column with a dotted name
  (``circle.rmse_mm``, ``truth.position_rmse_m``, ``rotations.complete``);
- ``summary.parquet`` / ``summary.csv``: per log x setting x estimator, over the seeds, for each
  figure ``<figure>.mean``, ``.std``, ``.ci95_low``, ``.ci95_high`` (Student t) and ``.n``,
  plus the number of tasks, of failures and their distinct errors.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from lgvtool import __version__
from lgvtool.fleet.keys import json_safe, write_json_atomic
from lgvtool.fleet.tasks import SweepTask, setting_label
from lgvtool.json_types import JSONObject

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.fleet.engine import Outcome

#: the value a task gives
R = TypeVar("R")

RECORD_FORMAT = "lgvtool.sweep-task"
RECORD_VERSION = 1

ID_COLUMNS = ("key", "log", "log_name", "log_sha256", "setting")
"""Leading columns of the tidy table; then one column per setting key, then these:"""
RUN_COLUMNS = ("seed", "estimator", "status", "error", "elapsed_s", "cpu_s")
SUMMARY_STATS = ("mean", "std", "ci95_low", "ci95_high", "n")
"""Suffixes of the summary's columns for each figure."""


def task_record(task: SweepTask, outcome: Outcome[SweepTask, R], kind: str
                ) -> dict[str, object]:
    """The JSON document stored for a finished task: what it was, and its value or error."""
    return {
        "format": RECORD_FORMAT,
        "format_version": RECORD_VERSION,
        "key": task.key,
        "kind": kind,
        "lgvtool_version": __version__,
        "log": {"path": task.label or task.log, "sha256": task.log_sha256},
        "settings": json_safe(dict(task.settings)),
        "seed": task.seed,
        "estimators": list(task.estimators),
        "extra": json_safe(dict(task.extra)),
        "status": "ok" if outcome.ok else "error",
        "error": outcome.error,
        "input_error": outcome.input_error,
        "detail": outcome.detail,
        "elapsed_s": outcome.elapsed_s,
        "cpu_s": outcome.cpu_s,
        "worker": outcome.worker,
        "finished_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "result": json_safe(outcome.value) if outcome.ok else None,
    }


class TaskStore:
    """The ``tasks/`` directory of a sweep: one JSON record per task key."""

    def __init__(self, outdir: str | Path) -> None:
        self.dir = Path(outdir) / "tasks"

    def path(self, key: str) -> Path:
        """File of the record of ``key``."""
        return self.dir / f"{key}.json"

    def load(self, key: str) -> JSONObject | None:
        """The record of ``key``, or None if absent or unreadable (then the task runs again)."""
        try:
            data = json.loads(self.path(key).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(data, dict) or data.get("format") != RECORD_FORMAT or data.get("key") != key:
            return None
        return data

    def save(self, record: Mapping[str, object]) -> None:
        """Store a record (atomically)."""
        write_json_atomic(self.path(str(record["key"])), record)


def is_final(record: Mapping[str, object] | None, *, retry_failed: bool = False) -> bool:
    """True when a stored record needs no new run: a success, or a failure caused by the
    task's input (which would fail the same way), unless ``retry_failed``. Failures of the
    machinery (a worker lost, an unexpected exception) are always run again."""
    if record is None:
        return False
    if record.get("status") == "ok":
        return True
    return bool(record.get("input_error")) and not retry_failed


def _setting_value_column(values: list[object]) -> list[object]:
    """One setting column with a single type: numbers, booleans, or else text."""
    present = [v for v in values if v is not None]
    if all(isinstance(v, bool) for v in present):
        return values
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in present):
        return values
    return [None if v is None else str(v) for v in values]


def tidy_table(
    tasks: Sequence[SweepTask],
    records: Mapping[str, Mapping[str, Any]],
    *,
    grid_keys: Sequence[str] = (),
) -> pd.DataFrame:
    """The tidy table of a sweep: one row per task x estimator, in task order.

    A failed task gives one row per estimator it was asked for (or, for the default set, per
    estimator seen in the other tasks) with ``status`` 'error', its ``error`` and no figures.
    Tasks without a record are left out.
    """
    import pandas as pd

    seen_estimators: list[str] = []
    for t in tasks:
        rec = records.get(t.key)
        if rec and rec.get("status") == "ok":
            for name in ((rec.get("result") or {}).get("metrics") or {}):
                if name not in seen_estimators:
                    seen_estimators.append(name)
    setting_keys: list[str] = list(grid_keys)
    for t in tasks:
        for k in t.settings:
            if k not in setting_keys:
                setting_keys.append(k)

    rows: list[dict[str, Any]] = []
    for t in tasks:
        rec = records.get(t.key)
        if rec is None:
            continue
        base: dict[str, Any] = {
            "key": t.key, "log": t.label or t.log, "log_name": Path(t.log).stem,
            "log_sha256": t.log_sha256, "setting": setting_label(t.settings, grid_keys),
        }
        base.update({k: t.settings.get(k) for k in setting_keys})
        base.update({"seed": t.seed, "status": rec.get("status"), "error": rec.get("error"),
                     "elapsed_s": rec.get("elapsed_s"), "cpu_s": rec.get("cpu_s")})
        result = rec.get("result") or {}
        metrics: Mapping[str, Mapping[str, Any]] = result.get("metrics") or {}
        log_metrics: Mapping[str, Any] = result.get("log_metrics") or {}
        warnings = "; ".join(str(w) for w in result.get("warnings") or [])
        names: list[str | None]
        if rec.get("status") == "ok":
            names = list(metrics) or [None]
        else:
            names = list(t.estimators or seen_estimators) or [None]
        for name in names:
            row = dict(base)
            row["estimator"] = name
            row.update(metrics.get(name, {}) if name is not None else {})
            row.update(log_metrics)
            row["warnings"] = warnings
            rows.append(row)

    fixed = [*ID_COLUMNS, *setting_keys, *RUN_COLUMNS]
    clash = [k for k in setting_keys if k in ID_COLUMNS or k in RUN_COLUMNS or k == "warnings"]
    if clash:
        from lgvtool.errors import InputError

        raise InputError(f"setting name(s) {', '.join(clash)} clash with column names of the table")
    metric_cols: list[str] = []
    for r in rows:
        for k in r:
            if k not in fixed and k != "warnings" and k not in metric_cols:
                metric_cols.append(k)
    df = pd.DataFrame(rows, columns=[*fixed, *metric_cols, "warnings"])
    for k in setting_keys:
        df[k] = _setting_value_column(df[k].tolist())
    for k in metric_cols:
        df[k] = pd.to_numeric(df[k], errors="coerce").astype(float)
    df["seed"] = df["seed"].astype("int64")
    for k in ("elapsed_s", "cpu_s"):
        df[k] = pd.to_numeric(df[k], errors="coerce").astype(float)
    return df


def metric_columns(tidy: pd.DataFrame, grid_keys: Sequence[str] = ()) -> list[str]:
    """The figure columns of a tidy table (everything that is not an id, setting or run
    column)."""
    fixed = {*ID_COLUMNS, *RUN_COLUMNS, "warnings", *grid_keys}
    start = list(tidy.columns).index(RUN_COLUMNS[-1]) + 1
    return [c for c in list(tidy.columns)[start:] if c not in fixed]


def summary_table(tidy: pd.DataFrame, *, grid_keys: Sequence[str] = (),
                  level: float = 0.95) -> pd.DataFrame:
    """Per log x setting x estimator over the seeds: ``tasks``, ``ok``, ``failed``, the first
    ``error``, and for each figure its mean, sample std, Student-t ``level`` confidence
    interval of the mean and the number of seeds that gave it."""
    import numpy as np
    import pandas as pd

    from lgvtool.quantiles import t_quantile

    metrics = metric_columns(tidy, grid_keys)
    start = list(tidy.columns).index("setting") + 1
    setting_cols = list(tidy.columns)[start:list(tidy.columns).index("seed")]
    keys = ["log", "log_name", "log_sha256", "setting", "estimator"]
    if tidy.empty:
        return pd.DataFrame(columns=[*keys[:4], *setting_cols, "estimator", "tasks", "ok", "failed",
                                     "error", *(f"{m}.{s}" for m in metrics for s in SUMMARY_STATS)])
    work = tidy.copy()
    work["estimator"] = work["estimator"].astype(object).where(work["estimator"].notna(), "")
    g = work.groupby(keys, sort=False, dropna=False)
    head = g[setting_cols].first() if setting_cols else g.size().to_frame().iloc[:, :0]
    out = head.copy()
    out["tasks"] = g.size()
    out["ok"] = g["status"].apply(lambda s: int((s == "ok").sum()))
    out["failed"] = out["tasks"] - out["ok"]
    out["error"] = g["error"].apply(
        lambda s: " | ".join(dict.fromkeys(str(e) for e in s if isinstance(e, str) and e)) or None)
    q = 1.0 - (1.0 - level) / 2.0
    if metrics:
        mean = g[metrics].mean()
        std = g[metrics].std(ddof=1)
        n = g[metrics].count()
        tq = n.map(lambda k: t_quantile(q, k - 1) if k > 1 else math.nan)
        half = tq * std / np.sqrt(n.where(n > 0))
        cols = {}
        for m in metrics:
            cols[f"{m}.mean"] = mean[m]
            cols[f"{m}.std"] = std[m]
            cols[f"{m}.ci95_low"] = mean[m] - half[m]
            cols[f"{m}.ci95_high"] = mean[m] + half[m]
            cols[f"{m}.n"] = n[m].astype("int64")
        out = pd.concat([out, pd.DataFrame(cols, index=out.index)], axis=1)
    out = out.reset_index()
    out["estimator"] = out["estimator"].where(out["estimator"] != "", None)
    order = [*keys[:4], *setting_cols, "estimator", "tasks", "ok", "failed", "error"]
    return out[[*order, *[c for c in out.columns if c not in order]]]


def write_table(df: pd.DataFrame, stem: Path, place: Callable[[Path], Path]) -> list[Path]:
    """Write ``df`` as ``<stem>.parquet`` and ``<stem>.csv`` through ``place`` (output ->
    the temporary path to write, :func:`lgvtool.outputs.atomic_outputs`); return both paths."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    pq, csv = stem.with_suffix(".parquet"), stem.with_suffix(".csv")
    df.to_parquet(place(pq), index=False)
    df.to_csv(place(csv), index=False)
    return [pq, csv]
