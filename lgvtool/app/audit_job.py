"""Auditing a site from its logs (``lgvtool audit``): each log replayed and turned into evidence
(:func:`lgvtool.audit.log_audit.log_evidence`; in this process for one log, else as tasks on the
fleet engine), the evidence pooled per reflector, each reflector judged
(:mod:`lgvtool.audit.reflector_audit`), and ``audit.json`` and ``report.html`` written into the
output folder. Positions in m, angles in rad, times in s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from pathlib import Path

    from lgvtool.app.option_values import SettingValue
    from lgvtool.audit.fleet_table import AuditedLog
    from lgvtool.audit.log_audit import LogAuditOptions
    from lgvtool.fleet.connect import SchedulerSpec
    from lgvtool.json_types import JSONObject
    from lgvtool.progress import Progress

OUTPUT_FILES = ("audit.json", "report.html", "kpis.csv")
"""Files that ``audit -o DIR`` writes (and ``kpis.parquet`` with the fleet extra's pyarrow,
and each log's evidence under ``logs/``)."""

#: prefixes of ``--set`` keys that are the audit's own (the rest go to the estimator)
SET_GROUPS = ("audit", "view", "coverage", "navigation", "segments", "stations")


@dataclass(frozen=True, slots=True)
class AuditOptions:
    """What :func:`audit_logs` audits and writes (``lgvtool audit``)."""

    logs: tuple[str, ...]
    """The logs (MCAP) of one site, in order."""
    outdir: str
    """Folder that receives :data:`OUTPUT_FILES`."""
    estimator: str | None = None
    """Estimator whose replayed pose is used; None: the best each log allows."""
    seed: int = 0
    """Seed of the estimator's random draws."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """``--set`` values: ``audit.<key>`` (:class:`lgvtool.audit.audit_settings.AuditSettings`),
    ``view.<key>`` (the device's :class:`lgvtool.audit.visibility.DeviceView`),
    ``coverage.<key>`` (:class:`lgvtool.audit.coverage.CoverageSettings`),
    ``navigation.<key>`` (:class:`lgvtool.audit.navigation_health.NavigationSettings`),
    ``segments.<key>`` (:class:`lgvtool.audit.segment_errors.SegmentSettings`),
    ``stations.<key>`` (:class:`lgvtool.audit.stations.StationSettings`), else the
    estimator's (``pf.particles``)."""
    stations_path: str | None = None
    """Stations file (TOML, :mod:`lgvtool.audit.stations_file`): the named stations the
    standstills are assigned to; None: stations are found automatically."""
    config_path: str | None = None
    """Configuration (TOML) used instead of each log's own."""
    workers: int | None = None
    """Processes of a local Dask cluster for several logs; None: one per CPU, or (one log, or
    no fleet extra) this process."""
    scheduler: str | None = None
    """Address of a Dask scheduler that runs the logs; None: none."""
    tls_ca_file: str | None = None
    """CA file (PEM) of a ``tls://`` :attr:`scheduler`."""
    tls_cert: str | None = None
    """This client's certificate (PEM) for a ``tls://`` :attr:`scheduler`."""
    tls_key: str | None = None
    """Private key of :attr:`tls_cert` (PEM), when not in that file."""
    force: bool = False
    """Replace existing files in :attr:`outdir`."""
    resume: bool = False
    """Take each log's evidence kept in :attr:`outdir` (``logs/``) instead of re-running it
    when the log (path, size, mtime) and the options are unchanged; replaces the outputs."""
    show_progress: bool = True
    """Progress on stderr once the audit takes over a second."""


@dataclass
class AuditRun:
    """What :func:`audit_logs` returns."""

    document: JSONObject
    """``audit.json``."""
    lines: list[str]
    """The one-screen text summary."""
    written: list[str]
    """The files written."""


def split_sets(settings: Mapping[str, SettingValue]
               ) -> tuple[dict[str, dict[str, object]], dict[str, SettingValue]]:
    """``--set`` values split into the audit's groups (:data:`SET_GROUPS`: group -> {key:
    value}) and the estimator's settings (the rest, as ``replay`` takes them)."""
    groups: dict[str, dict[str, object]] = {g: {} for g in SET_GROUPS}
    rest: dict[str, SettingValue] = {}
    for key, value in settings.items():
        group, dot, name = key.partition(".")
        if dot and group in groups:
            groups[group][name] = value
        else:
            rest[key] = value
    return groups, rest


@dataclass(frozen=True)
class _LogTask:
    """What one worker needs to audit one log: its path and the options (small, picklable)."""

    path: str
    options: LogAuditOptions
    key: str = ""
    """:func:`lgvtool.audit.fleet_table.log_key` of the log."""


def _audit_task(task: _LogTask) -> AuditedLog:
    """One log's evidence on a worker of the fleet engine, with its vehicle, day and the wall
    time it took (s)."""
    import time
    import warnings
    from pathlib import Path

    from lgvtool.audit.fleet_table import AuditedLog, utc_day, vehicle_of
    from lgvtool.audit.log_audit import log_evidence
    from lgvtool.log import LogReader

    started = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        evidence = log_evidence(task.path, task.options)
        reader = LogReader(task.path)
        start_ns = min((i.start_ns for i in reader.topics().values()), default=0)
    return AuditedLog(task.key, evidence, vehicle_of(reader.metadata, Path(task.path).stem),
                      utc_day(start_ns), time.perf_counter() - started)


def _evidence_of_all(logs: Sequence[str], options: LogAuditOptions, *, out: Path,
                     resume: bool, scheduler: SchedulerSpec | None, workers: int | None,
                     bar: Progress | None) -> list[AuditedLog]:
    """Every log's evidence, in the logs' order: with ``resume`` the ones kept in ``out``
    (``logs/``) as they are, the others run in this process for one log (or without the fleet
    extra), else on the fleet engine, and each kept in ``out``; the first log that fails
    stops the audit with its error."""
    import os

    from lgvtool.audit.fleet_table import load_audited, log_key, save_audited, stored_path
    from lgvtool.errors import LogFormatError
    from lgvtool.fleet.engine import run_in_order

    tasks = []
    for log in logs:
        try:
            st = os.stat(log)
        except OSError as exc:
            raise LogFormatError(f"{log}: {exc.strerror or 'cannot be read'}") from exc
        tasks.append(_LogTask(log, options, log_key(os.path.realpath(log), st.st_size,
                                                    st.st_mtime_ns, options)))
    done: dict[int, AuditedLog] = {}
    if resume:
        for i, task in enumerate(tasks):
            kept = load_audited(stored_path(out, task.path, task.key), task.key)
            if kept is not None:
                done[i] = kept
                if bar is not None:
                    bar.advance(1)

    def here(task: _LogTask) -> AuditedLog:
        audited = _audit_task(task)
        if bar is not None:
            bar.advance(1)
        return audited

    todo = [t for i, t in enumerate(tasks) if i not in done]
    ran = run_in_order(_audit_task, todo, scheduler=scheduler, workers=workers,
                       in_process=here, progress=bar is not None and bar.enabled,
                       path_of=lambda task: task.path)
    for task, audited in zip(todo, ran, strict=True):
        save_audited(stored_path(out, task.path, task.key), audited)
    fresh = iter(ran)
    return [done[i] if i in done else next(fresh) for i in range(len(tasks))]


def audit_logs(options: AuditOptions) -> AuditRun:
    """Audit the ``options``' logs as ``lgvtool audit`` does (see :class:`AuditOptions`) and
    write ``audit.json`` and ``report.html`` into its folder (an existing file is replaced only
    with ``force``, an input never).

    :raises InputError: (or a subclass; exit 2) a bad option or setting, an unknown estimator,
        an unreadable log, a log without a reflector layout, logs of different layouts, a bad
        stations file, or an output folder that is an input.
    """
    import json
    from pathlib import Path

    from lgvtool.app.evaluate_job import _refuse_input_as_outdir
    from lgvtool.audit.audit_document import audit_document, summary_lines
    from lgvtool.audit.audit_report import write_audit_report
    from lgvtool.audit.audit_settings import audit_settings
    from lgvtool.audit.coverage import CoverageSettings, section_from
    from lgvtool.audit.fleet_table import kpi_row, kpi_table, write_kpi_table
    from lgvtool.audit.log_audit import LogAuditOptions, same_layout
    from lgvtool.audit.navigation_health import NavigationSettings, navigation_section
    from lgvtool.audit.reflector_audit import judge, pooled
    from lgvtool.audit.segment_errors import SegmentSettings, segments_section
    from lgvtool.audit.stations import StationSettings, find_stations, stations_section
    from lgvtool.audit.stations import log_kpis as station_kpis
    from lgvtool.audit.stations_file import read_stations
    from lgvtool.audit.unmapped_objects import listed_objects, pooled_unmapped
    from lgvtool.audit.visibility import DeviceView
    from lgvtool.config import load_config
    from lgvtool.declared import make
    from lgvtool.errors import InputError
    from lgvtool.extras import available
    from lgvtool.fleet.connect import require_fleet, scheduler_spec
    from lgvtool.localize.registry import check_names
    from lgvtool.outdir import guard_directory
    from lgvtool.outputs import atomic_outputs
    from lgvtool.progress import Progress

    o = options
    if o.estimator is not None:
        check_names([o.estimator])
    inputs = [*o.logs, o.config_path, o.stations_path]
    _refuse_input_as_outdir(o.outdir, inputs, " and ".join(OUTPUT_FILES))
    out = guard_directory(o.outdir, (*OUTPUT_FILES, "kpis.parquet"), inputs,
                          force=o.force or o.resume)
    groups, estimator_settings = split_sets(o.settings)
    settings = audit_settings(groups["audit"])
    DeviceView.for_family("nav350", groups["view"])  # checked here, before any log is read
    cov_settings = make(CoverageSettings, "coverage", groups["coverage"], what="setting")
    nav_settings = make(NavigationSettings, "navigation", groups["navigation"], what="setting")
    seg_settings = make(SegmentSettings, "segments", groups["segments"], what="setting")
    st_settings = make(StationSettings, "stations", groups["stations"], what="setting")
    named = read_stations(o.stations_path) if o.stations_path is not None else None
    if o.workers is not None and o.scheduler is not None:
        raise InputError("give --workers or --scheduler, not both")
    if o.workers is not None:
        require_fleet("--workers")
    cluster = scheduler_spec(o.scheduler, o.tls_ca_file, o.tls_cert, o.tls_key)
    cfg = load_config(o.config_path) if o.config_path else None
    per_log = LogAuditOptions(estimator=o.estimator, config=cfg, seed=o.seed,
                              settings=dict(estimator_settings), audit=settings,
                              view=dict(groups["view"]), coverage=cov_settings,
                              navigation=nav_settings, segments=seg_settings,
                              stations=st_settings)
    bar = Progress(len(o.logs), "audit", enabled=o.show_progress, delay_s=1.0)
    try:
        logs = _evidence_of_all(o.logs, per_log, out=out, resume=o.resume,
                                scheduler=cluster, workers=o.workers, bar=bar)
    finally:
        bar.close()
    parts = [a.evidence for a in logs]
    if not same_layout(parts):
        raise InputError("the logs hold different reflector layouts: an audit pools the logs "
                         "of one layout (give --config with the site's layout)")
    layout = parts[0].layout
    audited = [p for p in parts if p.reflectors is not None]
    verdicts = []
    unmapped = []
    if audited:
        evidence = pooled([p.reflectors for p in audited if p.reflectors is not None])
        verdicts = judge(evidence, layout, settings)
        unmapped = listed_objects(pooled_unmapped(
            [p.unmapped for p in audited if p.unmapped is not None], settings), settings)
    coverage = section_from([p.track for p in parts], [p.coverage for p in parts], layout,
                            parts[0].view, cov_settings,
                            missing=[v.id for v in verdicts if v.status == "missing"])
    navigation = navigation_section([(p.path, p.family, p.navigation) for p in parts],
                                    nav_settings)
    segments = segments_section([e for p in parts for e in p.segments],
                                [p.path for p in parts if not p.segments], seg_settings)
    found = find_stations([v for p in parts for v in p.visits], named, st_settings)
    stations = stations_section(found, st_settings, file=o.stations_path,
                                without_odometry=[p.path for p in parts if not p.has_odometry])
    doc = audit_document(parts, verdicts, unmapped, coverage, settings, navigation=navigation,
                         segments=segments, stations=stations)
    table = kpi_table([kpi_row(a, judge(a.evidence.reflectors, layout, settings)
                               if a.evidence.reflectors is not None else [],
                               station_kpis(found, a.evidence.path))
                       for a in logs])
    parquet = out / "kpis.parquet" if available("pyarrow") else None
    written = [str(out / name) for name in OUTPUT_FILES]
    written += [str(parquet)] if parquet is not None else []
    out.mkdir(parents=True, exist_ok=True)
    with atomic_outputs() as place:
        place(out / "audit.json").write_text(json.dumps(doc, indent=2) + "\n",
                                             encoding="utf-8")
        write_audit_report(doc, layout, place(Path(out / "report.html")),
                           [p.track for p in parts])
        write_kpi_table(table, place(out / "kpis.csv"),
                        None if parquet is None else place(parquet))
    return AuditRun(doc, summary_lines(doc, written), written)
