"""``lgvtool recover``: a complete, indexed log from a broken one."""

from __future__ import annotations

import click

from lgvtool.options import compression_option, force_option, print_output


@click.command()
@click.argument("broken", metavar="LOG", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The recovered log to write.")
@compression_option()
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def recover(broken: str, output: str, compression: str, force: bool, as_json: bool) -> None:
    """Write every intact message of LOG (a log cut off by a crash, power loss or a full
    disk) into a complete, indexed log FILE (-o), and say how much was saved and the time it
    spans (ISO-8601 UTC, as info prints it)."""
    from lgvtool.app.recover_job import RecoverOptions, recover_log

    print_output(recover_log(RecoverOptions(broken, output, compression=compression,
                                            force=force)), as_json)
