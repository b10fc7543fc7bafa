"""``lgvtool simulate``: a scenario into a log; subcommands (e.g. ``serve``, the device
emulators) are imported only when used."""

from __future__ import annotations

from typing import Any

import click

from lgvtool.lazy_group import LazyGroup
from lgvtool.options import (
    Number,
    compression_option,
    force_option,
    scenario_option,
    seed_option,
    set_option,
)
from lgvtool.values import MAX_SIM_DURATION_S

#: subcommand name -> (module, attribute, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str, str]] = {
    "serve": ("lgvtool.sim.emulate.serve", "serve",
              "Serve a scenario or a log as a virtual NAV200 and a virtual MCU."),
}


@click.group(cls=LazyGroup, lazy=SUBCOMMANDS, invoke_without_command=True)
@scenario_option("Scenario to simulate (see --list).")
@seed_option("Seed of every random draw; the same seed gives the same messages.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="Vehicle, area, reflector map and [simulator] settings (TOML).")
@set_option("Override a setting, e.g. nav.skew=false, nav.latency_s=0, "
            "vehicle.nav_x=0, scenario.speed=0.5 (repeatable; docs/simulator.md).")
@click.option("--duration", type=Number(float, 0.0, MAX_SIM_DURATION_S, min_open=True), metavar="S",
              help="Length of the run in s (circles: drive until then; default: the "
                   "scenario's own).")
@click.option("-o", "--output", type=click.Path(dir_okay=False), metavar="FILE",
              help="Log file (MCAP) to write.")
@compression_option()
@force_option
@click.option("--list", "list_scenarios", is_flag=True,
              help="Describe every scenario and its parameters, then exit.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary (or --list) as JSON.")
@click.pass_context
def simulate(ctx: click.Context, scenario: str | None, seed: int, config_path: str | None,
             sets: tuple[str, ...], duration: float | None, output: str | None,
             compression: str, list_scenarios: bool, as_json: bool, force: bool) -> None:
    """Simulate a laser-guided forklift in a reflector hall and write the log a recorder
    would have written: raw MCU and NAV200 traffic (/mcu/rx, /nav200/tx, /nav200/rx), the
    decoded frames and the NAV's poses (a NAV200 delivers nothing more; its reflector scans
    with sim.paper_scans=true, the paper's setup; a NAV350 with sim.nav_device=nav350, its
    landmarks too), the reflector map, the ground truth of O (/truth/pose), injected faults
    (/diagnostics) and every setting in the metadata.

    Positions in m, angles in rad inside the log; host times start at sim.start_epoch_s.
    Exit 2 for an unknown scenario or setting.
    """
    ctx.obj = {"scenario": scenario, "seed": seed, "config": config_path, "sets": sets,
               "duration": duration}
    if ctx.invoked_subcommand is not None:
        return
    import json

    from lgvtool.app.option_values import parse_settings
    from lgvtool.app.simulate_job import SimulateOptions, describe_scenarios, simulate_log
    from lgvtool.errors import InputError

    if list_scenarios:
        given = [name for name, v in (("--scenario", scenario), ("-o", output),
                                      ("--duration", duration), ("--config", config_path),
                                      ("--set", sets)) if v]
        if given:
            raise InputError(f"--list describes the scenarios and writes nothing; "
                             f"drop {', '.join(given)}")
        listing = describe_scenarios()
        click.echo(json.dumps(listing, indent=2) if as_json else _listing_text(listing))
        return
    if scenario is None:
        raise InputError("simulate needs --scenario NAME (see lgvtool simulate --list)")
    if output is None:
        raise InputError("simulate needs -o FILE, the log to write")
    result = simulate_log(SimulateOptions(
        scenario, output, seed=seed, config_path=config_path, settings=parse_settings(sets),
        duration=duration, compression=compression, force=force))
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    faults = ", ".join(f"{k} {v}" for k, v in result["faults"].items()) or "none"
    click.echo(f"wrote {output}: {scenario}, seed {seed}, {result['duration_s']:.1f} s, "
               f"{result['messages']} messages; injected faults: {faults}")


def _listing_text(listing: dict[str, Any]) -> str:
    """``simulate --list`` for the terminal: each scenario, its parameters and presets, then
    the installation errors."""
    lines: list[str] = []
    for name, sc in listing.items():
        if name == "installation":
            continue
        lines.append(name)
        lines.append(click.wrap_text(sc["description"], initial_indent="  ",
                                     subsequent_indent="  ", width=96))
        params = " ".join(f"{k}={v:g}" for k, v in sc["parameters"].items())
        lines.append(click.wrap_text(f"scenario.*: {params}", initial_indent="  ",
                                     subsequent_indent="    ", width=96))
        if sc["presets"]:
            presets = " ".join(f"{k}={_text(v)}" for k, v in sc["presets"].items())
            lines.append(click.wrap_text(f"presets: {presets}", initial_indent="  ",
                                         subsequent_indent="    ", width=96))
    lines.append("installation errors (--set; the log's configuration keeps the nominal "
                 "vehicle; docs/calibration.md)")
    for key, item in listing["installation"].items():
        lines.append(f"  {key}={_text(item['default'])}: {item['description']}")
    return "\n".join(lines)


def _text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return f"{value:g}" if isinstance(value, float) else str(value)

