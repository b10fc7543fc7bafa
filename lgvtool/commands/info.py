"""``lgvtool info``: what a log holds."""

from __future__ import annotations

import click

from lgvtool.options import print_output


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON (stable keys, docs/log-format.md).")
def info(log: str, as_json: bool) -> None:
    """Summarise LOG: per topic its schema, message count, mean rate (Hz), first and last
    time, largest gap (s); the metadata; whether the file was complete or salvaged.

    Any other MCAP file (a ROS 2 bag, a protobuf recording) is described too: its topics,
    schemas, encodings and message counts, and that it is not an lgvtool log (exit 0)."""
    from lgvtool.app.info_job import describe_log

    print_output(describe_log(log), as_json)
