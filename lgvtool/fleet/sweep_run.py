"""A parameter sweep over many logs and seeds: plan, skip what is done, run the rest, tabulate.

:func:`run_sweep` is what ``lgvtool sweep`` calls. The task function is a parameter
(default :func:`lgvtool.fleet.tasks.evaluate_task`), so the machinery (keys, resuming, tables,
report) does not depend on what a task computes.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypedDict

from lgvtool import __version__
from lgvtool.fleet.keys import HashCache, file_sha256, json_safe, json_text
from lgvtool.fleet.results import (
    TaskStore,
    is_final,
    metric_columns,
    summary_table,
    task_record,
    tidy_table,
    write_table,
)
from lgvtool.fleet.tasks import KIND, SweepTask, build_tasks, evaluate_task, expand_logs, grid_settings
from lgvtool.json_types import SettingValue
from lgvtool.outputs import atomic_outputs

if TYPE_CHECKING:
    import pandas as pd
    from distributed import Client

    from lgvtool.config import Config
    from lgvtool.fleet.connect import SchedulerSpec


class SweepFacts(TypedDict):
    """The facts of a sweep (:meth:`SweepResult.as_dict`): its folder, the tasks in it, reused,
    run now and failed, the wall time (s), the files written (names), one {log, setting,
    seed, error} per failed task and the warnings per log."""

    outdir: str
    tasks: int
    reused: int
    ran: int
    failed: int
    elapsed_s: float
    files: list[str]
    failures: list[dict[str, object]]
    warnings: dict[str, str]


@dataclass
class SweepResult:
    """What a sweep did and where its results are."""

    outdir: Path
    tasks: int
    """Tasks in the sweep (logs x settings x seeds)."""
    reused: int
    """Tasks whose stored result was taken as it was."""
    ran: int
    """Tasks run now."""
    failed: int
    """Tasks (run now or earlier) that ended with an error."""
    elapsed_s: float
    """Wall time of the sweep, s."""
    tidy: pd.DataFrame
    summary: pd.DataFrame
    files: list[Path] = field(default_factory=list)
    failures: list[dict[str, Any]] = field(default_factory=list)
    """One {log, setting, seed, error} per failed task."""
    warnings: dict[str, str] = field(default_factory=dict)
    """Per log whose runs read it with warnings (a salvaged file, say): the warnings of its
    first such run, as results.csv's ``warnings`` column gives them but for the path the
    worker opened, which a reader's warning starts with."""

    def as_dict(self) -> SweepFacts:
        """JSON-ready facts of the sweep (no tables)."""
        return {"outdir": str(self.outdir), "tasks": self.tasks, "reused": self.reused,
                "ran": self.ran, "failed": self.failed, "elapsed_s": self.elapsed_s,
                "files": [p.name for p in self.files], "failures": self.failures,
                "warnings": self.warnings}


def check_paths_on_workers(client: Client, paths: Sequence[str]) -> None:
    """Check that every worker of ``client`` sees every log at its path.

    :raises InputError: naming a worker and up to five logs it does not see.
    """
    from lgvtool.errors import InputError
    from lgvtool.fleet.tasks import missing_files

    for worker, missing in sorted(client.run(missing_files, list(paths)).items()):
        if missing:
            raise InputError(f"the Dask worker {worker} does not see {', '.join(missing)}: every "
                             "worker must reach the logs at the same path (see docs/fleet.md)")


