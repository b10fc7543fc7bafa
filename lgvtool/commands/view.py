"""``lgvtool view``: play a log to the live view (Foxglove WebSocket) at N x speed
(:func:`lgvtool.app.view_job.view_log`)."""

from __future__ import annotations

import click

from lgvtool.options import (
    Number,
    print_output,
    progress_option,
    seed_option,
    set_option,
    split_names,
    warn,
)


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
    from lgvtool.app.option_values import parse_live_address, parse_settings
    from lgvtool.app.view_job import ViewOptions, view_log

    print_output(view_log(ViewOptions(
        log, parse_live_address(live), speed=speed,
        live_estimators=tuple(split_names(live_estimators, "--live-estimator")), seed=seed,
        settings=parse_settings(sets), wait_s=wait_s, show_progress=show_progress),
        warn=warn, notify=lambda line: click.echo(line, err=True)), as_json)
