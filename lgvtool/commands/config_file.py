"""``lgvtool config``: print the defaults, check a configuration file, or print a log's."""

from __future__ import annotations

import click

from lgvtool.options import print_output


@click.command()
@click.argument("file", required=False, type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of TOML.")
def config(file: str | None, as_json: bool) -> None:
    """Print the effective configuration: the defaults, or FILE (TOML) over them, checked;
    when FILE is a log (MCAP), the one its replay uses (stored in it, else the defaults with
    its reflector map), in the form --config takes: lgvtool config run.mcap > run.toml.

    Units: lengths in m, angles in rad unless the key ends in _deg. See docs/config.md.
    """
    from lgvtool.app.config_job import effective_config

    print_output(effective_config(file), as_json)
