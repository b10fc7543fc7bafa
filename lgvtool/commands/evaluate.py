"""``lgvtool evaluate``: Table 1, error metrics, plots and the report for one or more logs
(:func:`lgvtool.app.evaluate_job.evaluate_logs`)."""

from __future__ import annotations

import click

from lgvtool.options import (
    estimator_option,
    force_option,
    progress_option,
    scheduler_options,
    seed_option,
    set_option,
    split_names,
    threads_option,
    warn,
    workers_type,
)


@click.command()
@click.argument("logs", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", "outdir", type=click.Path(file_okay=False, path_type=str),
              metavar="OUTDIR",
              help="Write table1.{md,csv,tex,json} and report.html (and PNGs) into OUTDIR.")
@estimator_option("Estimator to score or run; default: the log's estimates, else laser, "
                  "deadreckoning, ekf, pf-paper, pf")
@click.option("--json", "as_json", is_flag=True, help="Print the JSON document (same as "
              "--format json).")
@click.option("--format", "fmt", type=click.Choice(["text", "md", "csv", "tex", "json"]),
              default="text", show_default=True, help="Format of the terminal output.")
@click.option("--max", "maxima", multiple=True, metavar="KEY=VALUE",
              help="Fail (exit 1) if a figure exceeds VALUE, e.g. pf.circle.rmse_mm=25.")
@click.option("--min", "minima", multiple=True, metavar="KEY=VALUE",
              help="Fail (exit 1) if a figure is below VALUE, e.g. rotations.complete=8.")
@click.option("--baseline", type=click.Path(dir_okay=False, path_type=str),
              help="A previous table1.json: fail (exit 1) if an error figure got worse.")
@click.option("--tolerance", default="0%", show_default=True, metavar="P",
              help="Allowed worsening against --baseline, percent (e.g. 10%).")
@seed_option("Seed of the estimators when evaluate runs them.")
@set_option("Estimator parameter when evaluate runs the estimators, e.g. pf.particles=500 "
            "(repeatable; docs/filter.md).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              help="Configuration TOML instead of the one stored in the log.")
@click.option("--shared-centre", is_flag=True,
              help="Fit one circle centre to all estimators instead of one each.")
@click.option("--free-radius", is_flag=True,
              help="Fit the radius too (geometric fit) instead of R = h / tan(delta).")
@click.option("--png", is_flag=True, help="Also write every figure as PNG into OUTDIR "
              "(needs the optional kaleido package).")
@click.option("--workers", type=workers_type(), default=None,
              help="Evaluate several logs on a local Dask cluster of this many processes "
                   "(default with several logs: one per CPU).")
@threads_option("1, which keeps a long log within its memory; more are faster")
@scheduler_options
@force_option
@click.option("--start-at-truth", is_flag=True,
              help="When evaluate runs the estimators: start every one at the log's ground "
                   "truth (/truth/pose) instead of letting it initialise itself.")
@click.option("--trajectory", "foreign", multiple=True, metavar="NAME=FILE",
              help="Also score a trajectory of O made by another tool: a TUM (.tum, .txt) or "
                   "CSV (.csv) file stamped in the log's time (repeatable; one LOG only).")
@progress_option()
def evaluate(
    logs: tuple[str, ...], outdir: str | None, estimators: tuple[str, ...], as_json: bool,
    fmt: str, maxima: tuple[str, ...], minima: tuple[str, ...], baseline: str | None,
    tolerance: str, seed: int, sets: tuple[str, ...], config_path: str | None,
    shared_centre: bool, free_radius: bool, png: bool, workers: int | None,
    threads: int | None, scheduler: str | None, tls_ca_file: str | None,
    tls_cert: str | None, tls_key: str | None,
    force: bool, start_at_truth: bool, foreign: tuple[str, ...] = (),
    show_progress: bool = True,
) -> None:
    """Evaluate the localization in LOG... against the kinematic reference circle (R = h /
    tan(delta), centre fitted by least squares) and, where the log has it, ground truth.

    Prints Table 1 (RMSE in mm and variance in mm^2 of the signed radial error per complete
    rotation, one column pair per estimator) and a summary (bias, max |error|, improvement over
    laser in %, true position error in mm and heading RMSE in degrees). Estimates come from the
    log's /estimate/<name>/pose channels, else evaluate runs the estimators itself.

    Exit 0 success, 1 a --max/--min/--baseline check failed, 2 bad input.
    """
    from lgvtool.app.evaluate_job import evaluate_logs
    from lgvtool.errors import InputError
    from lgvtool.outputs import printable

    if as_json and fmt not in ("text", "json"):
        raise InputError(f"--json prints JSON; it cannot be combined with --format {fmt}")
    fmt = "json" if as_json else fmt
    run = evaluate_logs(
        logs, outdir=outdir, fmt=fmt, estimators=split_names(estimators) or None,
        maxima=maxima, minima=minima, baseline=baseline, tolerance=tolerance, seed=seed,
        sets=sets, config_path=config_path, shared_centre=shared_centre,
        free_radius=free_radius, png=png, workers=workers, threads=threads, scheduler=scheduler,
        tls=(tls_ca_file, tls_cert, tls_key), force=force, start_at_truth=start_at_truth,
        foreign=foreign, show_progress=show_progress)
    for w in run.warnings:
        warn(w)
    click.echo(run.text if fmt == "json" else printable(run.text), nl=False)
    for note in run.notes:
        warn(note)
    run.check()
