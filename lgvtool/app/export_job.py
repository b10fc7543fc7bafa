"""Exporting a log's trajectories as TUM, KITTI, CSV or Parquet files (``lgvtool export``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.app.option_values import SettingValue
    from lgvtool.interop.trajectory_export import ExportSummary


@dataclass(frozen=True, slots=True)
class ExportOptions:
    """What :func:`export_trajectories` exports, and how (``lgvtool export``)."""

    log: str
    """The log (MCAP) whose trajectories are exported."""
    outdir: str
    """Folder that receives one file (set) per trajectory (created)."""
    fmt: str = "tum"
    """File format: tum, kitti, csv or parquet (docs/interop.md)."""
    estimators: tuple[str, ...] | None = None
    """Estimators to export; None: the log's estimates, else the default set run over it."""
    seed: int = 0
    """Seed of the estimators when they are run."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Estimator settings (``pf.particles`` -> 500) when they are run."""
    config_path: str | None = None
    """Configuration (TOML) used instead of the log's own; None: the log's."""
    start_at_truth: bool = False
    """Start the estimators run at the log's ground truth."""
    force: bool = False
    """Replace existing files in :attr:`outdir`."""
    threads: int | None = 1
    """Threads the estimators run on at once (None: one per estimator, at most one per CPU;
    the same files for any count)."""


def export_trajectories(options: ExportOptions) -> ExportSummary:
    """Write every trajectory of the ``options``' log into its folder as its format's files
    (see :class:`ExportOptions`): each estimator's pose of O, the NAV pose converted to O, the
    ground truth and the truth at each trajectory's stamps. Times in s since the Unix epoch,
    positions in m, headings in rad, in the map frame. The log's estimates are exported if it
    has any, else the estimators are run. The summary names every file written and holds the
    warnings.

    :raises InputError: (exit 2) unknown format, pyarrow missing for Parquet, an output that
        exists (without ``force``) or is the log, a log without the estimates asked for.
    """
    from lgvtool.config import load_config
    from lgvtool.interop.trajectory_export import export_log

    o = options
    return export_log(o.log, o.outdir, o.fmt,
                      estimators=None if o.estimators is None else list(o.estimators),
                      config=load_config(o.config_path) if o.config_path else None,
                      seed=o.seed, settings=dict(o.settings), start_at_truth=o.start_at_truth,
                      force=o.force, threads=o.threads)
