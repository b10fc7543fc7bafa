"""Recovering a broken log (``lgvtool recover``)."""

from __future__ import annotations

from lgvtool.app.job_output import JobOutput


def recover_log(broken: str, output: str, *, compression: str = "zstd",
                force: bool = False) -> JobOutput:
    """Write every intact message of ``broken`` (a log cut off by a crash, power loss or a
    full disk) into ``output``, a complete, indexed log (through a temporary file; an existing
    one is replaced only with ``force``, an input never). The document is the recovery report
    (messages and bytes saved, what was lost), the text its summary.

    :raises InputError: (exit 2) nothing can be read from ``broken``, or a refused output.
    """
    import warnings

    from lgvtool.log import salvage
    from lgvtool.outputs import atomic_output, guard_output

    guard_output(output, [broken], force=force)
    with warnings.catch_warnings(), atomic_output(output) as tmp:
        warnings.simplefilter("ignore")
        report = salvage.recover(broken, tmp, compression=compression)
    return JobOutput(report.__dict__, report.summary())
