"""``lgvtool simulate``: a scenario into a log; subcommands (e.g. ``serve``, the device
emulators) are imported only when used."""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

import click

from lgvtool.options import Number, compression_option, force_option, seed_option, set_option
from lgvtool.values import MAX_SIM_DURATION_S

#: subcommand name -> (module, attribute, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str, str]] = {
    "serve": ("lgvtool.sim.emulate.serve", "serve",
              "Serve a scenario or a log as a virtual NAV200 and a virtual MCU."),
}


class LazySubcommands(click.Group):
    """A group whose subcommands are imported only when they run (``--help`` stays light).

    A subcommand whose module is not installed is not offered.
    """

    def _available(self) -> list[str]:
        # look for the module's file rather than import its packages: help stays instant
        root = Path(__file__).resolve().parent.parent.parent
        return sorted(name for name, (module, _, _) in SUBCOMMANDS.items()
                      if (root / (module.replace(".", "/") + ".py")).is_file())

    def list_commands(self, ctx: click.Context) -> list[str]:
        return self._available()

    def get_command(self, ctx: click.Context, cmd_name: str) -> click.Command | None:
        if cmd_name not in self._available():
            return None
        module, attribute, _ = SUBCOMMANDS[cmd_name]
        command = getattr(importlib.import_module(module), attribute)
        assert isinstance(command, click.Command)
        return command

    def format_commands(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        rows = [(name, SUBCOMMANDS[name][2]) for name in self._available()]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


@click.group(cls=LazySubcommands, invoke_without_command=True)
@click.option("--scenario", "-s", metavar="NAME",
              help="Scenario to simulate (see --list).")
@seed_option("Seed of every random draw; the same seed gives the same messages.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="Vehicle, area, reflector map and [simulator] settings (TOML).")
@set_option("Override a setting, e.g. nav.skew=false, nav.latency_s=0, "
            "vehicle.nav_x=0, scenario.speed=0.5 (repeatable; docs/simulator.md).")
@click.option("--duration", type=Number(float, 0.0, MAX_SIM_DURATION_S, min_open=True), metavar="S",
              help="Length of the run in s (circles: drive until then; default: the "
                   "scenario's own).")
@click.option("-o", "--output", type=click.Path(dir_okay=False), metavar="OUT.mcap",
              help="Log file to write.")
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
    decoded frames and poses, the head's reflector scans, the reflector map, the ground truth
    of O (/truth/pose), injected faults (/diagnostics) and every setting in the metadata.

    Positions in m, angles in rad inside the log; host times start at sim.start_epoch_s.
    Exit 2 for an unknown scenario or setting.
    """
    ctx.obj = {"scenario": scenario, "seed": seed, "config": config_path, "sets": sets,
               "duration": duration}
    if ctx.invoked_subcommand is not None:
        return
    import json

    from lgvtool.errors import InputError

    if list_scenarios:
        given = [name for name, v in (("--scenario", scenario), ("-o", output),
                                      ("--duration", duration), ("--config", config_path),
                                      ("--set", sets)) if v]
        if given:
            raise InputError(f"--list describes the scenarios and writes nothing; "
                             f"drop {', '.join(given)}")
        from lgvtool.sim.scenarios import SCENARIOS
        from lgvtool.sim.settings import INSTALLATION, SimSettings, setting_value

        nominal = SimSettings()
        if as_json:
            listing: dict[str, Any] = {name: {"description": sc.description,
                                              "parameters": dict(sc.defaults),
                                              "presets": dict(sc.presets)}
                                       for name, sc in SCENARIOS.items()}
            listing["installation"] = {k: {"default": setting_value(nominal, k),
                                           "description": d} for k, d in INSTALLATION.items()}
            click.echo(json.dumps(listing, indent=2))
            return
        for name, sc in SCENARIOS.items():
            click.echo(name)
            click.echo(click.wrap_text(sc.description, initial_indent="  ",
                                       subsequent_indent="  ", width=96))
            params = " ".join(f"{k}={v:g}" for k, v in sc.defaults.items())
            click.echo(click.wrap_text(f"scenario.*: {params}", initial_indent="  ",
                                       subsequent_indent="    ", width=96))
            if sc.presets:
                presets = " ".join(f"{k}={_text(v)}" for k, v in sc.presets.items())
                click.echo(click.wrap_text(f"presets: {presets}", initial_indent="  ",
                                           subsequent_indent="    ", width=96))
        click.echo("installation errors (--set; the log's configuration keeps the nominal "
                   "vehicle; docs/calibration.md)")
        for key, meaning in INSTALLATION.items():
            click.echo(f"  {key}={_text(setting_value(nominal, key))}: {meaning}")
        return
    if scenario is None:
        raise InputError("simulate needs --scenario NAME (see lgvtool simulate --list)")
    if output is None:
        raise InputError("simulate needs -o OUT.mcap")

    from lgvtool.config import load_config, parse_set_options
    from lgvtool.outputs import atomic_output, guard_output
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate as run_simulation

    guard_output(output, [config_path], force=force)
    config = load_config(config_path)
    overrides = parse_set_options(sets)
    sim = run_simulation(scenario, seed=seed, config=config, overrides=overrides,
                         duration=duration)
    with atomic_output(output) as tmp:
        summary = write_log(sim, tmp, compression=compression)
    result = {"output": output, "scenario": scenario, "seed": seed,
              "duration_s": summary.duration_s, "messages": summary.messages,
              "faults": summary.faults}
    if as_json:
        click.echo(json.dumps(result, indent=2))
        return
    faults = ", ".join(f"{k} {v}" for k, v in summary.faults.items()) or "none"
    click.echo(f"wrote {output}: {scenario}, seed {seed}, {summary.duration_s:.1f} s, "
               f"{summary.messages} messages; injected faults: {faults}")


def _text(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    return f"{value:g}" if isinstance(value, float) else str(value)

