"""Evaluating logs: :func:`evaluate_log` (one log, from Python, with other tools'
trajectories; its core, :func:`lgvtool.evaluate.log_evaluation.evaluate_log`, is what the fleet
engine and calibration call) and :func:`evaluate_logs` (what ``lgvtool
evaluate`` runs: several logs, their document, tables, files and threshold checks).

A log's ``/estimate/<name>/pose`` channels are scored if it has any, else the estimators are
run over it (:mod:`lgvtool.localize`); the figures come from :mod:`lgvtool.evaluate`.
Positions in m, headings in rad, times in s; the tables print mm and mm^2 (docs/evaluation.md).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.app.option_values import Bound, SettingValue
    from lgvtool.config import Config
    from lgvtool.evaluate.evaluation import EvaluationResult
    from lgvtool.evaluate.regress import Check
    from lgvtool.evaluate.verdict import Verdict
    from lgvtool.fleet.connect import SchedulerSpec
    from lgvtool.json_types import JSONRecord
    from lgvtool.log import LogReader
    from lgvtool.progress import Progress


def evaluate_log(
    path_or_reader: str | Path | LogReader,
    *,
    estimators: Sequence[str] | None = None,
    config: Config | None = None,
    seed: int = 0,
    settings: Mapping[str, SettingValue] | None = None,
    shared_centre: bool = False,
    free_radius: bool = False,
    lap_source: str | None = None,
    start_at_truth: bool = False,
    replay: bool = False,
    trajectories: Mapping[str, pd.DataFrame] | None = None,
    progress: Progress | None = None,
    threads: int | None = 1,
) -> EvaluationResult:
    """Evaluate one log: :func:`lgvtool.evaluate.log_evaluation.evaluate_log` (see there), with
    other tools' ``trajectories`` (name -> DataFrame t, x, y, heading of O; ``--trajectory``)
    added by :func:`lgvtool.interop.foreign_trajectories.add_foreign`."""
    from lgvtool.evaluate import log_evaluation

    add_trajectories = None
    if trajectories:
        from lgvtool.interop.foreign_trajectories import add_foreign

        add_trajectories = add_foreign
    return log_evaluation.evaluate_log(
        path_or_reader, estimators=estimators, config=config, seed=seed, settings=settings,
        shared_centre=shared_centre, free_radius=free_radius, lap_source=lap_source,
        start_at_truth=start_at_truth, replay=replay, trajectories=trajectories,
        add_trajectories=add_trajectories, progress=progress, threads=threads)


@dataclass(frozen=True, slots=True)
class LogEvaluationOptions:
    """How each log of :func:`evaluate_logs` is evaluated (:func:`evaluate_log`'s options):
    small and picklable, they travel with every log to a worker of the fleet engine."""

    estimators: tuple[str, ...] | None = None
    """Estimators to score or run; None: the log's estimates, else the default set."""
    config: Config | None = None
    """Configuration used instead of the log's own; None: the log's."""
    seed: int = 0
    """Seed of the estimators when they are run."""
    settings: Mapping[str, SettingValue] | None = None
    """Estimator settings (``pf.particles`` -> 500) when they are run; None: none."""
    shared_centre: bool = False
    """Fit one circle centre to all estimators instead of one each."""
    free_radius: bool = False
    """Fit the radius too (geometric fit) instead of R = h / tan(delta)."""
    start_at_truth: bool = False
    """Start the estimators run at the log's ground truth."""
    trajectories: Mapping[str, pd.DataFrame] | None = None
    """Other tools' trajectories of O (name -> DataFrame t s, x m, y m, heading rad)."""
    threads: int | None = 1
    """Threads a log's estimators run on at once (None: one per estimator, at most one per
    CPU)."""


def _evaluate_one(path: str, options: LogEvaluationOptions,
                  progress: Progress | None = None) -> EvaluationResult:
    """:func:`evaluate_log` of the log at ``path`` with ``options``."""
    o = options
    return evaluate_log(path, estimators=None if o.estimators is None else list(o.estimators),
                        config=o.config, seed=o.seed, settings=o.settings,
                        shared_centre=o.shared_centre, free_radius=o.free_radius,
                        start_at_truth=o.start_at_truth, trajectories=o.trajectories,
                        progress=progress, threads=o.threads)


@dataclass(frozen=True)
class _LogTask:
    """What one worker needs to evaluate one log: its path and the options (small, picklable)."""

    path: str
    options: LogEvaluationOptions


def _evaluate_task(task: _LogTask) -> EvaluationResult:
    """Evaluate one log on a worker of the fleet engine (warnings travel in the result)."""
    import warnings as pywarnings

    with pywarnings.catch_warnings():
        pywarnings.simplefilter("ignore")
        return _evaluate_one(task.path, task.options)


def _evaluate_all(logs: Sequence[str], options: LogEvaluationOptions, *,
                  scheduler: SchedulerSpec | None, workers: int | None,
                  bar: Progress | None = None) -> list[EvaluationResult]:
    """Evaluate every log: in this process for one log, else on the fleet engine (a local Dask
    cluster, or ``scheduler``); the first log that fails stops the command with its error.
    ``bar``: progress on stderr (the estimators of one log, or the logs done)."""
    from lgvtool.fleet.engine import run_in_order

    def here(task: _LogTask) -> EvaluationResult:
        import warnings as pywarnings

        with pywarnings.catch_warnings():
            pywarnings.simplefilter("ignore")
            return _evaluate_one(task.path, task.options, progress=bar)

    return run_in_order(_evaluate_task, [_LogTask(log, options) for log in logs],
                        scheduler=scheduler, workers=workers, in_process=here,
                        progress=bar is not None and bar.enabled,
                        path_of=lambda task: task.path)


@dataclass
class EvaluationRun:
    """What :func:`evaluate_logs` returns: the results, their document and what to print."""

    results: list[EvaluationResult]
    """One result per log, in the order given (names made unique: ``-2``, ``-3``, ...)."""
    document: dict[str, Any]
    """The evaluation document (``table1.json``, ``lgvtool evaluate --json``)."""
    text: str
    """The tables (or the JSON document) in the format asked for, to print as they are."""
    warnings: list[str] = field(default_factory=list)
    """``<log name>: <warning>`` for each log's warnings."""
    notes: list[str] = field(default_factory=list)
    """What the comparison with the baseline noted (estimators it has that these lack)."""
    failures: list[str] = field(default_factory=list)
    """Every ``--max``/``--min``/``--baseline`` figure that failed (empty: all hold)."""
    verdicts: list[Verdict] = field(default_factory=list)
    """One verdict per log, with the paths written (:mod:`lgvtool.evaluate.verdict`)."""
    checks: list[Check] = field(default_factory=list)
    """Every check asked for, passed or failed (:mod:`lgvtool.evaluate.regress`)."""

    def verdict_lines(self, width: int = 100) -> list[str]:
        """The verdict to print: per log at most ten lines of at most ``width`` columns; over
        several logs each log's without the files and a blank line, then one summary line and
        the files."""
        from lgvtool.evaluate.verdict import format_verdict, paths_line, summary_line

        if len(self.verdicts) == 1:
            return format_verdict(self.verdicts[0], width)
        lines: list[str] = []
        for v in self.verdicts:
            lines += [*format_verdict(v, width, show_paths=False), ""]
        if self.verdicts:
            lines.append(summary_line(self.verdicts, width))
            lines.append(paths_line(self.verdicts[-1].paths, width))
        return lines

    def check_lines(self) -> list[str]:
        """One line per check (``check  pass  ...`` / ``check  FAIL  ...``) and a count; empty
        without checks."""
        from lgvtool.evaluate.regress import check_lines

        return check_lines(self.checks)

    def check(self) -> None:
        """Raise :class:`~lgvtool.errors.ThresholdError` (exit 1) if a check failed."""
        from lgvtool.evaluate import regress

        regress.raise_failures(self.failures)


@dataclass(frozen=True, slots=True)
class EvaluateOptions:
    """What :func:`evaluate_logs` evaluates and checks, and what it writes (``lgvtool
    evaluate``)."""

    logs: tuple[str, ...]
    """The logs (MCAP) to evaluate, in order."""
    outdir: str | None = None
    """Folder that receives :data:`OUTPUT_FILES` (and PNGs with :attr:`png`); None: nothing
    is written."""
    fmt: str = "text"
    """Format of the text: text, md, csv, tex or json."""
    estimators: tuple[str, ...] | None = None
    """Estimators to score or run; None: the logs' estimates, else the default set."""
    maxima: tuple[Bound, ...] = ()
    """Upper bounds on the document's figures (``pf.circle.rmse_mm`` -> 25, in the unit the
    key's suffix names)."""
    minima: tuple[Bound, ...] = ()
    """Lower bounds on the document's figures (``rotations.complete`` -> 8)."""
    baseline: str | None = None
    """A previous ``table1.json`` whose error figures may not get worse."""
    tolerance: float | None = None
    """Worsening allowed against :attr:`baseline`, a fraction (0.1: 10 %); None: 0, and
    refused without a baseline."""
    seed: int = 0
    """Seed of the estimators when they are run."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Estimator settings (``pf.particles`` -> 500) when they are run."""
    config_path: str | None = None
    """Configuration (TOML) used instead of each log's own; None: the logs' own."""
    shared_centre: bool = False
    """Fit one circle centre to all estimators instead of one each."""
    free_radius: bool = False
    """Fit the radius too (geometric fit) instead of R = h / tan(delta)."""
    png: bool = False
    """Also write every figure of the report as PNG into :attr:`outdir` (needs kaleido)."""
    workers: int | None = None
    """Processes of a local Dask cluster for several logs; None: one per CPU, or (one log, or
    no fleet extra) this process."""
    threads: int | None = None
    """Threads a log's estimators run on at once; None: 1."""
    scheduler: str | None = None
    """Address of a Dask scheduler (``tls://HOST:PORT`` or ``tcp://HOST:PORT``) that runs
    the logs; None: none."""
    tls_ca_file: str | None = None
    """CA file (PEM) of a ``tls://`` :attr:`scheduler`."""
    tls_cert: str | None = None
    """This client's certificate (PEM) for a ``tls://`` :attr:`scheduler`."""
    tls_key: str | None = None
    """Private key of :attr:`tls_cert` (PEM), when not in that file."""
    force: bool = False
    """Replace existing files in :attr:`outdir`."""
    start_at_truth: bool = False
    """Start the estimators run at each log's ground truth."""
    trajectories: Mapping[str, str] = field(default_factory=dict)
    """Other tools' trajectories of O to score too: name -> file (TUM or CSV, stamped in the
    log's time, s); one log only."""
    show_progress: bool = True
    """Progress on stderr once the evaluation takes over a second."""
    wide: bool = False
    """Text tables with every header spelled out (default: at most 120 columns)."""


def evaluate_logs(options: EvaluateOptions) -> EvaluationRun:
    """Evaluate the ``options``' logs as ``lgvtool evaluate`` does and check the figures
    (see :class:`EvaluateOptions`).

    Every log goes through :func:`evaluate_log` (in this process for one log, else on a local
    Dask cluster of ``workers`` processes or on ``scheduler`` with its TLS files); a log's
    estimators run on ``threads`` threads (default one). ``maxima``/``minima`` bound the
    document's figures; ``baseline`` is a previous ``table1.json``, worse by at most
    ``tolerance``. Every check is listed in :attr:`EvaluationRun.checks` and the document's
    ``checks``; each log's verdict (with the files written) in :attr:`EvaluationRun.verdicts`,
    the result's ``verdict`` and the document's ``verdict``. With ``outdir`` the files
    :data:`OUTPUT_FILES` (and PNGs with ``png``) are written there; an existing one is
    replaced only with ``force``.

    :raises InputError: (or a subclass; exit 2) a bad option, file or log; the first log that
        fails stops the evaluation.
    """
    import json

    from lgvtool.config import load_config
    from lgvtool.errors import InputError
    from lgvtool.evaluate import regress
    from lgvtool.evaluate.document import build_document, to_json
    from lgvtool.evaluate.table import render_tables
    from lgvtool.evaluate.verdict import verdict_of
    from lgvtool.fleet.connect import require_fleet, scheduler_spec
    from lgvtool.progress import Progress

    o = options
    logs, outdir, baseline, fmt, png = o.logs, o.outdir, o.baseline, o.fmt, o.png
    if png and outdir is None:
        raise InputError("--png needs -o DIR to write the images into")
    if png:
        from lgvtool.evaluate.plots import require_kaleido

        require_kaleido()
    if o.tolerance is not None and baseline is None:
        raise InputError("--tolerance needs --baseline: it is the worsening allowed against a "
                         "baseline (a previous table1.json)")
    if outdir is not None:
        from lgvtool.outdir import guard_directory

        inputs = [*logs, o.config_path, baseline, *o.trajectories.values()]
        _refuse_input_as_outdir(outdir, inputs)
        guard_directory(outdir, OUTPUT_FILES, inputs, force=o.force)
    tol = o.tolerance if o.tolerance is not None else 0.0
    base_doc = None
    if baseline is not None:
        try:
            base_doc = json.loads(Path(baseline).read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise InputError(f"baseline not found: {baseline}") from None
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(f"{baseline}: not JSON ({exc})") from None
        regress.validate_baseline(base_doc, baseline)
    cfg = load_config(o.config_path) if o.config_path else None

    if o.workers is not None and o.scheduler is not None:
        raise InputError("give --workers or --scheduler, not both")
    if o.workers is not None:
        require_fleet("--workers")
    cluster = scheduler_spec(o.scheduler, o.tls_ca_file, o.tls_cert, o.tls_key)
    trajectories = None
    if o.trajectories:
        from lgvtool.interop.trajfile import read_trajectory

        if len(logs) > 1:
            raise InputError("--trajectory scores a file against one log; give one LOG")
        trajectories = {name: read_trajectory(path) for name, path in o.trajectories.items()}
    per_log = LogEvaluationOptions(
        estimators=tuple(o.estimators) if o.estimators else None, config=cfg, seed=o.seed,
        settings=dict(o.settings) or None, shared_centre=o.shared_centre,
        free_radius=o.free_radius, start_at_truth=o.start_at_truth, trajectories=trajectories,
        threads=1 if o.threads is None else o.threads)

    bar = Progress(0, "evaluate", enabled=o.show_progress, delay_s=1.0)
    try:
        results = _evaluate_all(logs, per_log, scheduler=cluster, workers=o.workers, bar=bar)
        warnings = [f"{res.name}: {w}" for res in results for w in res.warnings]
        _unique_names(results)
        planned = ([str(Path(outdir) / name) for name in _REPORT_FIRST]
                   if outdir is not None else [])
        for res in results:
            res.verdict = verdict_of(res, paths=planned)
        doc = build_document(results)
        checks = regress.bound_checks(doc, o.maxima, o.minima)
        notes: list[str] = []
        if base_doc is not None:
            more, notes = regress.baseline_checks(doc, base_doc, tol,
                                                  source=baseline or "baseline")
            checks += more
        doc["checks"] = regress.check_dicts(checks)
        if outdir is not None:
            bar.stage("report", len(results))
            written = write_outputs(Path(outdir), results, doc, png, o.force, bar)
            pngs = [str(p) for p in written if p.suffix == ".png"]
            if pngs:
                for res in results:
                    if res.verdict is not None:
                        res.verdict = replace(res.verdict, paths=(*res.verdict.paths, *pngs))
    finally:
        bar.close()
    text = to_json(doc) if fmt == "json" else render_tables(results, fmt, wide=o.wide)
    failures = [c.text for c in checks if not c.passed]
    verdicts = [r.verdict for r in results if r.verdict is not None]
    return EvaluationRun(results, doc, text, warnings, notes, failures, verdicts, checks)


def _refuse_input_as_outdir(outdir: str, inputs: Sequence[str | None],
                            files: str = "report.html and table1.*") -> None:
    """InputError when ``outdir`` is one of the input files (also through a link): ``-o``
    names the folder the report (``files``, named in the message) goes into, and a log there
    would be replaced by it."""
    from lgvtool.errors import InputError

    out = Path(outdir)
    if not out.exists() or out.is_dir():
        return
    for src in inputs:
        if src is None:
            continue
        try:
            same = Path(src).exists() and out.samefile(src)
        except OSError:
            same = False
        if same:
            raise InputError(f"the output {outdir} is the input {src}: -o names a folder for "
                             f"{files}; choose another one")


def column_help() -> tuple[tuple[str, str], ...]:
    """(column, meaning) of every column of evaluate's tables, for its ``--help``
    (:data:`lgvtool.evaluate.verdict.COLUMN_HELP`)."""
    from lgvtool.evaluate.verdict import COLUMN_HELP

    return COLUMN_HELP


def _unique_names(results: list[EvaluationResult]) -> None:
    """Logs with the same file name (in different folders) get -2, -3, ... appended."""
    seen: dict[str, int] = {}
    for res in results:
        count = seen.get(res.name, 0) + 1
        seen[res.name] = count
        if count > 1:
            res.name = f"{res.name}-{count}"


OUTPUT_FILES = ("table1.md", "table1.csv", "table1.tex", "table1.json", "report.html")
"""Files that ``evaluate -o DIR`` writes (and PNGs with --png)."""
_REPORT_FIRST = ("report.html", "table1.md", "table1.csv", "table1.tex", "table1.json")
""":data:`OUTPUT_FILES` in the order the verdict names them."""


def write_outputs(out: Path, results: list[EvaluationResult], doc: JSONRecord,
                  png: bool, force: bool = False, bar: Progress | None = None) -> list[Path]:
    """Write :data:`OUTPUT_FILES` of ``results`` and their document ``doc`` into ``out``
    (created), and with ``png`` every figure of the report as ``<slug>.png``; a PNG that would
    replace an input, or an existing file without ``force``, is refused (InputError). ``bar``
    counts the report's figures. The files land together: when one cannot be written (a full
    disk), none of them is replaced. Returns the files written (the PNGs last)."""
    from lgvtool.evaluate.document import to_json
    from lgvtool.evaluate.html_report import render_report
    from lgvtool.evaluate.plots import write_png
    from lgvtool.evaluate.table import render_tables
    from lgvtool.outputs import atomic_outputs, guard_output

    out.mkdir(parents=True, exist_ok=True)
    with atomic_outputs() as place:
        for fmt in ("md", "csv", "tex"):
            place(out / f"table1.{fmt}").write_text(render_tables(results, fmt),
                                                    encoding="utf-8")
        place(out / "table1.json").write_text(to_json(doc), encoding="utf-8")
        figures: list[Any] = []
        place(out / "report.html").write_text(render_report(
            results, figures=figures, progress=None if bar is None else bar.advance),
            encoding="utf-8")
        written = [out / name for name in OUTPUT_FILES]
        if png:
            for slug, fig in figures:
                target = guard_output(out / f"{slug}.png", [r.path for r in results],
                                      force=force)
                write_png(fig, place(target))
                written.append(target)
    return written
