"""Describing a log (``lgvtool info``): its topics, rates, gaps and metadata, or what any
other MCAP file holds."""

from __future__ import annotations

from lgvtool.app.job_output import JobOutput


def describe_log(log: str) -> JobOutput:
    """Describe ``log``: per topic its schema, message count, mean rate (Hz), first and last
    time, largest gap (s); the metadata; whether the file was complete or salvaged. An MCAP
    file that is not an lgvtool log (a ROS 2 bag) is described by its topics, schemas,
    encodings and counts. The warnings are the corrupt chunks met in reading.

    :raises LogFormatError: (exit 2) the file is not an MCAP file.
    """
    import warnings

    from lgvtool.errors import LogFormatError
    from lgvtool.log import LogReader
    from lgvtool.log.inspect import describe, format_text
    from lgvtool.outputs import printable

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            reader = LogReader(log)
            summary = describe(reader)
    except LogFormatError as exc:
        if "not an lgvtool log" not in str(exc):
            raise
        from lgvtool.log.any_mcap import describe_any, format_any

        foreign = describe_any(log)  # an MCAP file of another tool: show what it holds
        return JobOutput(foreign, printable(format_any(foreign)))
    return JobOutput(summary, printable(format_text(summary)), warnings=list(reader.warnings))
