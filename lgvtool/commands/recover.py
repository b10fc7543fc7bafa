"""``lgvtool recover``: a complete, indexed log from a broken one."""

from __future__ import annotations

import click


@click.command()
@click.argument("broken", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The recovered log to write.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def recover(broken: str, output: str, as_json: bool) -> None:
    """Write every intact message of BROKEN (a log cut off by a crash, power loss or a full
    disk) into a complete, indexed log, and say how much was saved."""
    import warnings

    from lgvtool.log.salvage import recover as do_recover
    from lgvtool.log.salvage import report_json

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        report = do_recover(broken, output)
    click.echo(report_json(report) if as_json else report.summary())
