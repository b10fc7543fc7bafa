"""``lgvtool replay``: run estimators over a log and write a new log with their estimates."""

from __future__ import annotations

import os
from typing import Any

import click

from lgvtool.options import (
    Number,
    compression_option,
    estimator_option,
    force_option,
    progress_option,
    seed_option,
    set_option,
    split_names,
    warn,
)
from lgvtool.values import MAX_COUNT, MAX_WALL_S

# The filters' matrix products are tiny (at most particles x reflectors): BLAS threads only add
# their start-up and their spinning between calls (about 0.1 s of an hour's replay). Set before
# numpy is imported (the command imports it when it runs); an explicit setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")



@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="Output log (MCAP): the input's messages plus the estimates.")
@estimator_option("Estimator to run: laser, deadreckoning, ekf, pf-paper, pf; default: all five")
@click.option("--particles", type=Number(int, 1, MAX_COUNT), default=None,
              help="Particle count of the particle filters run (pf-paper, pf).")
@seed_option("Seed of every random draw; the same seed gives identical output.")
@set_option()
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              default=None, help="Configuration file (TOML): vehicle, area, reflectors, "
                                 "[estimators.*]. Default: the one stored in the log.")
@click.option("--start-at-truth", is_flag=True,
              help="Start every estimator at the log's ground truth (/truth/pose).")
@click.option("--cloud-period", type=Number(float, 0.0, MAX_WALL_S), default=2.0,
              show_default=True, help="Keep one particle cloud per this many seconds, s.")
@click.option("--cloud-size", type=Number(int, 0, MAX_COUNT), default=50, show_default=True,
              help="At most this many particles per kept cloud (0: no clouds).")
@compression_option("Chunk compression of the output (the input's messages and the estimates, "
                    "merged in time order).")
@click.option("--view/--no-view", default=True, show_default=True,
              help="Also write the channels Foxglove draws: frames, NAV head and scans, "
                   "covariance ellipses, reference circle (docs/log-format.md).")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@progress_option("Progress on stderr once the replay takes over a second.")
def replay(log: str, output: str, estimators: tuple[str, ...], particles: int | None,
           seed: int, sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
           cloud_period: float, cloud_size: int, compression: str, view: bool,
           as_json: bool, force: bool, show_progress: bool = True) -> None:
    """Replay LOG through the localisation estimators and write OUTPUT.

    OUTPUT is a complete log: every message of LOG, plus per estimator NAME the pose of the
    target rotation centre O on /estimate/NAME/pose (foxglove.PoseInFrame), the pose with its
    covariance on /estimate/NAME/state (lgvtool.PoseEstimate) and, for particle filters,
    decimated particle clouds on /estimate/NAME/particles (foxglove.PosesInFrame); with
    --view (the default) also what Foxglove's 3D panel draws: the frames map -> NAME/O ->
    NAME/head, covariance ellipses, the NAV head, its scans and the reference circle. The
    effective estimator settings and the seed are stored in the metadata record 'replay'.
    Positions in m, headings in rad, times in the log's own clock.
    """
    import gc

    # Reading, filtering and writing allocate millions of objects that form no cycles: the
    # collector's passes over them cost tens of ms and free nothing.
    collecting = gc.isenabled()
    gc.disable()
    from lgvtool.outputs import guard_output

    guard_output(output, [log, config_path], force=force)
    try:
        _replay(log, output, split_names(estimators), particles, seed, sets, config_path,
                start_at_truth, cloud_period, cloud_size, compression, as_json, show_progress,
                view)
    finally:
        if collecting:
            gc.enable()


