"""Replaying a log: run estimators over it and write a new log with their estimates
(``lgvtool replay``).

The output holds every message of the input, per estimator its poses, states and particle
clouds, and (``view``) the channels Foxglove draws (docs/log-format.md). Positions in m,
headings in rad, times in the log's own clock.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:
    from lgvtool.app.option_values import SettingValue
    from lgvtool.config import Config
    from lgvtool.localize.replay_driver import ReplayResult
    from lgvtool.log.reader import LogReader
    from lgvtool.log.view_channels import LogRows

# The filters' matrix products are tiny (at most particles x reflectors): BLAS threads only add
# their start-up and their spinning between calls (about 0.1 s of an hour's replay). Set before
# numpy is imported (this module is imported when a replay runs); an explicit setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


def _ignore(text: str) -> None:
    """The default ``warn`` of :func:`replay_log`: warnings are dropped."""


@dataclass(frozen=True, slots=True)
class ReplayOptions:
    """What :func:`replay_log` replays, through which estimators, and what it writes
    (``lgvtool replay``)."""

    log: str
    """The log (MCAP) to replay."""
    output: str
    """The log to write (through a temporary file): every message of :attr:`log` plus the
    estimates; an existing one is replaced only with :attr:`force`, an input never."""
    estimators: tuple[str, ...] = ()
    """Estimators to run; empty: all five (an estimator that cannot run on the log is then
    skipped with a warning, not refused)."""
    particles: int | None = None
    """Particle count of the particle filters chosen (pf-paper, pf); None: their setting."""
    seed: int = 0
    """Seed of every random draw; the same seed gives identical output."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Estimator settings (``pf.particles`` -> 500)."""
    config_path: str | None = None
    """Configuration (TOML) used instead of the log's own (and stored in the output); None:
    the log's."""
    start_at_truth: bool = False
    """Start every estimator at the log's ground truth (/truth/pose)."""
    cloud_period: float = 2.0
    """One particle cloud kept per this many s of log time."""
    cloud_size: int = 50
    """At most this many particles per kept cloud (0: no clouds)."""
    compression: str = "zstd"
    """Chunk compression of :attr:`output`: zstd, lz4 or none."""
    view: bool = True
    """Also write the channels Foxglove draws (frames, NAV head and scans, covariance
    ellipses, reference circle)."""
    force: bool = False
    """Replace an existing :attr:`output`."""
    threads: int | None = None
    """Threads the estimators run on at once; None: one per estimator, at most one per CPU,
    with the compiled kernels, else one (the same output for any count)."""
    show_progress: bool = True
    """Progress on stderr once the replay takes over a second."""


class EstimatorRun(TypedDict):
    """One estimator of a replay: the estimates and particle clouds it wrote, the seconds it
    took, and its events (restarts, re-anchorings: each also an event of the output)."""

    estimates: int
    clouds: int
    seconds: float
    events: int


class ReplaySummary(TypedDict):
    """What :func:`replay_log` did (``lgvtool replay --json``): the output, the seed, each
    estimator's run, the estimators skipped with the reason, the messages written and the
    seconds spent reading, filtering, writing and in total."""

    output: str
    seed: int
    estimators: dict[str, EstimatorRun]
    skipped: dict[str, str]
    messages_written: int
    seconds: dict[str, float]


def replay_log(options: ReplayOptions, *, warn: Callable[[str], None] = _ignore
               ) -> ReplaySummary:
    """Replay the ``options``' log through its estimators and write its output (see
    :class:`ReplayOptions`). ``warn`` receives each warning (corrupt chunks of the input,
    estimators left out) as it is met.

    Returns the summary ``lgvtool replay --json`` prints: output, seed, per estimator its
    estimates, clouds and seconds, skipped estimators with the reason, messages written and
    the seconds spent reading, filtering and writing.

    :raises InputError: (or a subclass; exit 2) a bad option, log or configuration, or an
        estimator asked for by name that cannot run on the log.
    """
    from lgvtool.gc_pause import collector_paused
    from lgvtool.outputs import guard_output

    guard_output(options.output, [options.log, options.config_path], force=options.force)
    with collector_paused():
        return _replay(options, warn)


