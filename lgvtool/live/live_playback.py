"""Play a log to the live server at N x speed (``lgvtool view LOG --live``).

Messages go out in log-time order, each when ``(log time - first log time) / speed`` of wall
time has passed (``speed`` 0: as fast as they can be sent), through the same
:class:`lgvtool.live.tap.LiveFeed` the recorder uses, so a log shows as it did live, online
estimates included. The data's time is broadcast to clients ten times a second.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.live.live_server import LiveServer
    from lgvtool.live.tap import LiveFeed
    from lgvtool.log import LogReader

__all__ = ["PlayResult", "play", "prepare_channels"]

#: how often the data's time is broadcast, wall s
_TIME_PERIOD_S = 0.1


@dataclass(frozen=True)
class PlayResult:
    """What a playback sent: messages, log time covered (s), wall time taken (s), why it
    ended."""

    messages: int
    log_seconds: float
    wall_seconds: float
    stop_reason: str


def prepare_channels(server: LiveServer, reader: LogReader,
                     skip_topics: frozenset[str] = frozenset()) -> None:
    """Advertise every channel of the log (but ``skip_topics``) before playing it."""
    server.prepare({t: i.schema for t, i in reader.topics().items() if t not in skip_topics})


def play(reader: LogReader, feed: LiveFeed, *, speed: float = 1.0,
         skip_topics: frozenset[str] = frozenset(), stop: threading.Event | None = None,
         progress: Callable[[float], None] | None = None,
         clock: Callable[[], float] = time.monotonic) -> PlayResult:
    """Send every message of ``reader`` (except ``skip_topics``) to ``feed`` at ``speed`` x
    real time (0: no waiting) until the end or until ``stop`` is set.

    ``progress`` is called with the log time played so far (s after the first message)."""
    if speed < 0:
        raise ValueError("speed must be >= 0")
    stop = stop or threading.Event()
    start = clock()
    first: int | None = None
    last = 0
    n = 0
    next_tick = start
    reason = "end of log"
    for m in reader.raw_messages():
        if m.topic in skip_topics:
            continue
        t = m.log_time_ns
        if first is None:
            first = t
        if speed > 0:
            due = start + (t - first) * 1e-9 / speed
            while True:
                now = clock()
                if stop.is_set() or now >= due:
                    break
                stop.wait(min(due - now, _TIME_PERIOD_S))
                if clock() >= next_tick:
                    next_tick = clock() + _TIME_PERIOD_S
                    feed.server.broadcast_time(max(last, first))
        if stop.is_set():
            reason = "stopped"
            break
        feed.message(m.topic, m.schema, m.data, t)
        last = max(last, t)
        n += 1
        now = clock()
        if now >= next_tick:
            next_tick = now + _TIME_PERIOD_S
            feed.server.broadcast_time(t)
            if progress is not None:
                progress((t - first) * 1e-9)
    span = 0.0 if first is None else (last - first) * 1e-9
    if progress is not None:
        progress(span)
    return PlayResult(n, span, clock() - start, reason)
