"""Sweep tasks: which logs, which settings, which seeds, and the work done for one of them.

A sweep is the cartesian product logs x settings x seeds, where the settings are the
cartesian product of the ``--grid key=v1,v2,...`` options (keys as in ``lgvtool replay
--set``: ``pf.particles``, ``pf-paper.spread_m``, ...). Each task carries only the path of its
log, its content hash, the settings, the seed and the estimators: a worker opens the log
itself, so log bytes never travel through the scheduler.
"""

from __future__ import annotations

import itertools
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

from lgvtool.errors import InputError
from lgvtool.fleet.keys import task_key
from lgvtool.json_types import SettingValue
from lgvtool.values import parse_setting, split_assignment

if TYPE_CHECKING:
    from lgvtool.config import Config

KIND = "evaluate"
"""Task kind of the real sweep task (part of every task key)."""

LOG_SUFFIXES = (".mcap",)
"""File suffixes taken from a directory given as LOG_OR_DIR."""

LOG_METRIC_KEYS = (
    "log.duration_s",
    "reference.kinematic_radius_m",
    "reference.steering_angle_deg",
)
"""Log-level figures of the evaluation document kept beside the ``rotations.*`` and
``truth_path.*`` figures (the same for every estimator of a task)."""


@dataclass(frozen=True)
class SweepTask:
    """One unit of work: evaluate ``estimators`` on one log with one setting and one seed."""

    log: str
    """Absolute path of the log, as every worker must see it."""
    log_sha256: str
    """SHA-256 of the log's bytes."""
    settings: Mapping[str, Any]
    """Estimator settings (``pf.particles`` -> 300), passed to ``run_replay``."""
    seed: int
    estimators: tuple[str, ...] = ()
    """Estimators to run; empty: the default set of :mod:`lgvtool.localize`."""
    config: Config | None = None
    """Configuration overriding the one stored in the log (None: the log's own)."""
    key: str = ""
    """Content key of the task (see :mod:`lgvtool.fleet.keys`)."""
    label: str = ""
    """The log as the user named it (for tables)."""
    extra: Mapping[str, Any] = field(default_factory=dict)
    """Further inputs that the key covers (e.g. the configuration file's hash)."""


def parse_grid(items: Sequence[str]) -> dict[str, list[SettingValue]]:
    """Parse ``--grid key=v1,v2,...`` options into {key: [values]}.

    Keys and values are read by the parser of ``--set``
    (:func:`lgvtool.values.split_assignment`, :func:`lgvtool.values.parse_setting`: TOML
    scalars, else a bare string). A key given twice, an empty value list or a repeated value
    is an error.
    """
    grid: dict[str, list[SettingValue]] = {}
    for item in items:
        key, raw = split_assignment(item, "--grid", "key=v1,v2,...")
        if key in grid:
            raise InputError(f"--grid key '{key}' given twice")
        parts = [p.strip() for p in raw.split(",")]
        if not raw.strip() or any(not p for p in parts):
            raise InputError(f"--grid {key}: empty value in '{raw}'")
        values = [parse_setting(p) for p in parts]
        seen: list[SettingValue] = []
        for v in values:
            if any(type(v) is type(s) and v == s for s in seen):
                raise InputError(f"--grid {key}: value {v!r} given twice")
            seen.append(v)
        grid[key] = values
    return grid


def grid_settings(grid: Mapping[str, Sequence[SettingValue]],
                  fixed: Mapping[str, SettingValue] | None = None
                  ) -> list[dict[str, SettingValue]]:
    """The cartesian product of ``grid`` as a list of settings dicts, each on top of
    ``fixed`` (settings common to every task). No grid gives one setting: ``fixed``."""
    base = dict(fixed or {})
    both = set(base) & set(grid)
    if both:
        raise InputError(f"setting(s) {', '.join(sorted(both))} given both fixed and in --grid")
    keys = list(grid)
    return [{**base, **dict(zip(keys, combo, strict=True))}
            for combo in itertools.product(*(grid[k] for k in keys))]


def setting_label(settings: Mapping[str, object], keys: Sequence[str] | None = None) -> str:
    """A short text naming a setting: ``pf.particles=300,pf-paper.spread_m=0.1``; ``default``
    when there is nothing to name."""
    ks = list(keys) if keys is not None else list(settings)
    text = ",".join(f"{k}={settings[k]}" for k in ks if k in settings)
    return text or "default"


def expand_logs(paths: Sequence[str | Path]) -> list[Path]:
    """The log files named by ``paths``: files as given, directories searched recursively for
    ``*.mcap``. Order: as given, each directory's files sorted; duplicates dropped.

    :raises InputError: a path does not exist, or a directory holds no log.
    """
    out: list[Path] = []
    seen: set[Path] = set()
    for p in map(Path, paths):
        if p.is_dir():
            found = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix in LOG_SUFFIXES)
            if not found:
                raise InputError(f"{p}: no {'/'.join(LOG_SUFFIXES)} log in this directory")
        elif p.is_file():
            found = [p]
        else:
            raise InputError(f"{p}: no such file or directory")
        for f in found:
            r = f.resolve()
            if r not in seen:
                seen.add(r)
                out.append(f)
    return out


