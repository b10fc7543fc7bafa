"""Parameter sweeps over many logs and seeds on a Dask cluster (``lgvtool sweep``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.app.option_values import SettingValue
    from lgvtool.fleet.sweep_run import SweepResult

OUTPUT_FILES = ("results.parquet", "results.csv", "summary.parquet", "summary.csv",
                "report.html", "sweep.json")
"""Files a sweep writes into OUTDIR (beside its tasks/ cache, which is always reused)."""


@dataclass(frozen=True, slots=True)
class SweepOptions:
    """What :func:`sweep_logs` sweeps, where it runs and where it writes (``lgvtool
    sweep``)."""

    logs: tuple[str, ...]
    """Log files, or directories searched for *.mcap."""
    outdir: str
    """Directory of the results (created; re-using it resumes the sweep)."""
    estimators: tuple[str, ...] = ()
    """Estimators to run; empty: the default set."""
    grid: Mapping[str, tuple[SettingValue, ...]] = field(default_factory=dict)
    """Values of each estimator setting to sweep (``pf.particles`` -> (100, 300, 1000));
    their product is swept."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Estimator settings fixed for every task (``pf.init`` -> ``laser``)."""
    seeds: int = 1
    """Seeds per log and setting: 0 .. seeds - 1."""
    scheduler: str | None = None
    """Address of a Dask scheduler (``tls://HOST:PORT`` or ``tcp://HOST:PORT``); None: a
    local cluster."""
    tls_ca_file: str | None = None
    """CA file (PEM) of a ``tls://`` :attr:`scheduler`."""
    tls_cert: str | None = None
    """This client's certificate (PEM) for a ``tls://`` :attr:`scheduler`."""
    tls_key: str | None = None
    """Private key of :attr:`tls_cert` (PEM), when not in that file."""
    force: bool = False
    """Replace the files of :data:`OUTPUT_FILES` in :attr:`outdir`."""
    workers: int | None = None
    """Worker processes of the local cluster; None: one per CPU."""
    config_path: str | None = None
    """Configuration (TOML) used instead of the one stored in each log; None: the logs' own."""
    retry_failed: bool = False
    """Run again the tasks whose log failed before (corrupt, missing channels)."""
    show_progress: bool = True
    """Progress bar on stderr."""


def sweep_logs(options: SweepOptions) -> SweepResult:
    """Run the ``options``' estimators over every log for every setting of the grid and every
    seed, and evaluate each run as :func:`lgvtool.evaluate.log_evaluation.evaluate_log` does:
    one task per (log, setting, seed), on a local Dask cluster or on a scheduler (see
    :class:`SweepOptions`). Finished tasks are kept in ``outdir``/tasks/ and reused;
    :data:`OUTPUT_FILES` are written into ``outdir`` (replaced only with ``force``). A log
    that fails is reported in the result, not raised.

    :raises InputError: (exit 2) the fleet extra is missing, a bad option, setting or path.
    """
    from pathlib import Path

    from lgvtool.config import load_config
    from lgvtool.errors import InputError
    from lgvtool.fleet.connect import require_fleet, scheduler_spec
    from lgvtool.outdir import guard_directory

    require_fleet("sweep", ("dask", "distributed", "pyarrow"))
    from lgvtool.fleet.sweep_run import run_sweep
    from lgvtool.fleet.tasks import check_settings, grid_settings

    o = options
    if o.scheduler is not None and o.workers is not None:
        raise InputError("give --scheduler or --workers, not both")
    guard_directory(o.outdir, OUTPUT_FILES, [*o.logs, o.config_path], force=o.force)
    cluster = scheduler_spec(o.scheduler, o.tls_ca_file, o.tls_cert, o.tls_key)
    grid = {key: list(values) for key, values in o.grid.items()}
    fixed = dict(o.settings)
    config = load_config(o.config_path) if o.config_path else None
    names = check_settings(list(o.estimators), grid_settings(grid, fixed), config)
    return run_sweep(
        o.logs, Path(o.outdir), grid=grid, fixed=fixed, seeds=o.seeds, estimators=names,
        config=config, config_path=o.config_path, scheduler=cluster, workers=o.workers,
        progress=o.show_progress, retry_failed=o.retry_failed)
