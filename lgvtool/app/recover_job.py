"""Recovering a broken log (``lgvtool recover``)."""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.app.job_output import JobOutput


@dataclass(frozen=True, slots=True)
class RecoverOptions:
    """What :func:`recover_log` recovers, and into what (``lgvtool recover``)."""

    broken: str
    """The log cut off by a crash, power loss or a full disk."""
    output: str
    """The complete, indexed log to write (through a temporary file); an existing one is
    replaced only with :attr:`force`, an input never."""
    compression: str = "zstd"
    """Chunk compression of :attr:`output`: zstd, lz4 or none."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def recover_log(options: RecoverOptions) -> JobOutput:
    """Write every intact message of the ``options``' broken log into its output, a
    complete, indexed log (see :class:`RecoverOptions`). The document is the recovery report
    (messages and bytes saved, what was lost), the text its summary and the time span of what
    was saved, in ISO-8601 UTC as ``lgvtool info`` prints it.

    :raises InputError: (exit 2) nothing can be read from the broken log, or a refused output.
    """
    import warnings

    from lgvtool.log import salvage
    from lgvtool.outputs import atomic_output, guard_output

    guard_output(options.output, [options.broken], force=options.force)
    with warnings.catch_warnings(), atomic_output(options.output) as tmp:
        warnings.simplefilter("ignore")
        report = salvage.recover(options.broken, tmp, compression=options.compression)
    return JobOutput(report.__dict__, report.summary() + _time_line(report.first_s, report.last_s))


def _time_line(first_s: float | None, last_s: float | None) -> str:
    """The recovered messages' time span as ``lgvtool info`` prints a log's: ISO-8601 UTC by
    info's own formatter (the JSON keeps ``first_s``/``last_s`` in s since the Unix epoch, as
    ``info --json`` keeps ``start_time_s``); empty when nothing was recovered."""
    if first_s is None or last_s is None:
        return ""
    from lgvtool.log.inspect import _iso

    return (f"\ntime:      {_iso(int(first_s * 1e9))} .. {_iso(int(last_s * 1e9))} "
            f"({last_s - first_s:.3f} s)")