def build_tasks(
    logs: Sequence[tuple[str | Path, str]],
    settings: Sequence[Mapping[str, SettingValue]],
    seeds: Sequence[int],
    *,
    estimators: Sequence[str] = (),
    config: Config | None = None,
    extra: Mapping[str, object] | None = None,
    kind: str = KIND,
) -> list[SweepTask]:
    """One task per (log, setting, seed), in that nesting order, each with its key.

    ``logs`` holds (path, sha256) pairs. Two paths with the same content give the same key:
    only the first is kept.
    """
    tasks: list[SweepTask] = []
    keys: set[str] = set()
    for path, sha in logs:
        for s in settings:
            for seed in seeds:
                key = task_key(log_sha256=sha, kind=kind, estimators=estimators, settings=s,
                               seed=seed, extra=extra)
                if key in keys:
                    continue
                keys.add(key)
                tasks.append(SweepTask(
                    log=str(Path(path).resolve()), log_sha256=sha, settings=dict(s),
                    seed=int(seed), estimators=tuple(estimators), config=config, key=key,
                    label=str(path), extra=dict(extra or {})))
    return tasks


# --------------------------------------------------------------------------- the work


def flatten(data: Mapping[str, object], prefix: str = "") -> dict[str, float | int | None]:
    """Numbers of a nested dict under dotted keys (``circle.rmse_mm``); None stays None (a
    figure that could not be computed). Strings, booleans and lists are left out."""
    out: dict[str, float | int | None] = {}
    for k, v in data.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        elif isinstance(v, bool):
            continue
        elif v is None or isinstance(v, int | float):
            out[key] = v
    return out


class TaskMetrics(TypedDict):
    """The figures of one task's evaluation (:func:`document_metrics`): per estimator its
    dotted figure keys, the log's own figures, the effective settings per estimator, the
    evaluation's warnings."""

    metrics: dict[str, dict[str, float | int | None]]
    log_metrics: dict[str, float | int | None]
    settings: dict[str, object]
    warnings: list[str]


def document_metrics(doc: Mapping[str, Any]) -> TaskMetrics:
    """The figures of one log's evaluation document (``lgvtool evaluate --json``):

    ``metrics``: {estimator: {dotted key: number}} from ``estimators.<name>`` (its per-rotation
    rows and settings left out; a block that is null, such as ``circle`` without a circle
    drive, gives no key); ``log_metrics``: ``rotations.*``, ``truth_path.*`` and
    :data:`LOG_METRIC_KEYS`; ``settings``: the effective settings per estimator;
    ``warnings``: the evaluation's warnings.
    """
    metrics: dict[str, dict[str, Any]] = {}
    settings: dict[str, Any] = {}
    for name, block in (doc.get("estimators") or {}).items():
        block = dict(block or {})
        if block.get("settings"):
            settings[name] = block["settings"]
        block.pop("settings", None)
        metrics[name] = flatten({k: v for k, v in block.items() if v is not None})
    log_level = flatten({k: doc.get(k) or {} for k in ("rotations", "truth_path")})
    everything = flatten({k: doc.get(k) or {} for k in ("log", "reference")})
    log_level.update({k: everything.get(k) for k in LOG_METRIC_KEYS if k in everything})
    return {"metrics": metrics, "log_metrics": log_level, "settings": settings,
            "warnings": [str(w) for w in doc.get("warnings") or []]}


def check_settings(estimators: Sequence[str], settings: Sequence[Mapping[str, SettingValue]],
                   config: Config | None = None) -> list[str]:
    """Check estimator names and every setting of a sweep before any task runs; return the
    estimator names, deduplicated in order.

    :raises InputError: an unknown estimator or parameter, a value of the wrong type or range,
        or a setting of an estimator that is not run.
    """
    from lgvtool.localize.registry import (
        DEFAULT_ESTIMATORS,
        check_names,
        resolve_params,
        split_settings,
    )

    names = check_names(list(estimators))
    table = dict(config.estimators) if config is not None else None
    running = names or list(DEFAULT_ESTIMATORS)
    for s in settings:
        for name, overrides in split_settings(s).items():
            if name not in running:
                raise InputError(f"setting(s) {', '.join(sorted(overrides))} of estimator "
                                 f"'{name}' given, but '{name}' is not run "
                                 f"(running: {', '.join(running)})")
            resolve_params(name, table, overrides)
    return names


def missing_files(paths: Sequence[str], limit: int = 5) -> list[str]:
    """Run on a worker: up to ``limit`` of ``paths`` that are not files there."""
    out: list[str] = []
    for p in paths:
        if not Path(p).is_file():
            out.append(p)
            if len(out) >= limit:
                break
    return out


def evaluate_task(task: SweepTask) -> TaskMetrics:
    """Run the estimators over the task's log with its settings and seed, and evaluate them
    (:func:`lgvtool.evaluate.log_evaluation.evaluate_log`, the same figures as ``lgvtool evaluate
    --json``). Runs on a worker; opens only this task's log.

    Returns :func:`document_metrics` of the evaluation. Raises
    :class:`~lgvtool.errors.InputError` for a log that cannot be evaluated, and
    FileNotFoundError (not an input error: the task runs again next time) when this worker
    does not see the log at its path.
    """
    from lgvtool.evaluate.document import build_document
    from lgvtool.evaluate.log_evaluation import evaluate_log
    from lgvtool.log import LogReader

    if not Path(task.log).is_file():
        raise FileNotFoundError(f"{task.log}: not found on this worker (every worker must see "
                                "the logs at the same path)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(task.log)
        # a log written by replay holds estimates: the sweep runs the estimators afresh anyway
        result = evaluate_log(reader, estimators=list(task.estimators) or None,
                              config=task.config, seed=task.seed, settings=dict(task.settings),
                              replay=True, threads=1)  # the sweep runs tasks side by side
    return document_metrics(build_document([result]))
