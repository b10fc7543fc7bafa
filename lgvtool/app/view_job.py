"""Playing a log to the live view (Foxglove WebSocket) at N x speed (``lgvtool view``)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from lgvtool.app.job_output import JobOutput

if TYPE_CHECKING:
    from lgvtool.app.option_values import SettingValue
    from lgvtool.live.live_server import LiveAddress


def _ignore(text: str) -> None:
    """The default ``warn`` and ``notify`` of :func:`view_log`: the text is dropped."""


def _default_address() -> LiveAddress:
    """``--live``'s default: 127.0.0.1:8765."""
    from lgvtool.live.live_server import LiveAddress

    return LiveAddress()


@dataclass(frozen=True, slots=True)
class ViewOptions:
    """What :func:`view_log` plays, where and how fast (``lgvtool view``)."""

    log: str
    """The log (MCAP) to play."""
    live: LiveAddress = field(default_factory=_default_address)
    """The address the live view is served on (Foxglove WebSocket; port 0: any free one);
    default 127.0.0.1:8765."""
    speed: float = 1.0
    """Play this many times faster than recorded (0: as fast as possible)."""
    live_estimators: tuple[str, ...] = ()
    """Estimators computed online while playing; the log's own /estimate/NAME/* are then not
    sent."""
    seed: int = 0
    """Seed of the online estimators' random draws."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Online estimator settings (``pf.particles`` -> 500)."""
    wait_s: float = 0.0
    """Wait this many s after the server starts before playing (time to connect)."""
    show_progress: bool = True
    """Progress on stderr."""


def view_log(options: ViewOptions, *, warn: Callable[[str], None] = _ignore,
             notify: Callable[[str], None] = _ignore) -> JobOutput:
    """Serve the ``options``' log on their address over the Foxglove WebSocket protocol:
    every channel under its own topic, at the recorded pace times their speed (0: as fast as
    possible), after waiting their ``wait_s``, with the estimates of their live estimators
    computed online instead of the log's own (see :class:`ViewOptions`). Ctrl-C (SIGINT)
    stops the playing. ``warn`` receives the log's warnings, ``notify`` the line naming the
    server before playing starts.

    The document holds the messages sent, the s of log and of wall time, why playing stopped
    and the live view's figures; the text says the same in one line, the epilogue gives the
    live view's figures.

    :raises InputError: (exit 2) a bad estimator or setting, an unreadable log.
    """
    import signal
    import threading
    import warnings

    from lgvtool.live.drawing import TOPICS as DRAWING_TOPICS
    from lgvtool.live.drawing import drawing_of
    from lgvtool.live.live_playback import play, prepare_channels
    from lgvtool.live.live_server import LiveServer
    from lgvtool.live.online import OnlineEstimator
    from lgvtool.live.tap import LiveFeed, describe
    from lgvtool.localize.registry import check_names
    from lgvtool.log import LogReader, topics
    from lgvtool.log.schemas import schema_names
    from lgvtool.progress import Progress

    o = options
    log, speed = o.log, o.speed
    names = check_names(list(o.live_estimators))
    settings = dict(o.settings)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    for w in reader.warnings:
        warn(w)
    cfg = reader.config()
    estimators = [OnlineEstimator(n, cfg, seed=o.seed, settings=settings) for n in names]
    # the log's own channels of an estimator computed online are not sent: the online one is
    skip = frozenset(t for e in estimators for t in e.output_topics)
    infos = reader.topics()
    # the live view re-publishes a channel with lgvtool's copy of its schema (JSON): a channel
    # under a schema lgvtool does not have is left out, and said so
    known = set(schema_names())
    foreign = sorted(t for t, i in infos.items() if i.schema and i.schema not in known)
    for t in foreign:
        warn(f"{t} is not played: lgvtool has no schema named {infos[t].schema!r}")
    skip |= frozenset(foreign)
    starts = [i.start_ns for i in infos.values() if i.count]
    ends = [i.end_ns for i in infos.values() if i.count]
    span = (max(ends) - min(starts)) * 1e-9 if starts else 0.0
    server = LiveServer(o.live)
    prepare_channels(server, reader, skip)
    # a raw log drawn as replay draws it (a replayed log holds its own drawing); its scans on
    # the NAV's head, or on the truth's when it has no NAV poses (an imported dataset)
    drawing = None
    if not any(t in infos for t in DRAWING_TOPICS):
        on = "truth" if topics.NAV_POSE not in infos and topics.TRUTH in infos else "nav"
        drawing = drawing_of(cfg, scans_on=on)
    feed = LiveFeed(server, estimators, warn=warn, drawing=drawing)
    stop = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *_: stop.set())
    pace = f"at {speed:g}x" if speed > 0 else "as fast as possible"
    notify(f"lgvtool: live view on {feed.server.url}: {log} ({span:.1f} s of data) {pace}")
    bar = Progress(max(1, round(span)), "view", unit="s", enabled=o.show_progress)
    try:
        if o.wait_s > 0:
            stop.wait(o.wait_s)
        result = play(reader, feed, speed=speed, skip_topics=skip, stop=stop,
                      progress=lambda s: bar.set(round(s)))
    finally:
        signal.signal(signal.SIGINT, previous)
        bar.close()
        feed.close()
    stats = feed.stats()
    document = {"log": log, "messages": result.messages,
                "log_seconds": round(result.log_seconds, 3),
                "wall_seconds": round(result.wall_seconds, 3),
                "stop_reason": result.stop_reason, "live": stats}
    text = (f"played {result.messages} messages, {result.log_seconds:.1f} s of data in "
            f"{result.wall_seconds:.1f} s ({result.stop_reason})")
    return JobOutput(document, text, epilogue=describe(stats))