def _replay(options: ReplayOptions, warn: Callable[[str], None]) -> ReplaySummary:
    """The replay (see :func:`replay_log`)."""
    import time
    import warnings
    from dataclasses import fields

    from lgvtool.config import load_config
    from lgvtool.errors import InputError, MissingDataError
    from lgvtool.localize.registry import DEFAULT_ESTIMATORS, ESTIMATORS, check_names
    from lgvtool.localize.replay_driver import LazyScans, load_log, replay_data
    from lgvtool.log import LogReader
    from lgvtool.log.view_channels import LogRows, RowCollector
    from lgvtool.outputs import atomic_output

    o = options
    log, output, estimators, particles, seed = o.log, o.output, o.estimators, o.particles, o.seed
    config_path, start_at_truth, view = o.config_path, o.start_at_truth, o.view
    started = time.perf_counter()
    names = check_names(list(estimators) if estimators else list(DEFAULT_ESTIMATORS))
    settings: dict[str, Any] = dict(o.settings)
    if particles is not None:
        targets = [n for n in names
                   if any(f.name == "particles" for f in fields(ESTIMATORS[n].Params))]
        if not targets:
            raise InputError("--particles applies to the particle filters (pf-paper, pf), "
                             "none of which is selected")
        for n in targets:
            settings.setdefault(f"{n}.particles", particles)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    for w in reader.warnings:
        warn(w)
    cfg = load_config(config_path) if config_path else reader.config()
    # the view's rows (NAV poses, truth, MCU frames) gathered in the estimators' reading
    collector = RowCollector(reader, skip_scans=True) if view else None
    # decoded as they are read when they will all be: by an estimator or by the view
    data = load_log(reader, cfg.reflectors or None, truth=start_at_truth, tap=collector,
                    decode_scans=view or any(ESTIMATORS[n].uses_scans for n in names))
    t_read = time.perf_counter() - started

    from lgvtool.progress import Progress

    total = len(names) * (len(data.scans) + (len(data.nav["t"]) if data.nav else 0))
    t0 = time.perf_counter()
    with Progress(max(total, 1), "replay", enabled=o.show_progress, delay_s=1.0) as bar:
        result = replay_data(data, names, config=cfg, seed=seed, settings=settings,
                             initial_pose="truth" if start_at_truth else None,
                             progress=bar.advance, cloud_period_s=o.cloud_period,
                             cloud_size=o.cloud_size, threads=o.threads)
        bar.set(max(total, 1))
    t_filter = time.perf_counter() - t0
    if estimators:
        for n in names:
            if n in result.skipped:
                raise MissingDataError(f"{log}: {result.skipped[n]}")
    for why in result.skipped.values():
        warn(f"{why}; skipped")
    for name, events in result.events.items():
        kinds = ", ".join(f"{k} {sum(e[1] == k for e in events)}"
                          for k in dict.fromkeys(e[1] for e in events))
        warn(f"{name}: {kinds} (the first at {(events[0][0] - result.t0_ns) * 1e-9:.1f} s: "
             f"{events[0][2]}); each is an event on /diagnostics")

    t1 = time.perf_counter()
    with atomic_output(output) as tmp:
        rows = None
        if collector is not None:
            # the scans as the estimators decoded them, if any did
            scans = data.scans.decoded_columns() if isinstance(data.scans, LazyScans) else None
            rows = LogRows(reader, scans, collector)
        written = write_replay_log(reader, str(tmp), result, cfg if config_path else None, log,
                                   o.compression, view_config=cfg if view else None, rows=rows)
    t_write = time.perf_counter() - t1
    return {
        "output": output,
        "seed": seed,
        "estimators": {n: {"estimates": len(result.estimates[n]),
                           "clouds": len(result.clouds.get(n, [])),
                           "seconds": round(result.timings.get(n, 0.0), 4),
                           "events": len(result.events.get(n, []))}
                       for n in result.estimates},
        "skipped": result.skipped,
        "messages_written": written,
        "seconds": {"read": round(t_read, 4), "filter": round(t_filter, 4),
                    "write": round(t_write, 4),
                    "total": round(time.perf_counter() - started, 4)},
    }


def write_replay_log(reader: LogReader, output: str, result: ReplayResult, config: Config | None,
                     source: str, compression: str = "zstd", view_config: Config | None = None,
                     window_ns: int | None = None, rows: LogRows | None = None) -> int:
    """Write ``output``: the messages of ``reader`` (the input, named ``source`` in the
    metadata), the metadata, the estimates of ``result`` (a replay result), ``config`` (when
    given) and the Foxglove view channels of ``view_config``; returns the messages written.

    The input's messages, the metadata, the estimates and the Foxglove view channels
    (lgvtool.log.view_channels), merged in log-time order (an input message first at one time, then
    pose before state before cloud before the view channels, estimators in run order), so
    that the file passes the reference checker without an ordering warning. The added
    messages are encoded one window of log time (``window_ns``, default
    lgvtool.log.windows.WINDOW_NS) at a time, as the merge reaches it. ``rows``: the rows
    the view draws, already gathered (:class:`lgvtool.log.view_channels.LogRows`, with the
    scans as the estimators decoded them), which the view then does not read again. The
    input's estimates and view channels are replaced; its events (/diagnostics and their
    mirror) are kept, and the replay's are added to them
    (:func:`lgvtool.localize.replay_sources.replay_events`: once, a replayed log replayed
    again does not repeat them)."""
    from pathlib import Path

    from lgvtool.localize.replay_sources import replay_sources
    from lgvtool.log import LogWriter, topics
    from lgvtool.log.windows import WINDOW_NS, WindowedMerge

    merge = WindowedMerge(replay_sources(reader, result, view_config, rows),
                          WINDOW_NS if window_ns is None else window_ns)
    # the replay's topics replace the input's, but for the events: those of the input stay,
    # the replay's are added to them
    skip = frozenset(t for t in merge.topics if reader.has_topic(t)
                     and t not in (topics.DIAGNOSTICS, topics.DIAGNOSTICS_LOG))
    with LogWriter(output, source="replay", chunk_seconds=None, compression=compression) as w:
        n_written = w.copy_from(reader, skip_topics=skip, extra=merge) + merge.count
        w.add_metadata("replay", {
            "input": Path(source).name,
            "seed": result.seed,
            "estimators": list(result.estimates),
            "settings": result.settings,
            "skipped": result.skipped,
            "foxglove_view": view_config is not None,
        })
        if config is not None:
            w.write_config(config)
    return n_written
