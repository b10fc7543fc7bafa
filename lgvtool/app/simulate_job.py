"""Simulating a scenario into a log (``lgvtool simulate``), and the scenarios there are."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypedDict

if TYPE_CHECKING:
    from lgvtool.app.option_values import SettingValue


@dataclass(frozen=True, slots=True)
class SimulateOptions:
    """What :func:`simulate_log` simulates, and into what (``lgvtool simulate``)."""

    scenario: str
    """The scenario to simulate (``lgvtool simulate --list``)."""
    output: str
    """The log (MCAP) to write (through a temporary file); an existing one is replaced only
    with :attr:`force`."""
    seed: int = 0
    """Seed of every random draw; the same seed gives the same messages."""
    config_path: str | None = None
    """Vehicle, area, reflector map and [simulator] settings (TOML); None: the defaults."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Setting overrides (``nav.latency_s`` -> 0, ``scenario.speed`` -> 0.5; docs/simulator.md)."""
    duration: float | None = None
    """Length of the run, s of simulated time; None: the scenario's own."""
    compression: str = "zstd"
    """Chunk compression of :attr:`output`: zstd, lz4 or none."""
    force: bool = False
    """Replace an existing :attr:`output`."""


class SimulatedLog(TypedDict):
    """What :func:`simulate_log` wrote: the output, scenario and seed, ``duration_s`` (s of
    simulated time), ``messages`` written and ``faults`` (injected fault kind -> count)."""

    output: str
    scenario: str
    seed: int
    duration_s: float
    messages: int
    faults: dict[str, int]


def simulate_log(options: SimulateOptions) -> SimulatedLog:
    """Simulate the ``options``' scenario and write the log a recorder would have written into
    its output (see :class:`SimulateOptions`).

    Returns output, scenario, seed, ``duration_s`` (s of simulated time), ``messages`` written
    and ``faults`` (injected fault kind -> count).

    :raises InputError: (exit 2) an unknown scenario or setting, or a refused output.
    """
    from lgvtool.config import load_config
    from lgvtool.outputs import atomic_output, guard_output
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    o = options
    guard_output(o.output, [o.config_path], force=o.force)
    config = load_config(o.config_path)
    sim = simulate(o.scenario, seed=o.seed, config=config, overrides=dict(o.settings),
                   duration=o.duration)
    with atomic_output(o.output) as tmp:
        summary = write_log(sim, tmp, compression=o.compression)
    return {"output": o.output, "scenario": o.scenario, "seed": o.seed,
            "duration_s": summary.duration_s, "messages": summary.messages,
            "faults": summary.faults}


def describe_scenarios() -> dict[str, Any]:
    """Every scenario (name -> description, ``parameters``: the ``scenario.*`` settings with
    their defaults, ``presets``: the settings it changes), and under ``installation`` every
    installation error the simulator can add (key -> default and description)."""
    from lgvtool.sim.scenarios import SCENARIOS
    from lgvtool.sim.settings import INSTALLATION, SimSettings, setting_value

    nominal = SimSettings()
    listing: dict[str, Any] = {name: {"description": sc.description,
                                      "parameters": dict(sc.defaults),
                                      "presets": dict(sc.presets)}
                               for name, sc in SCENARIOS.items()}
    listing["installation"] = {k: {"default": setting_value(nominal, k), "description": d}
                               for k, d in INSTALLATION.items()}
    return listing
