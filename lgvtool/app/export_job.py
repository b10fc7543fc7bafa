"""Exporting a log's trajectories as TUM, KITTI, CSV or Parquet files (``lgvtool export``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.interop.trajectory_export import ExportSummary


def export_trajectories(log: str, outdir: str, fmt: str = "tum", *,
                        estimators: Sequence[str] | None = None, seed: int = 0,
                        sets: Sequence[str] = (), config_path: str | None = None,
                        start_at_truth: bool = False, force: bool = False,
                        threads: int | None = 1) -> ExportSummary:
    """Write every trajectory of ``log`` into ``outdir`` as ``fmt`` (tum, kitti, csv or
    parquet) files: each estimator's pose of O, the NAV pose converted to O, the ground truth
    and the truth at each trajectory's stamps. Times in s since the Unix epoch, positions in
    m, headings in rad, in the map frame. The log's estimates are exported if it has any, else
    ``estimators`` are run with ``seed``, the ``KEY=VALUE`` settings ``sets`` and the
    configuration ``config_path`` (default: the log's own), on ``threads`` threads at once
    (None: one per estimator, at most one per CPU; the same files for any count). The summary
    names every file written and holds the warnings.

    :raises InputError: (exit 2) unknown format, pyarrow missing for Parquet, an output that
        exists (without ``force``) or is the log, a log without the estimates asked for.
    """
    from lgvtool.config import load_config, parse_set_options
    from lgvtool.interop.trajectory_export import export_log

    return export_log(log, outdir, fmt, estimators=estimators,
                      config=load_config(config_path) if config_path else None, seed=seed,
                      settings=parse_set_options(list(sets)), start_at_truth=start_at_truth,
                      force=force, threads=threads)