def run_sweep(
    logs: Sequence[str | Path],
    outdir: str | Path,
    *,
    grid: Mapping[str, Sequence[SettingValue]] | None = None,
    fixed: Mapping[str, SettingValue] | None = None,
    seeds: int | Iterable[int] = 1,
    estimators: Sequence[str] = (),
    config: Config | None = None,
    config_path: str | Path | None = None,
    scheduler: str | SchedulerSpec | None = None,
    workers: int | None = None,
    client: Client | None = None,
    progress: bool = True,
    retry_failed: bool = False,
    task_fn: Callable[[SweepTask], Mapping[str, object]] = evaluate_task,
    kind: str = KIND,
    report: bool = True,
) -> SweepResult:
    """Run a sweep and write its results into ``outdir``.

    :param logs: log files and directories (searched for ``*.mcap``).
    :param grid: {setting: [values]}; the sweep runs the cartesian product.
    :param fixed: settings common to every task.
    :param seeds: number of seeds (0 .. n-1) or the seeds themselves.
    :param estimators: estimators to run (empty: lgvtool's default set).
    :param config: configuration overriding each log's own; ``config_path`` is its file,
        whose hash enters the task keys.
    :param scheduler: ``tcp://host:port`` of a Dask scheduler; None: a local cluster of
        ``workers`` processes (default one per CPU), started only if there is work to do.
    :param client: an open Dask client to use instead.
    :param progress: progress bar on stderr.
    :param retry_failed: run again the tasks that failed on their input before.
    :param task_fn: the work of one task; returns {"metrics": {estimator: {figure: number}},
        "log_metrics": {figure: number}, "warnings": [...]}.
    :param kind: name of the task function's kind, part of every task key.
    :param report: write report.html.
    """
    from lgvtool.fleet.engine import open_client, run_tasks

    t_start = time.monotonic()
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    grid = {k: list(v) for k, v in (grid or {}).items()}
    seed_list = list(range(seeds)) if isinstance(seeds, int) else [int(s) for s in seeds]
    if not seed_list:
        from lgvtool.errors import InputError

        raise InputError("a sweep needs at least one seed")
    files = expand_logs(logs)
    cache = HashCache(out / "logs.json")
    hashes = cache.hash_many(files)
    cache.save()
    extra: dict[str, Any] = {}
    if config_path is not None:
        extra["config_sha256"] = file_sha256(config_path)
    settings = grid_settings(grid, fixed)
    tasks = build_tasks(list(zip(files, hashes, strict=True)), settings, seed_list,
                        estimators=estimators, config=config, extra=extra, kind=kind)

    store = TaskStore(out)
    records: dict[str, Mapping[str, Any]] = {}
    todo: list[SweepTask] = []
    for t in tasks:
        rec = store.load(t.key)
        if is_final(rec, retry_failed=retry_failed):
            assert rec is not None
            records[t.key] = rec
        else:
            todo.append(t)
    reused = len(tasks) - len(todo)
    if progress and reused:
        print(f"lgvtool: sweep: {reused} of {len(tasks)} task(s) already done, {len(todo)} to run",
              file=sys.stderr)
    if todo:
        with ExitStack() as stack:
            if client is None:
                client = stack.enter_context(open_client(scheduler, workers))
                if scheduler is not None:
                    check_paths_on_workers(client, sorted({t.log for t in todo}))
            for outcome in run_tasks(task_fn, todo, client=client, progress=progress,
                                     label="sweep"):
                record = task_record(outcome.task, outcome, kind)
                store.save(record)
                records[outcome.task.key] = record

    grid_keys = list(grid)
    tidy = tidy_table(tasks, records, grid_keys=grid_keys)
    summary = summary_table(tidy, grid_keys=grid_keys)
    failures = [{"log": t.label, "setting": dict(t.settings), "seed": t.seed,
                 "error": records[t.key].get("error")}
                for t in tasks if records.get(t.key, {}).get("status") != "ok"]
    warned: dict[str, str] = {}
    for t in tasks:
        said = (records.get(t.key, {}).get("result") or {}).get("warnings") or []
        if said and t.label not in warned:
            # a reader's warning names the file as the worker opened it: the label says that
            warned[t.label] = "; ".join(str(w).removeprefix(f"{t.log}: ") for w in said)
    # the results land together: when one file cannot be written (a full disk), none of them
    # is replaced (the tasks' cache stays, and a run again resumes from it)
    with atomic_outputs() as place:
        written = (write_table(tidy, out / "results", place)
                   + write_table(summary, out / "summary", place))
        result = SweepResult(out, len(tasks), reused, len(todo), len(failures), 0.0, tidy,
                             summary, written, failures, warned)
        if report:
            from lgvtool.fleet.sweep_report import render_report

            facts = {"logs": len(files), "settings": len(settings), "seeds": len(seed_list),
                     "tasks": len(tasks), "failed": len(failures),
                     "estimators": ", ".join(estimators) or "default set",
                     "grid": "; ".join(f"{k} = {', '.join(map(str, v))}"
                                       for k, v in grid.items()) or "none",
                     "lgvtool": __version__}
            page = render_report(tidy, grid=grid, metrics=metric_columns(tidy, grid_keys),
                                 title="lgvtool sweep", facts=facts)
            place(out / "report.html").write_text(page, encoding="utf-8")
            result.files.append(out / "report.html")
        manifest = {"format": "lgvtool.sweep", "format_version": 1,
                    "lgvtool_version": __version__, "grid": grid, "fixed": dict(fixed or {}),
                    "seeds": seed_list, "estimators": list(estimators), "kind": kind,
                    **result.as_dict(),
                    "logs": [{"path": str(f), "sha256": h}
                             for f, h in zip(files, hashes, strict=True)],
                    "keys": [t.key for t in tasks]}
        manifest.pop("outdir")
        manifest.pop("elapsed_s")
        place(out / "sweep.json").write_text(
            json_text(json_safe(manifest)), encoding="utf-8")
        result.files.append(out / "sweep.json")
    result.elapsed_s = time.monotonic() - t_start
    return result
