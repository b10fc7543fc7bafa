"""``lgvtool replay``: run estimators over a log and write a new log with their estimates."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING, Any

import click

# The filters' matrix products are tiny (at most particles x reflectors): BLAS threads only add
# their start-up and their spinning between calls (about 0.1 s of an hour's replay). Set before
# numpy is imported (the command imports it when it runs); an explicit setting wins.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

#: logs longer than this (s of data) show a progress bar even when stderr is not a terminal
LONG_LOG_S = 600.0


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="Output log (MCAP): the input's messages plus the estimates.")
@click.option("-e", "--estimator", "estimators", multiple=True, metavar="NAME",
              help="Estimator to run (repeatable): laser, deadreckoning, ekf, pf-paper, pf. "
                   "Default: all five.")
@click.option("--particles", type=click.IntRange(min=1), default=None,
              help="Particle count of the particle filters run (pf-paper, pf).")
@click.option("--seed", type=int, default=0, show_default=True,
              help="Seed of every random draw; the same seed gives identical output.")
@click.option("--set", "sets", multiple=True, metavar="EST.PARAM=VALUE",
              help="Estimator parameter, e.g. pf.particles=500 or pf-paper.spread_m=0.3 "
                   "(repeatable; docs/filter.md lists them).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              default=None, help="Configuration file (TOML): vehicle, area, reflectors, "
                                 "[estimators.*]. Default: the one stored in the log.")
@click.option("--start-at-truth", is_flag=True,
              help="Start every estimator at the log's ground truth (/truth/pose).")
@click.option("--cloud-period", type=click.FloatRange(min=0.0), default=2.0, show_default=True,
              help="Keep one particle cloud per this many seconds, s.")
@click.option("--cloud-size", type=click.IntRange(min=0), default=50, show_default=True,
              help="At most this many particles per kept cloud (0: no clouds).")
@click.option("--compression", type=click.Choice(["lz4", "zstd", "none"]), default="lz4",
              show_default=True, help="Compression of the chunks holding the estimates (the "
                                      "input's chunks are copied as they are).")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def replay(log: str, output: str, estimators: tuple[str, ...], particles: int | None,
           seed: int, sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
           cloud_period: float, cloud_size: int, compression: str, as_json: bool) -> None:
    """Replay LOG through the localisation estimators and write OUTPUT.

    OUTPUT is a complete log: every message of LOG, plus per estimator NAME the pose of the
    target rotation centre O on /estimate/NAME/pose (foxglove.PoseInFrame), the pose with its
    covariance on /estimate/NAME/state (lgvtool.PoseEstimate) and, for particle filters,
    decimated particle clouds on /estimate/NAME/particles (foxglove.PosesInFrame). The
    effective estimator settings and the seed are stored in the metadata record 'replay'.
    Positions in m, headings in rad, times in the log's own clock.
    """
    import gc

    # Reading, filtering and writing allocate millions of objects that form no cycles: the
    # collector's passes over them cost tens of ms and free nothing.
    collecting = gc.isenabled()
    gc.disable()
    try:
        _replay(log, output, estimators, particles, seed, sets, config_path, start_at_truth,
                cloud_period, cloud_size, compression, as_json)
    finally:
        if collecting:
            gc.enable()


def _replay(log: str, output: str, estimators: tuple[str, ...], particles: int | None,
            seed: int, sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
            cloud_period: float, cloud_size: int, compression: str, as_json: bool) -> None:
    """The replay command (see :func:`replay`)."""
    import json
    import sys
    import time
    import warnings
    from dataclasses import fields

    from lgvtool.config import load_config, parse_set_options
    from lgvtool.errors import InputError, MissingDataError
    from lgvtool.localize.registry import DEFAULT_ESTIMATORS, ESTIMATORS, check_names
    from lgvtool.localize.replay import load_log, replay_data
    from lgvtool.log import LogReader

    started = time.perf_counter()
    if os.path.abspath(output) == os.path.abspath(log):
        raise InputError("the output must not be the input log")
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
        click.echo(f"lgvtool: warning: {w}", err=True)
    cfg = load_config(config_path) if config_path else reader.config()
    data = load_log(reader, cfg.reflectors or None, truth=start_at_truth)
    t_read = time.perf_counter() - started

    show = sys.stderr.isatty() or data.end > LONG_LOG_S
    total = len(names) * (len(data.scans) + (len(data.nav["t"]) if data.nav else 0))
    t0 = time.perf_counter()
    if show:
        with click.progressbar(length=max(total, 1), label="replay", file=sys.stderr) as bar:
            result = replay_data(data, names, config=cfg, seed=seed, settings=settings,
                                 initial_pose="truth" if start_at_truth else None,
                                 progress=bar.update, cloud_period_s=cloud_period,
                                 cloud_size=cloud_size)
            bar.update(max(0, total - bar.pos))
    else:
        result = replay_data(data, names, config=cfg, seed=seed, settings=settings,
                             initial_pose="truth" if start_at_truth else None,
                             cloud_period_s=cloud_period, cloud_size=cloud_size)
    t_filter = time.perf_counter() - t0
    if estimators:
        for n in names:
            if n in result.skipped:
                raise MissingDataError(f"{log}: {result.skipped[n]}")
    for why in result.skipped.values():
        click.echo(f"lgvtool: warning: {why}; skipped", err=True)

    t1 = time.perf_counter()
    written = _write(reader, output, result, cfg if config_path else None, log, compression)
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
           compression: str = "lz4") -> int:
    """The input's messages (chunks copied verbatim), the metadata and the estimates, merged
    in time order (pose before state before cloud at one time, estimators in run order)."""
    from pathlib import Path

    import numpy as np

    from lgvtool.log import LogWriter, topics

    skip = frozenset(t for n in result.tables for t in (
        topics.estimate_pose(n), topics.estimate_state(n), topics.estimate_particles(n)))
    skip = frozenset(t for t in skip if reader.has_topic(t))

    def encode(tables: dict[str, Any], clouds_of: dict[str, Any]) -> tuple[
            list[str], list[bytes], NDArray[np.int64], list[int]]:
        """The estimate messages of ``tables`` and ``clouds_of``: topics, JSON, times and
        their write order."""
        names: list[str] = []
        datas: list[bytes] = []
        times: list[NDArray[np.int64]] = []
        keys: list[NDArray[np.int64]] = []  # (order at one time, stream)
        stream = 0
        for name, tab in tables.items():
            for order, (topic, encoded) in enumerate((
                    (topics.estimate_pose(name), _pose_messages(tab)),
                    (topics.estimate_state(name), _state_messages(name, tab)))):
                names.extend([topic] * len(encoded))
                datas.extend(encoded)
                times.append(tab.t_ns)
                keys.append(np.full(len(encoded), order * 1024 + stream, dtype=np.int64))
            stream += 1
        for name, clouds in clouds_of.items():
            encoded = _cloud_messages(clouds)
            names.extend([topics.estimate_particles(name)] * len(encoded))
            datas.extend(encoded)
            times.append(np.array([c[0] for c in clouds], dtype=np.int64))
            keys.append(np.full(len(encoded), 2 * 1024 + stream, dtype=np.int64))
            stream += 1
        t_all = np.concatenate(times) if times else np.zeros(0, dtype=np.int64)
        k_all = np.concatenate(keys) if keys else np.zeros(0, dtype=np.int64)
        order_all = np.lexsort((k_all, t_all)).tolist()
        return names, datas, t_all, order_all

    n_written = 0
    with LogWriter(output, source="replay", chunk_seconds=None, compression=compression) as w:
        n_written += w.copy_from(reader, skip_topics=skip)
        w.add_metadata("replay", {
            "input": Path(source).name,
            "seed": result.seed,
            "estimators": list(result.tables),
            "settings": result.settings,
            "skipped": result.skipped,
        })
        if config is not None:
            w.write_config(config)
        for t_ns, text in getattr(result, "gated", []):
            w.write_diagnostic("nav200", "pose_implausible", text, t_ns)
        n_written += 2 * len(getattr(result, "gated", []))
        # the estimates a time window at a time: the same messages in the same order, without
        # holding the JSON of every estimate of a long log at once
        for tables, clouds_of in _windows(result.tables, result.clouds):
            names, datas, t_all, order_all = encode(tables, clouds_of)
            w.write_encoded_many([names[i] for i in order_all],
                                 [datas[i] for i in order_all], t_all[order_all].tolist())
            n_written += len(order_all)
    return n_written


#: log time covered by one window of estimates written at a time, ns
WINDOW_NS = 600 * 1_000_000_000


def _windows(tables: dict[str, Any], clouds: dict[str, Any]) -> Any:
    """``(tables, clouds)`` restricted to consecutive windows of :data:`WINDOW_NS` of log time
    (the rows and clouds of each estimator whose time falls in the window)."""
    from dataclasses import fields, replace

    import numpy as np

    stamps = [t.t_ns for t in tables.values() if len(t.t_ns)]
    stamps += [np.array([c[0] for c in cl], dtype=np.int64) for cl in clouds.values() if cl]
    if not stamps:
        yield tables, clouds
        return
    lo = min(int(a.min()) for a in stamps)
    hi = max(int(a.max()) for a in stamps)
    for start in range(lo, hi + 1, WINDOW_NS):
        end = start + WINDOW_NS
        part = {}
        for name, tab in tables.items():
            a, b = np.searchsorted(tab.t_ns, [start, end], side="left").tolist()
            part[name] = replace(tab, **{f.name: getattr(tab, f.name)[a:b] for f in fields(tab)})
        yield part, {name: [c for c in cl if start <= c[0] < end] for name, cl in clouds.items()}


def _numbers(values: Any) -> list[bytes]:
    """JSON texts of the numbers of a 1-D array (orjson's formatting, as in whole messages)."""
    import numpy as np
    import orjson

    text = orjson.dumps(np.ascontiguousarray(values, dtype=np.float64),
                        option=orjson.OPT_SERIALIZE_NUMPY)
    return text[1:-1].split(b",") if len(text) > 2 else []


def _stamps(t_ns: Any) -> tuple[list[int], list[int]]:
    """Seconds and nanoseconds of integer ns since the epoch."""
    import numpy as np

    sec, nsec = np.divmod(np.asarray(t_ns, dtype=np.int64), 1_000_000_000)
    return sec.tolist(), nsec.tolist()


def _pose_messages(tab: Any) -> list[bytes]:
    """foxglove.PoseInFrame messages (JSON) of an estimate table's poses."""
    import numpy as np
    import orjson

    from lgvtool.log.messages import FRAME_ID

    head = b'{"timestamp":{"sec":%d,"nsec":%d},"frame_id":' + orjson.dumps(FRAME_ID)
    template = head + (b',"pose":{"position":{"x":%b,"y":%b,"z":0.0},"orientation":'
                       b'{"x":0.0,"y":0.0,"z":%b,"w":%b}}}')
    half = 0.5 * tab.heading
    return [template % row for row in zip(*_stamps(tab.t_ns), _numbers(tab.x), _numbers(tab.y),
                                          _numbers(np.sin(half)), _numbers(np.cos(half)),
                                          strict=True)]


def _state_messages(name: str, tab: Any) -> list[bytes]:
    """lgvtool.PoseEstimate messages (JSON) of an estimate table."""
    import orjson

    template = (b'{"timestamp":{"sec":%d,"nsec":%d},"estimator":' + orjson.dumps(name)
                + b',"x":%b,"y":%b,"heading":%b,"covariance":[%b],"particles":%d,"ess":%b}')
    cov = _numbers(tab.covariance.ravel())
    rows = [b",".join(cov[i:i + 9]) for i in range(0, len(cov), 9)]
    return [template % row for row in zip(
        *_stamps(tab.t_ns), _numbers(tab.x), _numbers(tab.y), _numbers(tab.heading), rows,
        tab.particles.tolist(), _numbers(tab.ess), strict=True)]


def _cloud_messages(clouds: Any) -> list[bytes]:
    """foxglove.PosesInFrame messages (JSON) of kept particle clouds ``(t_ns, x, y,
    heading)``."""
    import numpy as np
    import orjson

    from lgvtool.log.messages import FRAME_ID

    if not clouds:
        return []
    head = b'{"timestamp":{"sec":%d,"nsec":%d},"frame_id":' + orjson.dumps(FRAME_ID) \
        + b',"poses":['
    sizes = [len(c[1]) for c in clouds]
    half = 0.5 * np.concatenate([c[3] for c in clouds])
    cols = (_numbers(np.concatenate([c[1] for c in clouds])),
            _numbers(np.concatenate([c[2] for c in clouds])), _numbers(np.sin(half)),
            _numbers(np.cos(half)))
    # one pose: {"position":{"x":X,"y":Y,"z":0.0},"orientation":{"x":0.0,"y":0.0,"z":Z,"w":W}}
    glue = (b'{"position":{"x":', b',"y":', b',"z":0.0},"orientation":{"x":0.0,"y":0.0,"z":',
            b',"w":', b'}},')
    n = len(cols[0])
    parts: list[bytes] = [b""] * (9 * n)
    for j in range(4):
        parts[2 * j::9] = [glue[j]] * n
        parts[2 * j + 1::9] = cols[j]
    parts[8::9] = [glue[4]] * n
    secs, nsecs = _stamps([c[0] for c in clouds])
    out: list[bytes] = []
    at = 0
    for sec, nsec, k in zip(secs, nsecs, sizes, strict=True):
        body = b"".join(parts[9 * at:9 * (at + k)])[:-1] if k else b""
        out.append(head % (sec, nsec) + body + b"]}")
        at += k
    return out
