"""``lgvtool info``: what a log holds."""

from __future__ import annotations

import click


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON (stable keys, docs/log-format.md).")
def info(log: str, as_json: bool) -> None:
    """Summarise LOG: per topic its schema, message count, mean rate (Hz), first and last
    time, largest gap (s); the metadata; whether the file was complete or salvaged."""
    import json
    import warnings

    from lgvtool.log import LogReader
    from lgvtool.log.inspect import describe, format_text

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
        summary = describe(reader)  # its corrupt-chunk warnings are printed below
    if as_json:
        click.echo(json.dumps(summary, indent=2))
    else:
        for w in reader.warnings:
            click.echo(f"lgvtool: warning: {w}", err=True)
        click.echo(format_text(summary))
