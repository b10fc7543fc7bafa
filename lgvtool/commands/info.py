"""``lgvtool info``: what a log holds."""

from __future__ import annotations

import click

from lgvtool.options import warn


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON (stable keys, docs/log-format.md).")
def info(log: str, as_json: bool) -> None:
    """Summarise LOG: per topic its schema, message count, mean rate (Hz), first and last
    time, largest gap (s); the metadata; whether the file was complete or salvaged.

    Any other MCAP file (a ROS 2 bag, a protobuf recording) is described too: its topics,
    schemas, encodings and message counts, and that it is not an lgvtool log (exit 0)."""
    import json
    import warnings

    from lgvtool.errors import LogFormatError
    from lgvtool.log import LogReader
    from lgvtool.log.inspect import describe, format_text
    from lgvtool.outputs import printable

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = LogReader(log)
            summary = describe(reader)  # its corrupt-chunk warnings are printed below
    except LogFormatError as exc:
        if "not an lgvtool log" not in str(exc):
            raise
        from lgvtool.log.any_mcap import describe_any, format_any

        foreign = describe_any(log)  # an MCAP file of another tool: show what it holds
        click.echo(json.dumps(foreign, indent=2) if as_json else printable(format_any(foreign)))
        return
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        for w in reader.warnings:
            warn(w)
        click.echo(printable(format_text(summary)))
