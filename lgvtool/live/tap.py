"""The live feed: every message the log writer writes, published as it is written, and the
online estimators fed from them on their own thread.

:class:`TappedLogWriter` is a :class:`lgvtool.log.LogWriter` that hands each message it writes
(topic, schema name, JSON bytes, log time) to a tap, after writing it: whatever channels the
writer puts in the log show live under the same topics, schemas and encoding. :class:`LiveFeed`
is the tap: it publishes on a :class:`lgvtool.live.live_server.LiveServer` and queues the
estimators' input topics for a worker thread, so neither a client nor a slow estimator ever
holds up the writer. When the estimators fall behind (a loaded machine), an observation that
has waited over :data:`MAX_LAG_S` while a newer one is queued is skipped, so the live estimate
stays current rather than complete (motion and the map are never skipped). A failure of the
live side is counted and reported, never raised into the recording.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import IO, Any, Protocol, TypedDict, Unpack

from lgvtool.live.drawing import INPUTS as DRAWN_FROM
from lgvtool.live.drawing import TOPICS as DRAWING_TOPICS
from lgvtool.live.drawing import LiveDrawing
from lgvtool.live.front import ClientCounts
from lgvtool.live.live_server import LiveServer
from lgvtool.live.online import INPUT_TOPICS, OnlineEstimator
from lgvtool.log import topics
from lgvtool.log.writer import LogWriter, WriterOptions

__all__ = ["LiveFeed", "LogTap", "TappedLogWriter", "latency_summary"]

_STOP = object()
#: an observation that waited longer than this (s) is dropped when a newer one is queued
MAX_LAG_S = 0.5
#: observations the estimators may shed; motion and the map are always applied
_SHEDDABLE = frozenset({topics.NAV_POSE, topics.NAV_REFLECTORS})


class LogTap(Protocol):
    """What receives each message a :class:`TappedLogWriter` writes."""

    def message(self, topic: str, schema: str, data: bytes, log_time_ns: int) -> None:
        """One message: topic, schema name, JSON bytes, log time (ns since the epoch)."""


class TappedLogWriter(LogWriter):
    """A log writer that also hands every message it writes to ``tap`` (after writing it).

    Takes the arguments of :class:`lgvtool.log.LogWriter`, plus ``tap``."""

    def __init__(self, path: str | Path | IO[bytes], *, tap: LogTap,
                 **kwargs: Unpack[WriterOptions]) -> None:
        self._tap = tap
        self._schema_of: dict[str, str] = {}
        super().__init__(path, **kwargs)

    def channel_id(self, topic: str, schema: str | None = None,
                   own: tuple[str, bytes] | None = None) -> int:
        cid = super().channel_id(topic, schema, own)
        if topic not in self._schema_of:
            self._schema_of[topic] = schema or topics.schema_for_topic(topic) or ""
        return cid

    def write_encoded(self, topic: str, data: bytes, log_time_ns: int,
                      publish_time_ns: int | None = None) -> None:
        super().write_encoded(topic, data, log_time_ns, publish_time_ns)
        self._tap.message(topic, self._schema_of[topic], data, int(log_time_ns))

    def write_encoded_many(self, topics: Sequence[str], datas: Sequence[bytes],
                           log_times_ns: Sequence[int]) -> None:
        if self._chunk_ns is not None:  # one by one, through write_encoded
            super().write_encoded_many(topics, datas, log_times_ns)
            return
        super().write_encoded_many(topics, datas, log_times_ns)
        for topic, data, t in zip(topics, datas, log_times_ns, strict=True):
            self._tap.message(topic, self._schema_of[topic], data, int(t))


class LiveStats(TypedDict):
    """A live view's figures (:meth:`LiveFeed.stats`): its URL, the messages published, the
    clients (None without a front), the estimators, their latencies (ms,
    :func:`latency_summary`) overall, per estimator and per update, the largest backlog, the
    observations shed and the live failures."""

    url: str
    published: int
    clients: ClientCounts | None
    estimators: list[str]
    latency: dict[str, float | int]
    latency_by_estimator: dict[str, dict[str, float | int]]
    update: dict[str, dict[str, float | int]]
    backlog_max: int
    shed: int
    failures: int


def latency_summary(seconds: Sequence[float]) -> dict[str, float | int]:
    """Count, median, 95th percentile and maximum of latencies given in s, in ms."""
    if not seconds:
        return {"count": 0}
    s = sorted(seconds)
    n = len(s)

    def q(f: float) -> float:
        return round(1e3 * s[min(n - 1, int(f * (n - 1) + 0.5))], 3)

    return {"count": n, "median_ms": q(0.5), "p95_ms": q(0.95), "max_ms": round(1e3 * s[-1], 3)}


class LiveFeed:
    """Publish log messages live and run online estimators beside the recording.

    :param server: where to publish.
    :param estimators: online estimators fed from the input topics, on one worker thread;
        their estimates are published (not written to the log).
    :param warn: called with one line when the live side fails (once per kind of failure).
    :param drawing: publishes what ``replay`` draws of the log's own data (``/nav/head``,
        ``/nav/tf``, ``/nav/scan``, ``/truth/tf``) as each NAV pose, scan and ground-truth pose
        passes, on the writer's thread (about 0.1 ms a message, 1 ms per second of a NAV200's
        traffic); None: nothing drawn (a log that holds its drawing already).
    """

    def __init__(self, server: LiveServer, estimators: Sequence[OnlineEstimator] = (), *,
                 warn: Callable[[str], None] | None = None, drawing: LiveDrawing | None = None
                 ) -> None:
        self.server = server
        self.estimators = list(estimators)
        server.prepare({t: topics.schema_for_topic(t) or "" for e in self.estimators
                        for t in e.output_topics})
        self._drawing = drawing
        if drawing is not None:
            server.prepare(DRAWING_TOPICS)
        self._warn = warn
        self._warned: set[str] = set()
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        #: s from a message reaching the feed to its estimate being published, per update
        self.latencies: list[float] = []
        #: the same per estimator name
        self.latency_of: dict[str, list[float]] = {e.name: [] for e in self.estimators}
        self.failures = 0
        #: observations skipped because the estimators were behind
        self.shed = 0
        self._newest_observation = -math.inf
        self.backlog_max = 0
        self._thread: threading.Thread | None = None
        if self.estimators:
            self._thread = threading.Thread(target=self._run, name="live-estimate", daemon=True)
            self._thread.start()

    def _fail(self, what: str, exc: BaseException) -> None:
        self.failures += 1
        if what not in self._warned and self._warn is not None:
            self._warned.add(what)
            self._warn(f"live view: {what} failed ({type(exc).__name__}: {exc}); "
                       f"the recording goes on")

    def message(self, topic: str, schema: str, data: bytes, log_time_ns: int) -> None:
        """Publish one message and queue it for the estimators (never raises, never blocks)."""
        try:
            self.server.publish(topic, schema, data, log_time_ns)
        except Exception as exc:
            self._fail("publishing", exc)
        if self._drawing is not None and topic in DRAWN_FROM:
            try:
                for m in self._drawing.feed(topic, data, log_time_ns):
                    self.server.publish(m.topic, m.schema, m.data, log_time_ns)
            except Exception as exc:
                self._fail("the drawing", exc)
        if self._thread is not None and topic in INPUT_TOPICS:
            now = time.perf_counter()
            if topic in _SHEDDABLE:
                self._newest_observation = now
            self._queue.put((topic, data, log_time_ns, now))

    def _run(self) -> None:
        while True:
            item = self._queue.get()
            if item is _STOP:
                return
            topic, data, t_ns, arrived = item
            if (topic in _SHEDDABLE and time.perf_counter() - arrived > MAX_LAG_S
                    and arrived < self._newest_observation):
                self.shed += 1
                continue
            for est in list(self.estimators):
                try:
                    outs = est.feed(topic, data, t_ns)
                    for o in outs:
                        self.server.publish(o.topic, o.schema, o.data, o.t_ns)
                except Exception as exc:
                    self._fail(f"estimator {est.name}", exc)
                    self.estimators.remove(est)
                    continue
                if outs:
                    lag = time.perf_counter() - arrived
                    self.latencies.append(lag)
                    self.latency_of[est.name].append(lag)

    def stats(self) -> LiveStats:
        """Published counts, estimator latency (ms), failures and the clients served and
        refused (:class:`lgvtool.live.front.FrontStats`), for the command's summary."""
        front = getattr(self.server, "front", None)
        return {"url": self.server.url, "published": sum(self.server.counts.values()),
                "clients": None if front is None else front.stats.as_dict(),
                "estimators": [e.name for e in self.estimators],
                "latency": latency_summary(self.latencies),
                "latency_by_estimator": {n: latency_summary(v)
                                         for n, v in self.latency_of.items()},
                "update": {e.name: latency_summary(e.update_seconds) for e in self.estimators},
                "backlog_max": self.backlog_max, "shed": self.shed, "failures": self.failures}

    def close(self, timeout: float = 5.0) -> None:
        """Let the estimators finish what is queued (at most ``timeout`` s), stop the server."""
        if self._thread is not None:
            self._queue.put(_STOP)
            self._thread.join(timeout)
            self._thread = None
        self.server.close()


def describe(stats: LiveStats) -> str:
    """One line for the terminal from :meth:`LiveFeed.stats`."""
    text = f"lgvtool: live view {stats['url']}: {stats['published']} messages published"
    lat = stats.get("latency", {})
    if lat.get("count"):
        text += (f"; estimate latency median {lat['median_ms']:.1f} ms, p95 {lat['p95_ms']:.1f} ms"
                 f" over {lat['count']} updates")
    clients = stats.get("clients")
    if clients and (clients.get("served") or clients.get("refused")):
        names = ", ".join(f"{n} {p}" for p, n in sorted(clients["by_subprotocol"].items()))
        n = clients["served"]
        text += f"; {n} client{'' if n == 1 else 's'} served ({names or 'none'})"
        if clients["refused"]:
            text += f", {clients['refused']} refused"
        if clients["stalled"]:
            text += f", {clients['stalled']} disconnected for not keeping up"
    if stats.get("shed"):
        text += f"; {stats['shed']} observations skipped to keep up"
    if stats.get("failures"):
        text += f"; {stats['failures']} live failures (the log is complete)"
    return text