def _replay(log: str, output: str, estimators: list[str], particles: int | None,
            seed: int, sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
            cloud_period: float, cloud_size: int, compression: str, as_json: bool,
            show_progress: bool = True, view: bool = True) -> None:
    """The replay command (see :func:`replay`)."""
    import json
    import time
    import warnings
    from dataclasses import fields

    from lgvtool.config import load_config, parse_set_options
    from lgvtool.errors import InputError, MissingDataError
    from lgvtool.localize.registry import DEFAULT_ESTIMATORS, ESTIMATORS, check_names
    from lgvtool.localize.replay_driver import load_log, replay_data
    from lgvtool.log import LogReader
    from lgvtool.outputs import atomic_output

    started = time.perf_counter()
    names = check_names(list(estimators) if estimators else list(DEFAULT_ESTIMATORS))
    settings: dict[str, Any] = parse_set_options(sets)
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
    data = load_log(reader, cfg.reflectors or None, truth=start_at_truth)
    t_read = time.perf_counter() - started

    from lgvtool.progress import Progress

    total = len(names) * (len(data.scans) + (len(data.nav["t"]) if data.nav else 0))
    t0 = time.perf_counter()
    with Progress(max(total, 1), "replay", enabled=show_progress, delay_s=1.0) as bar:
        result = replay_data(data, names, config=cfg, seed=seed, settings=settings,
                             initial_pose="truth" if start_at_truth else None,
                             progress=bar.advance, cloud_period_s=cloud_period,
                             cloud_size=cloud_size)
        bar.set(max(total, 1))
    t_filter = time.perf_counter() - t0
    if estimators:
        for n in names:
            if n in result.skipped:
                raise MissingDataError(f"{log}: {result.skipped[n]}")
    for why in result.skipped.values():
        warn(f"{why}; skipped")

    t1 = time.perf_counter()
    with atomic_output(output) as tmp:
        written = _write(reader, str(tmp), result, cfg if config_path else None, log,
                         compression, view_config=cfg if view else None)
    t_write = time.perf_counter() - t1
    summary: dict[str, Any] = {
        "output": output,
        "seed": seed,
        "estimators": {n: {"estimates": len(result.tables[n].x),
                           "clouds": len(result.clouds.get(n, [])),
                           "seconds": round(result.timings.get(n, 0.0), 4)}
                       for n in result.tables},
        "skipped": result.skipped,
        "messages_written": written,
        "seconds": {"read": round(t_read, 4), "filter": round(t_filter, 4),
                    "write": round(t_write, 4),
                    "total": round(time.perf_counter() - started, 4)},
    }
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        parts = ", ".join(f"{n} {v['estimates']}" for n, v in summary["estimators"].items())
        click.echo(f"wrote {output}: estimates per estimator: {parts}")


def _write(reader: Any, output: str, result: Any, config: Any, source: str,
           compression: str = "zstd", view_config: Any = None,
           window_ns: int | None = None) -> int:
    """The input's messages, the metadata, the estimates and the Foxglove view channels
    (lgvtool.log.view_channels), merged in log-time order (an input message first at one time, then
    pose before state before cloud before the view channels, estimators in run order), so
    that the file passes the reference checker without an ordering warning. The added
    messages are encoded one window of log time (``window_ns``, default
    lgvtool.log.windows.WINDOW_NS) at a time, as the merge reaches it."""
    from pathlib import Path

    from lgvtool.localize.replay_sources import replay_sources
    from lgvtool.log import LogWriter
    from lgvtool.log.windows import WINDOW_NS, WindowedMerge

    merge = WindowedMerge(replay_sources(reader, result, view_config),
                          WINDOW_NS if window_ns is None else window_ns)
    skip = frozenset(t for t in merge.topics if reader.has_topic(t))
    with LogWriter(output, source="replay", chunk_seconds=None, compression=compression) as w:
        n_written = w.copy_from(reader, skip_topics=skip, extra=merge) + merge.count
        w.add_metadata("replay", {
            "input": Path(source).name,
            "seed": result.seed,
            "estimators": list(result.tables),
            "settings": result.settings,
            "skipped": result.skipped,
            "foxglove_view": view_config is not None,
        })
        if config is not None:
            w.write_config(config)
    return n_written
