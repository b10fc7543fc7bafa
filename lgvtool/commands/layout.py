"""``lgvtool layout``: reflector layout files (:mod:`lgvtool.app.layout_job`)."""

from __future__ import annotations

import click

from lgvtool.options import force_option, print_output, set_option, split_names


@click.group()
def layout() -> None:
    """Reflector layout files: lgvtool's [[reflectors]] TOML (a configuration file is one)
    and SICK's .imk layout files (SOPAS ET, SICK's NAV350 driver), and the layout corrected
    from drives. See docs/config.md and docs/audit.md."""


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


@layout.command(short_help="Correct the layout from drives (least squares, NAV350 landmarks).")
@click.argument("logs", nargs=-1, required=True, metavar="LOG...",
                type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, metavar="FILE",
              type=click.Path(dir_okay=False, path_type=str),
              help="The refined layout file to write: lgvtool's [[reflectors]] TOML (.imk: "
              "SICK's).")
@click.option("--fix", metavar="ID,...", help="Layout ids held at their surveyed positions "
              "(comma-separated).")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              metavar="FILE", help="Layout, vehicle and motion noise (default: each log's "
              "stored configuration; the layout: the first log's).")
@set_option("Setting of the adjustment, e.g. survey_sigma_m=0.01 (repeatable; "
            "docs/audit.md lists them).")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def refine(logs: tuple[str, ...], output: str, fix: str | None, config_path: str | None,
           sets: tuple[str, ...], force: bool, as_json: bool) -> None:
    """Adjust the reflector layout to one or more NAV350 LOG... (odometry and every landmark
    observation, the surveyed layout as a prior of survey_sigma_m per axis, the --fix
    reflectors held) by a sparse least squares, print each reflector's refined position,
    shift and 1-sigma (mm), and write the refined layout to FILE (-o). Needs scipy (the
    calibrate extra). Exit 2 for a log without landmarks (a NAV200 recording), an unknown
    --fix id or an output that is an input."""
    from lgvtool.app.layout_job import LayoutRefineOptions, refine_layout
    from lgvtool.app.option_values import parse_settings

    print_output(refine_layout(LayoutRefineOptions(
        tuple(logs), output, fix=_ids(fix), config_path=config_path,
        settings=parse_settings(sets), force=force)), as_json)


def _ids(text: str | None) -> tuple[int, ...]:
    """``--fix 3,7`` -> (3, 7).

    :raises InputError: (exit 2) an empty or non-integer id.
    """
    from lgvtool.errors import InputError

    out = []
    for name in split_names([text], "--fix") if text is not None else []:
        try:
            out.append(int(name))
        except ValueError:
            raise InputError(f"--fix {name!r} is not a reflector id (an integer)") from None
    return tuple(out)
