"""``lgvtool layout``: reflector layout files (:mod:`lgvtool.app.layout_job`)."""

from __future__ import annotations

import click

from lgvtool.options import force_option, print_output


@click.group()
def layout() -> None:
    """Reflector layout files: lgvtool's [[reflectors]] TOML (a configuration file is one)
    and SICK's .imk layout files (SOPAS ET, SICK's NAV350 driver). See docs/config.md."""


@layout.command(short_help="Convert a layout file between lgvtool TOML and SICK .imk.")
@click.argument("source", metavar="FILE", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, metavar="FILE",
              type=click.Path(dir_okay=False, path_type=str),
              help="The layout file to write: .imk for SICK's format, else lgvtool's TOML.")
@click.option("--layer", type=click.IntRange(0, 255), default=None,
              help="Only the reflectors of this layer (default: all).")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def convert(source: str, output: str, layer: int | None, force: bool, as_json: bool) -> None:
    """Read the layout FILE (SICK .imk by its suffix, else TOML with [[reflectors]]: id, x, y
    m, radius m, layer) and write its reflectors to the -o FILE in the format its suffix names. .imk lines
    are 'globID x_mm y_mm type subtype size_mm layer...': the size (mm) is the reflector's
    diameter, a landmark's first layer is its layer, and type and subtype are written as 1."""
    from lgvtool.app.layout_job import LayoutConvertOptions, convert_layout

    print_output(convert_layout(LayoutConvertOptions(source, output, layer=layer, force=force)),
                 as_json)
