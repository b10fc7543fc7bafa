"""``lgvtool config``: print the defaults, check a configuration file, or print a log's."""

from __future__ import annotations

import click

from lgvtool.options import print_output


@click.command()
@click.argument("file", required=False, type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of TOML.")
@click.option("--parameters", is_flag=True,
              help="Print every setting of the configuration, the estimators and the simulator "
                   "with its default, unit, range and meaning.")
@click.option("--markdown", is_flag=True, help="With --parameters: as the docs' tables.")
def config(file: str | None, as_json: bool, parameters: bool, markdown: bool) -> None:
    """Print the effective configuration: the defaults, or FILE (TOML) over them, checked;
    when FILE is a log (MCAP), the one its replay uses (stored in it, else the defaults with
    its reflector map), in the form --config takes: lgvtool config run.mcap > run.toml.

    Units: lengths in m, angles in rad unless the key ends in _deg. See docs/config.md.

    --parameters lists every setting instead: the keys of the configuration's tables, of
    --set for the estimators (pf.particles) and the simulator (nav.sigma_range_mm).
    """
    from lgvtool.errors import InputError

    if markdown and not parameters:
        raise click.UsageError("--markdown goes with --parameters")
    if parameters:
        if file is not None:
            raise InputError("--parameters lists the settings of every configuration: give no "
                             "FILE")
        from lgvtool.app.config_job import parameters as listing

        print_output(listing(markdown), as_json)
        return
    from lgvtool.app.config_job import effective_config

    print_output(effective_config(file), as_json)
