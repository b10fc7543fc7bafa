"""``lgvtool decode``: re-decode the raw device traffic of a log into fresh decoded channels
(:func:`lgvtool.app.decode_job.decode_file`)."""

from __future__ import annotations

import click

from lgvtool.options import compression_option, force_option, print_output


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=str),
    help="The re-decoded log to write (must differ from LOG).",
)
@compression_option()
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the counts as JSON.")
def decode(log: str, output: str, compression: str, force: bool, as_json: bool) -> None:
    """Re-decode the raw traffic of LOG (/mcu/rx, /nav200/tx, /nav200/rx, /nav350/tx,
    /nav350/rx) into fresh /mcu/frame, /nav/pose, /nav/reflectors and /diagnostics channels
    in the log FILE (-o), copying every other channel and the metadata; print the frames decoded and the
    error counts per device (bad checksums, bad lengths, skipped bytes, truncated frames,
    sequence gaps, NAV200 error replies, ...).

    Use it after a decoder fix: raw bytes are always logged, so nothing is lost.
    """
    from lgvtool.app.decode_job import DecodeOptions, decode_file

    print_output(decode_file(DecodeOptions(log, output, compression=compression, force=force)),
                 as_json)
