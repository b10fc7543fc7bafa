"""``lgvtool evaluate``: Table 1, error metrics, plots and the report for one or more logs
(:func:`lgvtool.app.evaluate_job.evaluate_logs`)."""

from __future__ import annotations

import inspect

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


def _columns_help() -> str:
    """The help's list of the table columns (:data:`lgvtool.evaluate.verdict.COLUMN_HELP`),
    wrapped to 78 columns with a hanging indent."""
    import textwrap

    from lgvtool.app.evaluate_job import column_help

    return "\n".join(textwrap.fill(f"{name}: {text}.", width=78, initial_indent="  ",
                                    subsequent_indent="      ", break_on_hyphens=False)
                      for name, text in column_help())


_HELP = """Evaluate the localisation in LOG... against the kinematic reference circle (R = h /
    tan(delta), centre fitted by least squares) and, where the log has it, ground truth.

    Prints Table 1 (per complete rotation and per estimator, the RMSE in mm and variance in
    mm^2 of the signed radial error: the paper's Table 1, one column pair per estimator), a
    summary per estimator (circle and ground-truth figures), then the verdict: each
    estimator's error on the best reference the log has (the truth, else the circle), as a
    multiple of the laser's (0.19 x the laser; lower is better), what it observed, the
    paper's own figures on the paper's experiment, warnings, and the files written. Estimates
    come from the log's /estimate/<name>/pose channels, else evaluate runs the estimators.
    Tables fit 120 columns (--wide: every header spelled out).

    \b
    Columns (lower is better for every error):
    {columns}

    Exit 0 success, 1 a --max/--min/--baseline check failed (every check is listed, pass or
    FAIL, on stderr), 2 bad input.
    """


@click.command(help=inspect.cleandoc(_HELP).replace("{columns}", _columns_help()))
@click.argument("logs", nargs=-1, required=True, metavar="LOG...",
                type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", "outdir", type=click.Path(path_type=str),
              metavar="DIR",
              help="Write report.html and table1.{md,csv,tex,json} (and PNGs) into the folder "
                   "DIR.")
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
@click.option("--tolerance", default=None, metavar="P",
              help="Allowed worsening against --baseline, percent (e.g. 10%; default 0%); "
                   "only with --baseline.")
@click.option("--wide", is_flag=True,
              help="Terminal tables with every header spelled out, one line per row, however "
                   "wide (default: at most 120 columns).")
@seed_option("Seed of the estimators when evaluate runs them.")
@set_option("Estimator parameter when evaluate runs the estimators, e.g. pf.particles=500 "
            "(repeatable; docs/filter.md).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              help="Configuration TOML instead of the one stored in the log.")
@click.option("--shared-centre", is_flag=True,
              help="Fit one circle centre to all estimators instead of one each.")
@click.option("--free-radius", is_flag=True,
              help="Fit the radius too (geometric fit) instead of R = h / tan(delta).")
@click.option("--png", is_flag=True, help="Also write every figure as PNG into DIR "
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
    tolerance: str | None, wide: bool, seed: int, sets: tuple[str, ...], config_path: str | None,
    shared_centre: bool, free_radius: bool, png: bool, workers: int | None,
    threads: int | None, scheduler: str | None, tls_ca_file: str | None,
    tls_cert: str | None, tls_key: str | None,
    force: bool, start_at_truth: bool, foreign: tuple[str, ...] = (),
    show_progress: bool = True,
) -> None:
    import sys

    from lgvtool.app.evaluate_job import EvaluateOptions, evaluate_logs
    from lgvtool.app.option_values import (
        parse_bounds,
        parse_settings,
        parse_tolerance,
        parse_trajectories,
    )
    from lgvtool.errors import InputError
    from lgvtool.outputs import printable

    if as_json and fmt not in ("text", "json"):
        raise InputError(f"--json prints JSON; it cannot be combined with --format {fmt}")
    fmt = "json" if as_json else fmt
    run = evaluate_logs(EvaluateOptions(
        tuple(logs), outdir=outdir, fmt=fmt, estimators=tuple(split_names(estimators)) or None,
        maxima=parse_bounds(maxima, "--max"), minima=parse_bounds(minima, "--min"),
        baseline=baseline, tolerance=parse_tolerance(tolerance), seed=seed,
        settings=parse_settings(sets), config_path=config_path, shared_centre=shared_centre,
        free_radius=free_radius, png=png, workers=workers, threads=threads, scheduler=scheduler,
        tls_ca_file=tls_ca_file, tls_cert=tls_cert, tls_key=tls_key, force=force,
        start_at_truth=start_at_truth, trajectories=parse_trajectories(foreign),
        show_progress=show_progress, wide=wide))
    for w in run.warnings:
        warn(w)
    click.echo(run.text if fmt == "json" else printable(run.text), nl=False)
    for note in run.notes:
        warn(note)
    if fmt != "json":
        # the verdict ends the text output; beside md/csv/tex on stdout it goes to stderr
        lines = [printable(line) for line in run.verdict_lines()]
        if fmt == "text":
            click.echo("")
        click.echo("\n".join(lines), err=fmt != "text")
    for line in run.check_lines():
        click.echo(line, err=True)
    if run.failures:
        sys.exit(1)  # every check listed above; not an error (exit 2) but a failed check
