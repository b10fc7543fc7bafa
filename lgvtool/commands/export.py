"""``lgvtool export``: a log's trajectories as TUM, KITTI, CSV or Parquet files."""

from __future__ import annotations

import click

from lgvtool.options import (
    estimator_option,
    force_option,
    seed_option,
    set_option,
    split_names,
    threads_option,
    warn,
)


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", "outdir", required=True, metavar="DIR",
              type=click.Path(file_okay=False, path_type=str),
              help="Folder that receives one file (set) per trajectory (created).")
@click.option("--format", "fmt", type=click.Choice(["tum", "kitti", "csv", "parquet"]),
              default="tum", show_default=True, help="File format (docs/interop.md).")
@estimator_option("Estimator to export; default: the log's estimates, else laser, "
                  "deadreckoning, ekf, pf-paper, pf run over the log")
@seed_option("Seed of the estimators when export runs them.")
@set_option("Estimator parameter when export runs them, e.g. pf.particles=500 (repeatable).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              help="Configuration TOML instead of the one stored in the log.")
@click.option("--start-at-truth", is_flag=True,
              help="When export runs the estimators: start them at the log's ground truth.")
@threads_option("1, which keeps a long log within its memory; more are faster")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def export(log: str, outdir: str, fmt: str, estimators: tuple[str, ...], seed: int,
           sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
           threads: int | None, force: bool, as_json: bool) -> None:
    """Write every trajectory of LOG into DIR: each estimator's pose of the target rotation
    centre O (NAME.EXT), the NAV pose converted to O (nav.EXT), the ground truth (truth.EXT)
    and the truth interpolated at each trajectory's stamps as lgvtool scores it
    (truth-at-NAME.EXT). Times are the log's (s since the Unix epoch), positions m, headings
    rad, in the map frame.

    TUM: `t x y z qx qy qz qw`; KITTI: 3x4 pose rows (NAME.kitti.txt) and stamps
    (NAME.times.txt); CSV: t_s,x_m,y_m,heading_rad; Parquet: the same columns with units in
    the metadata (needs pyarrow).
    """
    import json

    from lgvtool.app.export_job import ExportOptions, export_trajectories
    from lgvtool.app.option_values import parse_settings

    summary = export_trajectories(ExportOptions(
        log, outdir, fmt, estimators=tuple(split_names(estimators)) or None, seed=seed,
        settings=parse_settings(sets), config_path=config_path, start_at_truth=start_at_truth,
        force=force, threads=threads if threads is not None else 1))
    for w in summary.warnings:
        warn(w)
    click.echo(json.dumps(summary.to_dict(), indent=2) if as_json else summary.format_text())
