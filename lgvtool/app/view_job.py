"""Playing a log to the live view (Foxglove WebSocket) at N x speed (``lgvtool view``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from lgvtool.app.job_output import JobOutput


def _ignore(text: str) -> None:
    """The default ``warn`` and ``notify`` of :func:`view_log`: the text is dropped."""


def view_log(log: str, *, live: str = "127.0.0.1:8765", speed: float = 1.0,
             live_estimators: Sequence[str] = (), seed: int = 0, sets: Sequence[str] = (),
             wait_s: float = 0.0, show_progress: bool = True,
             warn: Callable[[str], None] = _ignore,
             notify: Callable[[str], None] = _ignore) -> JobOutput:
    """Serve ``log`` on ``live`` (``[HOST:]PORT``) over the Foxglove WebSocket protocol: every
    channel under its own topic, at the recorded pace times ``speed`` (0: as fast as
    possible), after waiting ``wait_s`` s, with the estimates of ``live_estimators`` computed
    online (``seed``, ``KEY=VALUE`` settings ``sets``) instead of the log's own. Ctrl-C
    (SIGINT) stops the playing. ``warn`` receives the log's warnings, ``notify`` the line
    naming the server before playing starts.

    The document holds the messages sent, the s of log and of wall time, why playing stopped
    and the live view's figures; the text says the same in one line, the epilogue gives the
    live view's figures.

    :raises InputError: (exit 2) a bad address, estimator or setting, an unreadable log.
    """
    import signal
    import threading
    import warnings

    from lgvtool.config import parse_set_options
    from lgvtool.live.drawing import TOPICS as DRAWING_TOPICS
    from lgvtool.live.drawing import drawing_of
    from lgvtool.live.live_playback import play, prepare_channels
    from lgvtool.live.live_server import LiveServer, parse_address
    from lgvtool.live.online import OnlineEstimator
    from lgvtool.live.tap import LiveFeed, describe
    from lgvtool.localize.registry import check_names
    from lgvtool.log import LogReader, topics
    from lgvtool.log.schemas import schema_names
    from lgvtool.progress import Progress

    address = parse_address(live)
    names = check_names(list(live_estimators))
    settings = parse_set_options(list(sets))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    for w in reader.warnings:
        warn(w)
    cfg = reader.config()
    estimators = [OnlineEstimator(n, cfg, seed=seed, settings=settings) for n in names]
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
    server = LiveServer(address)
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
    bar = Progress(max(1, round(span)), "view", unit="s", enabled=show_progress)
    try:
        if wait_s > 0:
            stop.wait(wait_s)
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
