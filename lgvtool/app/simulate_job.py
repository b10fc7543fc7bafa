"""Simulating a scenario into a log (``lgvtool simulate``), and the scenarios there are."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any


def simulate_log(scenario: str, output: str, *, seed: int = 0, config_path: str | None = None,
                 sets: Sequence[str] = (), duration: float | None = None,
                 compression: str = "zstd", force: bool = False) -> dict[str, Any]:
    """Simulate ``scenario`` with ``seed`` and write the log a recorder would have written
    into ``output`` (through a temporary file; an existing one is replaced only with
    ``force``). ``config_path``: vehicle, area, reflector map and [simulator] settings (TOML);
    ``sets``: ``KEY=VALUE`` overrides (``nav.latency_s=0``, ``scenario.speed=0.5``);
    ``duration``: length of the run, s (default: the scenario's own).

    Returns output, scenario, seed, ``duration_s`` (s of simulated time), ``messages`` written
    and ``faults`` (injected fault kind -> count).

    :raises InputError: (exit 2) an unknown scenario or setting, or a refused output.
    """
    from lgvtool.config import load_config, parse_set_options
    from lgvtool.outputs import atomic_output, guard_output
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    guard_output(output, [config_path], force=force)
    config = load_config(config_path)
    overrides = parse_set_options(list(sets))
    sim = simulate(scenario, seed=seed, config=config, overrides=overrides, duration=duration)
    with atomic_output(output) as tmp:
        summary = write_log(sim, tmp, compression=compression)
    return {"output": output, "scenario": scenario, "seed": seed,
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
