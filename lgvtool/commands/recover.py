"""``lgvtool recover``: a complete, indexed log from a broken one."""

from __future__ import annotations

import click

from lgvtool.options import compression_option, force_option


@click.command()
@click.argument("broken", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The recovered log to write.")
@compression_option()
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def recover(broken: str, output: str, compression: str, force: bool, as_json: bool) -> None:
    """Write every intact message of BROKEN (a log cut off by a crash, power loss or a full
    disk) into a complete, indexed log, and say how much was saved."""
    import warnings

    from lgvtool.log.salvage import recover as do_recover
    from lgvtool.log.salvage import report_json
    from lgvtool.outputs import atomic_output, guard_output

    guard_output(output, [broken], force=force)
    with warnings.catch_warnings(), atomic_output(output) as tmp:
        warnings.simplefilter("ignore")
        report = do_recover(broken, tmp, compression=compression)
    click.echo(report_json(report) if as_json else report.summary())
