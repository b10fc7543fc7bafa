"""``lgvtool view``: play a log to the live view (Foxglove WebSocket) at N x speed."""

from __future__ import annotations

import click

from lgvtool.options import Number, progress_option, seed_option, set_option, split_names, warn


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("--live", "live", metavar="[HOST:]PORT", default="127.0.0.1:8765",
              show_default=True,
              help="Serve on PORT over the Foxglove WebSocket protocol (host 127.0.0.1 unless "
                   "given; 0.0.0.0 for every interface).")
@click.option("--speed", type=Number(float, 0.0, 1e6), default=1.0, show_default=True,
              metavar="N", help="Play N times faster than recorded (0: as fast as possible).")
@click.option("--live-estimator", "live_estimators", multiple=True, metavar="NAME[,NAME]",
              help="Compute this estimate online while playing (repeatable or comma-separated): laser, "
                   "deadreckoning, ekf, pf-paper, pf. The log's own /estimate/NAME/* are then "
                   "not sent.")
@seed_option("Seed of the online estimators' random draws.")
@set_option("Online estimator parameter, e.g. pf.particles=500 (repeatable).")
@click.option("--wait", "wait_s", type=Number(float, 0.0, 3600.0), default=0.0,
              show_default=True, metavar="S",
              help="Wait S seconds after the server starts before playing (time to connect).")
@progress_option("Progress on stderr.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def view(log: str, live: str, speed: float, live_estimators: tuple[str, ...], seed: int,
         sets: tuple[str, ...], wait_s: float, show_progress: bool, as_json: bool) -> None:
    """Play LOG to a live view that Foxglove opens (Open connection, Foxglove WebSocket,
    ws://HOST:PORT): every channel of the log under its own topic, schema and JSON encoding,
    at the recorded pace times --speed, and the estimates of --live-estimator computed online
    as the recorder's --live does. Ctrl-C stops. See docs/live.md.
    """
    import json
    import signal
    import threading
    import warnings

    from lgvtool.config import parse_set_options
    from lgvtool.live.live_playback import play, prepare_channels
    from lgvtool.live.live_server import LiveServer, parse_address
    from lgvtool.live.online import OnlineEstimator
    from lgvtool.live.tap import LiveFeed, describe
    from lgvtool.localize.registry import check_names
    from lgvtool.log import LogReader, topics
    from lgvtool.progress import Progress

    address = parse_address(live)
    names = check_names(split_names(live_estimators))
    settings = parse_set_options(sets)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    for w in reader.warnings:
        warn(w)
    cfg = reader.config()
    estimators = [OnlineEstimator(n, cfg, seed=seed, settings=settings) for n in names]
    skip = frozenset(t for n in names for t in (topics.estimate_pose(n), topics.estimate_state(n),
                                                 topics.estimate_particles(n)))
    infos = reader.topics()
    starts = [i.start_ns for i in infos.values() if i.count]
    ends = [i.end_ns for i in infos.values() if i.count]
    span = (max(ends) - min(starts)) * 1e-9 if starts else 0.0
    server = LiveServer(address)
    prepare_channels(server, reader, skip)
    feed = LiveFeed(server, estimators,
                    warn=warn)
    stop = threading.Event()
    previous = signal.signal(signal.SIGINT, lambda *_: stop.set())
    click.echo(f"lgvtool: live view on {feed.server.url}: {log} ({span:.1f} s of data) at "
               f"{speed:g}x", err=True)
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
    if as_json:
        click.echo(json.dumps({"log": log, "messages": result.messages,
                               "log_seconds": round(result.log_seconds, 3),
                               "wall_seconds": round(result.wall_seconds, 3),
                               "stop_reason": result.stop_reason, "live": stats}, indent=2))
    else:
        click.echo(f"played {result.messages} messages, {result.log_seconds:.1f} s of data in "
                   f"{result.wall_seconds:.1f} s ({result.stop_reason})")
        click.echo(describe(stats), err=True)
