"""Parameter sweeps over many logs and seeds on a Dask cluster (``lgvtool sweep``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.fleet.sweep_run import SweepResult

OUTPUT_FILES = ("results.parquet", "results.csv", "summary.parquet", "summary.csv",
                "report.html", "sweep.json")
"""Files a sweep writes into OUTDIR (beside its tasks/ cache, which is always reused)."""


def sweep_logs(logs: Sequence[str], outdir: str, *, estimators: Sequence[str] = (),
               grid_items: Sequence[str] = (), sets: Sequence[str] = (), seeds: int = 1,
               scheduler: str | None = None,
               tls: tuple[str | None, str | None, str | None] = (None, None, None),
               force: bool = False, workers: int | None = None, config_path: str | None = None,
               retry_failed: bool = False, show_progress: bool = True) -> SweepResult:
    """Run ``estimators`` over every log of ``logs`` (files, or directories searched for
    *.mcap) for every setting of the grid and every seed 0 .. ``seeds`` - 1, and evaluate each
    run as :func:`lgvtool.evaluate.log_evaluation.evaluate_log` does: one task per (log, setting,
    seed), on a local Dask cluster of ``workers`` processes or on ``scheduler`` (with the
    ``tls`` CA file, certificate and key). ``grid_items`` are ``KEY=V1,V2,...`` (their
    product is swept), ``sets`` ``KEY=VALUE`` settings fixed for every task, ``config_path``
    a configuration TOML used instead of each log's own. Finished tasks are kept in
    ``outdir``/tasks/ and reused; :data:`OUTPUT_FILES` are written into ``outdir`` (replaced
    only with ``force``). A log that fails is reported in the result, not raised.

    :raises InputError: (exit 2) the fleet extra is missing, a bad option, setting or path.
    """
    from pathlib import Path

    from lgvtool.config import load_config, parse_set_options
    from lgvtool.errors import InputError
    from lgvtool.fleet.connect import require_fleet, scheduler_spec
    from lgvtool.outdir import guard_directory

    require_fleet("sweep", ("dask", "distributed", "pyarrow"))
    from lgvtool.fleet.sweep_run import run_sweep
    from lgvtool.fleet.tasks import check_settings, grid_settings, parse_grid

    if scheduler is not None and workers is not None:
        raise InputError("give --scheduler or --workers, not both")
    guard_directory(outdir, OUTPUT_FILES, [*logs, config_path], force=force)
    cluster = scheduler_spec(scheduler, *tls)
    grid = parse_grid(grid_items)
    fixed = parse_set_options(list(sets))
    config = load_config(config_path) if config_path else None
    names = check_settings(list(estimators), grid_settings(grid, fixed), config)
    return run_sweep(
        logs, Path(outdir), grid=grid, fixed=fixed, seeds=seeds, estimators=names,
        config=config, config_path=config_path, scheduler=cluster, workers=workers,
        progress=show_progress, retry_failed=retry_failed)
