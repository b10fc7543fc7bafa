"""``lgvtool evaluate``: Table 1, error metrics, plots and the report for one or more logs.

Also the Python entry point :func:`evaluate_log` (notebooks, the fleet engine): read a log,
take its estimates or run the estimators, and evaluate them with :mod:`lgvtool.evaluate`.
Heavy imports stay inside the functions so that ``lgvtool --help`` stays instant.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from lgvtool.options import (
    estimator_option,
    force_option,
    progress_option,
    scheduler_options,
    seed_option,
    set_option,
    split_names,
    warn,
    workers_type,
)

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.config import Config
    from lgvtool.evaluate.evaluation import EvaluationResult
    from lgvtool.log import LogReader
    from lgvtool.progress import Progress


def _pose_frame(reader: LogReader, topic: str) -> pd.DataFrame:
    df = reader.dataframe(topic)
    if df.empty:
        return df
    return df[["t", "x", "y", "heading"]]


def _estimates_from_log(
    reader: LogReader, names: Sequence[str] | None
) -> dict[str, pd.DataFrame] | None:
    from lgvtool.errors import InputError
    from lgvtool.log import topics

    present = topics.estimator_names(reader.topic_names())
    if not present:
        return None
    if names:
        missing = [n for n in names if n not in present]
        if missing:
            raise InputError(f"{reader.path}: no estimates of {', '.join(missing)} in the log "
                             f"(it holds {', '.join(present)}); run lgvtool replay first")
        present = list(names)
    return {n: _pose_frame(reader, topics.estimate_pose(n)) for n in present}


def _run_estimators(
    reader: LogReader, names: Sequence[str] | None, cfg: Config, seed: int,
    settings: Mapping[str, Any] | None, warnings: list[str], start_at_truth: bool = False,
    progress: Progress | None = None,
) -> tuple[dict[str, pd.DataFrame], dict[str, Any]]:
    from lgvtool.localize import DEFAULT_ESTIMATORS, run_replay
    from lgvtool.log import topics

    chosen = list(names) if names else list(DEFAULT_ESTIMATORS)
    start: dict[str, Any] = {"initial_pose": "truth"} if start_at_truth else {}
    if progress is not None and progress.enabled:
        # at most every scan and every NAV pose, per estimator
        infos = reader.topics()
        per = sum(infos[t].count for t in (topics.NAV_REFLECTORS, topics.NAV_POSE) if t in infos)
        progress.stage(f"{Path(str(reader.path)).name}: estimators", len(chosen) * per)
        start["progress"] = progress.advance
    out = run_replay(reader, chosen, config=cfg, seed=seed, settings=dict(settings or {}),
                     **start)
    for name, reason in (getattr(out, "skipped", None) or {}).items():
        warnings.append(f"estimator '{name}' left out: {reason}")
    return dict(out.trajectories), dict(out.settings)


def evaluate_log(
    path_or_reader: str | Path | LogReader,
    *,
    estimators: Sequence[str] | None = None,
    config: Config | None = None,
    seed: int = 0,
    settings: Mapping[str, Any] | None = None,
    shared_centre: bool = False,
    free_radius: bool = False,
    lap_source: str | None = None,
    start_at_truth: bool = False,
    replay: bool = False,
    trajectories: Mapping[str, pd.DataFrame] | None = None,
    progress: Progress | None = None,
) -> EvaluationResult:
    """Evaluate one log.

    The log's ``/estimate/<name>/pose`` channels are scored if it has any (``estimators``
    picks among them); otherwise the estimators (default: ``DEFAULT_ESTIMATORS`` of
    :mod:`lgvtool.localize`) are run with ``run_replay`` using ``seed`` and ``settings``, and
    with ``start_at_truth`` every estimator starts at the log's ground truth (``/truth/pose``)
    at its first observation instead of initialising itself (a warning when the log's own
    estimates are scored, since nothing is run then).
    ``config`` overrides the configuration stored in the log. The steering angle of the
    reference circle is the median logged steering angle (MCU frames), else
    ``config.reference.steering_angle_deg``. Raises :class:`~lgvtool.errors.InputError` (or a
    subclass) for a log that cannot be evaluated. ``replay=True`` runs the estimators even when
    the log holds estimates of its own (parameter sweeps over logs written by ``replay``).
    ``trajectories`` (name -> DataFrame t, x, y, heading of O) are scored beside them
    (``--trajectory``, :mod:`lgvtool.interop.foreign_trajectories`).
    ``progress`` (a :class:`lgvtool.progress.Progress`) shows the estimators' progress.
    """
    from lgvtool.evaluate.evaluation import evaluate_trajectories
    from lgvtool.evaluate.reference import steering_from_frames
    from lgvtool.log import LogReader, topics

    reader = (path_or_reader if isinstance(path_or_reader, LogReader)
              else LogReader(path_or_reader))
    cfg = config if config is not None else reader.config()
    warnings: list[str] = list(reader.warnings)
    trajs = None if replay else _estimates_from_log(reader, estimators)
    source = "log"
    used: dict[str, Any] = {}
    if trajs is None:
        trajs, used = _run_estimators(reader, estimators, cfg, seed, settings, warnings,
                                      start_at_truth, progress)
        source = "replay"
    else:
        if start_at_truth:
            warnings.append("--start-at-truth has no effect: the log's own estimates are scored "
                            "(evaluate a log without /estimate/* channels to run the estimators)")
        if settings:
            warnings.append("--set has no effect: the log's own estimates are scored (evaluate a "
                            "log without /estimate/* channels to run the estimators)")
    truth = _pose_frame(reader, topics.TRUTH) if reader.has_topic(topics.TRUTH) else None
    if truth is not None and truth.empty:
        truth = None
    if trajectories:
        from lgvtool.interop.foreign_trajectories import add_foreign

        trajs = add_foreign(trajs, trajectories, truth, log=str(reader.path))
    steering = None
    steering_source = "none"
    if reader.has_topic(topics.MCU_FRAME):
        steering = steering_from_frames(reader.dataframe(topics.MCU_FRAME))
        steering_source = "log" if steering is not None else "none"
    if steering is None and cfg.reference.steering_angle_deg is not None:
        steering = math.radians(cfg.reference.steering_angle_deg)
        steering_source = "config"
    result = evaluate_trajectories(
        trajs, truth=truth, steering_angle=steering, steering_source=steering_source,
        h=cfg.vehicle.h, shared_centre=shared_centre, free_radius=free_radius,
        name=Path(str(reader.path)).stem, reflectors=reader.reflector_map() or cfg.reflectors,
        lap_source=lap_source,
    )
    result.path = str(reader.path)
    result.source = source
    result.settings = used
    late = [w for w in reader.warnings if w not in warnings]  # corrupt chunks met in reading
    result.warnings[:0] = warnings + late
    return result


@dataclass(frozen=True)
class _LogTask:
    """What one worker needs to evaluate one log: its path and the options (small, picklable)."""

    path: str
    options: dict[str, Any]


def _evaluate_task(task: _LogTask) -> EvaluationResult:
    """Evaluate one log on a worker of the fleet engine (warnings travel in the result)."""
    import warnings as pywarnings

    with pywarnings.catch_warnings():
        pywarnings.simplefilter("ignore")
        return evaluate_log(task.path, **task.options)


def _evaluate_all(logs: Sequence[str], options: dict[str, Any], *, scheduler: Any,
                  workers: int | None, bar: Progress | None = None) -> list[EvaluationResult]:
    """Evaluate every log: in this process for one log, else on the fleet engine (a local Dask
    cluster, or ``scheduler``); the first log that fails stops the command with its error.
    ``bar``: progress on stderr (the estimators of one log, or the logs done)."""
    from lgvtool.errors import InputError
    from lgvtool.fleet.connect import fleet_available

    tasks = [_LogTask(log, options) for log in logs]
    if scheduler is None and workers is None and (len(tasks) == 1 or not fleet_available()):
        import warnings as pywarnings

        with pywarnings.catch_warnings():
            pywarnings.simplefilter("ignore")
            return [evaluate_log(t.path, **t.options, progress=bar) for t in tasks]
    from lgvtool.fleet.engine import run_tasks

    results: list[EvaluationResult | None] = [None] * len(tasks)
    for out in run_tasks(_evaluate_task, tasks, scheduler=scheduler, workers=workers,
                         progress=bar is not None and bar.enabled, label="logs"):
        if not out.ok:
            error = out.error or "failed"
            if out.input_error:  # "LogFormatError: <path>: ..." already names the log
                raise InputError(error.split(": ", 1)[-1])
            raise InputError(f"{out.task.path}: {error}")
        results[out.index] = out.value
    return [r for r in results if r is not None]


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
    scheduler: str | None, tls_ca_file: str | None, tls_cert: str | None, tls_key: str | None,
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
    import json

    from lgvtool.config import load_config, parse_set_options
    from lgvtool.errors import InputError
    from lgvtool.evaluate import regress
    from lgvtool.evaluate.document import build_document, to_json
    from lgvtool.evaluate.table import render_tables

    if as_json and fmt not in ("text", "json"):
        raise InputError(f"--json prints JSON; it cannot be combined with --format {fmt}")
    if png and not outdir:
        raise InputError("--png needs -o OUTDIR to write the images into")
    if png:
        from lgvtool.evaluate.plots import require_kaleido

        require_kaleido()
    if outdir:
        from lgvtool.outdir import guard_directory

        trajectory_files = [spec.partition("=")[2] for spec in foreign]
        guard_directory(outdir, OUTPUT_FILES, [*logs, config_path, baseline, *trajectory_files],
                        force=force)
    upper = [regress.parse_bound(b, "--max") for b in maxima]
    lower = [regress.parse_bound(b, "--min") for b in minima]
    tol = regress.parse_tolerance(tolerance)
    base_doc = None
    if baseline is not None:
        try:
            base_doc = json.loads(Path(baseline).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"baseline not found: {baseline}") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"{baseline}: not JSON ({exc})") from None
        regress.validate_baseline(base_doc, baseline)
    cfg = load_config(config_path) if config_path else None
    names = split_names(estimators) or None
    settings = parse_set_options(sets)

    if workers is not None and scheduler is not None:
        raise InputError("give --workers or --scheduler, not both")
    from lgvtool.fleet.connect import require_fleet, scheduler_spec

    if workers is not None:
        require_fleet("--workers")
    cluster = scheduler_spec(scheduler, tls_ca_file, tls_cert, tls_key)
    options = {"estimators": names, "config": cfg, "seed": seed, "shared_centre": shared_centre,
               "free_radius": free_radius, "start_at_truth": start_at_truth,
               "settings": settings or None}
    if foreign:
        from lgvtool.interop.foreign_trajectories import load_trajectories

        if len(logs) > 1:
            raise InputError("--trajectory scores a file against one log; give one LOG")
        trajectories: Any = load_trajectories(foreign)
        options["trajectories"] = trajectories
    from lgvtool.progress import Progress

    bar = Progress(0, "evaluate", enabled=show_progress, delay_s=1.0)
    try:
        results = _evaluate_all(logs, options, scheduler=cluster, workers=workers, bar=bar)
        if outdir:
            bar.stage("report", len(results))
    finally:
        if not outdir:
            bar.close()
    for res in results:
        for w in res.warnings:
            warn(f"{res.name}: {w}")
    _unique_names(results)
    doc = build_document(results)

    if as_json or fmt == "json":
        click.echo(to_json(doc), nl=False)
    else:
        from lgvtool.outputs import printable

        click.echo(printable(render_tables(results, fmt)), nl=False)
    if outdir:
        try:
            _write_outputs(Path(outdir), results, doc, png, force, bar)
        finally:
            bar.close()

    failures = regress.check_bounds(doc, upper, lower)
    if base_doc is not None:
        more, notes = regress.check_baseline(doc, base_doc, tol, source=baseline or "baseline")
        for note in notes:
            warn(note)
        failures += more
    regress.raise_failures(failures)


def _unique_names(results: list[EvaluationResult]) -> None:
    """Logs with the same file name (in different folders) get -2, -3, ... appended."""
    seen: dict[str, int] = {}
    for res in results:
        count = seen.get(res.name, 0) + 1
        seen[res.name] = count
        if count > 1:
            res.name = f"{res.name}-{count}"


OUTPUT_FILES = ("table1.md", "table1.csv", "table1.tex", "table1.json", "report.html")
"""Files that ``evaluate -o OUTDIR`` writes (and PNGs with --png)."""


def _write_outputs(out: Path, results: list[EvaluationResult], doc: dict[str, Any],
                   png: bool, force: bool = False, bar: Progress | None = None) -> None:
    from lgvtool.evaluate.document import to_json
    from lgvtool.evaluate.html_report import render_report
    from lgvtool.evaluate.plots import write_png
    from lgvtool.evaluate.table import render_tables
    from lgvtool.outdir import write_text
    from lgvtool.outputs import atomic_output, guard_output

    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "table1.md", render_tables(results, "md"))
    write_text(out / "table1.csv", render_tables(results, "csv"))
    write_text(out / "table1.tex", render_tables(results, "tex"))
    write_text(out / "table1.json", to_json(doc))
    figures: list[Any] = []
    write_text(out / "report.html", render_report(
        results, figures=figures, progress=None if bar is None else bar.advance))
    if png:
        for slug, fig in figures:
            target = guard_output(out / f"{slug}.png", [r.path for r in results], force=force)
            with atomic_output(target) as tmp:
                write_png(fig, tmp)
