"""``lgvtool sweep``: parameter sweeps over many logs and seeds on a Dask cluster
(:func:`lgvtool.app.sweep_job.sweep_logs`)."""

from __future__ import annotations

import click

from lgvtool.options import (
    Number,
    estimator_option,
    force_option,
    progress_option,
    scheduler_options,
    set_option,
    split_names,
    warn,
    workers_type,
)
from lgvtool.values import MAX_SEEDS

MAX_LISTED = 10
"""Failed tasks (and logs read with warnings) named one by one on stderr before the rest are
only counted."""


@click.command()
@click.argument("logs", nargs=-1, required=True, metavar="LOG_OR_DIR...",
                type=click.Path(exists=True, path_type=str))
@click.option("-o", "--output", "outdir", required=True, metavar="DIR",
              type=click.Path(file_okay=False, path_type=str),
              help="Directory of the results (created; re-using it resumes the sweep).")
@estimator_option("Estimator to run; default: laser, deadreckoning, ekf, pf-paper, pf")
@click.option("--grid", "grid_items", multiple=True, metavar="KEY=V1,V2,...",
              help="Values of an estimator setting to sweep, as in replay --set "
                   "(e.g. pf.particles=100,300,1000); several --grid give their product.")
@set_option("An estimator setting fixed for every task (e.g. pf.init=laser).")
@click.option("--seeds", type=Number(int, 1, MAX_SEEDS), default=1, show_default=True,
              help="Seeds per log and setting: 0 .. N-1.")
@scheduler_options
@force_option
@click.option("--workers", type=workers_type(), default=None,
              help="Worker processes of the local cluster  [default: one per CPU]")
@click.option("--config", "config_path", type=click.Path(exists=True, dir_okay=False, path_type=str),
              help="Configuration TOML used instead of the one stored in each log.")
@click.option("--retry-failed", is_flag=True,
              help="Run again the tasks whose log failed before (corrupt, missing channels).")
@progress_option("Progress bar on stderr.")
@click.option("--json", "as_json", is_flag=True, help="Print the outcome as JSON.")
def sweep(logs: tuple[str, ...], outdir: str, estimators: tuple[str, ...],
          grid_items: tuple[str, ...], sets: tuple[str, ...], seeds: int,
          scheduler: str | None, tls_ca_file: str | None, tls_cert: str | None,
          tls_key: str | None, force: bool, workers: int | None, config_path: str | None,
          retry_failed: bool, show_progress: bool, as_json: bool) -> None:
    """Run the estimators over every log in LOG_OR_DIR... (files, or directories searched for
    *.mcap) for every setting of the grid and every seed, and evaluate each run as
    lgvtool evaluate does: one task per (log, setting, seed).

    Tasks run on a local Dask cluster (one process per CPU), or with --scheduler on an
    existing one. Every finished task is stored in DIR/tasks/ under a key made of the
    log's content hash, the settings, the seed and the lgvtool version, so running the same
    sweep again skips what is done and an interrupted sweep resumes. A log that fails
    (corrupt, missing channels) is reported and does not stop the others; a log read with
    warnings (a cut-off file's salvage, say) is named on stderr with them.

    Writes into DIR (-o): results.parquet/.csv (one row per log x setting x seed x estimator,
    every figure of evaluate's JSON under a dotted name such as circle.rmse_mm or
    truth.position_rmse_m), summary.parquet/.csv (per log x setting x estimator over the
    seeds: mean, std, Student-t 95 % interval), report.html and sweep.json.

    Exit 0 when the sweep ran (failed logs are reported, not fatal), 2 bad input.
    """
    import json

    from lgvtool.app.option_values import parse_grid, parse_settings
    from lgvtool.app.sweep_job import SweepOptions, sweep_logs

    result = sweep_logs(SweepOptions(
        tuple(logs), outdir, estimators=tuple(split_names(estimators)),
        grid=parse_grid(grid_items), settings=parse_settings(sets), seeds=seeds,
        scheduler=scheduler, tls_ca_file=tls_ca_file, tls_cert=tls_cert, tls_key=tls_key,
        force=force, workers=workers, config_path=config_path, retry_failed=retry_failed,
        show_progress=show_progress))
    for i, f in enumerate(result.failures):
        if i == MAX_LISTED:
            warn(f"sweep: {len(result.failures) - MAX_LISTED} more failed task(s), see summary.csv")
            break
        setting = ",".join(f"{k}={v}" for k, v in f["setting"].items()) or "default"
        warn(f"sweep: {f['log']} ({setting}, seed {f['seed']}): {f['error']}")
    for i, (log, said) in enumerate(result.warnings.items()):
        if i == MAX_LISTED:
            warn(f"sweep: {len(result.warnings) - MAX_LISTED} more log(s) read with warnings, "
                 "see results.csv")
            break
        warn(f"sweep: {log}: {said}")
    if as_json:
        click.echo(json.dumps(result.as_dict(), indent=2))
        return
    click.echo(f"{result.tasks} task(s): {result.ran} run now, {result.reused} already done, "
               f"{result.failed} failed; {result.elapsed_s:.1f} s")
    for p in result.files:
        click.echo(f"  {p}")
