"""``lgvtool config``: print the defaults, or check a configuration file."""

from __future__ import annotations

import click


@click.command()
@click.argument("file", required=False, type=click.Path(dir_okay=False, path_type=str))
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of TOML.")
def config(file: str | None, as_json: bool) -> None:
    """Print the effective configuration: the defaults, or FILE (TOML) over them, checked.

    Units: lengths in m, angles in rad unless the key ends in _deg. See docs/config.md.
    """
    import json

    from lgvtool.config import load_config, to_toml
    from lgvtool.outputs import printable

    cfg = load_config(file)
    click.echo(json.dumps(cfg.to_dict(), indent=2) if as_json else printable(to_toml(cfg.to_dict())))
