"""``lgvtool simulate serve``: a virtual NAV200 and a virtual MCU (and a NAV350) for ``lgvtool
record``; each device family's port option comes from its emulation
(:mod:`lgvtool.sim.emulate.emulator_registry`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

import click

from lgvtool.options import Number, force_option, positive, scenario_option, set_option
from lgvtool.sim.emulate.emulator_registry import emulations
from lgvtool.values import MAX_SEED, MAX_SIM_DURATION_S, MAX_WALL_S

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.emulator_server import Fault

F = TypeVar("F", bound=Callable[..., object])


def _port_options(f: F) -> F:
    """Every registered device family's ``serve`` port option, in the order the ports are
    listed."""
    for e in reversed(emulations()):
        o = e.SERVE_OPTION
        f = click.option(o.flag, o.param, default=o.default, show_default=True,
                         metavar=o.metavar, help=o.help)(f)
    return f


@click.command()
@click.argument("log", required=False, type=click.Path(dir_okay=False, exists=True))
@scenario_option("Simulate this scenario and serve it (default when no LOG: paper-circle).")
@click.option("--seed", type=Number(int, 0, MAX_SEED),
              help="Seed of the scenario and of injected garbage.")
@click.option("--duration", type=positive(MAX_SIM_DURATION_S), metavar="S",
              help="Length of the simulated run, s.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False), metavar="FILE",
              help="Vehicle, reflector map and [simulator] settings (TOML) of the scenario.")
@set_option("Override a simulator setting (repeatable), as for 'lgvtool simulate'.")
@click.option("--speed", type=positive(1000.0), default=1.0,
              show_default=True, metavar="N", help="Play N times faster than real time.")
@_port_options
@click.option("--pty-dir", type=click.Path(file_okay=False, exists=True), metavar="DIR",
              help="Put the pseudo-terminal links here (default: a new temporary folder).")
@click.option("--fault", "faults", multiple=True, metavar="SPEC",
              help="Inject a fault at a run time, s (repeatable): drop:DEVICE:AT:SECONDS, "
                   "silent:DEVICE:AT:SECONDS, garbage:DEVICE:AT:BYTES, reset:nav200:AT; "
                   "NAV350: sfa:nav350:AT[:CODE], error:nav350:AT:SECONDS[:CODE], "
                   "badsum:nav350:AT:COUNT; DEVICE is nav200, nav350, mcu or all.")
@click.option("--transcript", type=click.Path(dir_okay=False), metavar="FILE",
              help="Write every byte the devices send and receive as JSON lines.")
@click.option("--loop", is_flag=True, help="Play the run over and over.")
@click.option("--start-now", is_flag=True,
              help="Start the run's clock at once instead of when the clients have connected.")
@force_option
@click.option("--exit-after", type=Number(float, 0.0, MAX_WALL_S), metavar="S",
              help="Exit S seconds (wall clock) after the run has been played "
                   "(default: serve until Ctrl-C).")
@click.pass_context
def serve(ctx: click.Context, /, log: str | None, scenario: str | None, seed: int | None,
          duration: float | None, config_path: str | None, sets: tuple[str, ...],
          speed: float, pty_dir: str | None, faults: tuple[str, ...], transcript: str | None,
          loop: bool, start_now: bool, force: bool, exit_after: float | None,
          **ports: str) -> None:
    """Serve a run as devices for 'lgvtool record': a virtual NAV200 that answers the host
    protocol (modes, identity, the map upload, error replies to requests in the wrong mode)
    and a virtual MCU that streams its frames, over pseudo-terminals or TCP.

    Plays LOG (its /mcu/rx bytes and /nav/pose poses), or simulates --scenario. Prints one
    line per device, 'nav200: URL' and 'mcu: URL', to pass to 'lgvtool record --nav URL
    --mcu URL'. Times of --fault and --duration are run time, s. See docs/recording.md.
    """

    from lgvtool.errors import InputError

    group: dict[str, Any] = ctx.obj if isinstance(ctx.obj, dict) else {}
    scenario = scenario or group.get("scenario")
    seed = seed if seed is not None else int(group.get("seed") or 0)
    duration = duration if duration is not None else group.get("duration")
    config_path = config_path or group.get("config")
    sets = sets or tuple(group.get("sets") or ())
    if log is not None and scenario is not None:
        raise InputError("serve: give a LOG or --scenario, not both")
    if transcript is not None:
        from lgvtool.outputs import guard_output

        guard_output(transcript, [log, config_path], force=force, what="transcript")
    from lgvtool.sim.emulate.emulator_server import parse_fault

    fault_list = [parse_fault(f) for f in faults]
    playback = _playback(log, scenario or "paper-circle", seed, duration, config_path, sets)
    if transcript is None:
        _serve(playback, ports, pty_dir, speed, fault_list, start_now, loop, None, seed,
               exit_after)
        return
    from lgvtool.outputs import atomic_output

    with atomic_output(transcript) as tmp:
        _serve(playback, ports, pty_dir, speed, fault_list, start_now, loop, str(tmp), seed,
               exit_after)


def _serve(playback: Playback, ports: dict[str, str], pty_dir: str | None, speed: float,
           fault_list: list[Fault], start_now: bool, loop: bool, transcript: str | None,
           seed: int, exit_after: float | None) -> None:
    """Serve ``playback`` on the families' ``ports`` (by parameter name; 'none': not served)
    until it is played (``exit_after``) or stopped; print the counts."""
    import signal

    from lgvtool.json_types import member
    from lgvtool.sim.emulate.emulator_server import EmulatorServer

    server = EmulatorServer(playback, link_dir=pty_dir, speed=speed, faults=fault_list,
                            wait=not start_now, loop=loop, transcript=transcript, seed=seed,
                            **{name: None if spec == "none" else spec
                               for name, spec in ports.items()})
    try:
        for name, ep in server.endpoints.items():
            click.echo(f"{name}: {ep.url}")
        for name, ep in server.endpoints.items():
            click.echo(f"  {name} is {ep.describe()}")
        start = "now" if start_now else "when the recorder connects"
        click.echo(f"serving {playback.source}: {playback.duration:.1f} s at {speed:g}x, "
                   f"starting {start}{', looping' if loop else ''}; Ctrl-C to stop")
        old = {sig: signal.signal(sig, lambda *_: server.request_stop())
               for sig in (signal.SIGINT, signal.SIGTERM)}
        try:
            server.run(until=exit_after)
        finally:
            for sig, handler in old.items():
                signal.signal(sig, handler)
        status = server.status()
        parts = [f"{n}: sent {member(status[n], 'sent_bytes')} B, received "
                 f"{member(status[n], 'received_bytes')} B, "
                 f"{member(status[n], 'connections')} connection(s)" for n in server.endpoints]
        click.echo("; ".join(parts) + f"; {status['faults']} fault(s) injected")
    finally:
        server.close()


def _playback(log: str | None, scenario: str, seed: int, duration: float | None,
              config_path: str | None, sets: tuple[str, ...]) -> Playback:
    from lgvtool.sim.emulate.emulator_playback import playback_from_log, playback_from_scenario

    if log is not None:
        return playback_from_log(log)
    from lgvtool.config import load_config, parse_set_options

    return playback_from_scenario(scenario, seed=seed, duration=duration,
                                  config=load_config(config_path),
                                  overrides=parse_set_options(sets))
