"""Simulations and logs shared by the simulator tests (each built once per session)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import Simulation, simulate


@pytest.fixture(scope="session")
def sim_cache() -> Callable[..., Simulation]:
    """``get(scenario, seed=0, **overrides)``: a cached simulation."""
    cache: dict[tuple[Any, ...], Simulation] = {}

    def get(scenario: str, seed: int = 0, duration: float | None = None,
            **overrides: Any) -> Simulation:
        key = (scenario, seed, duration, tuple(sorted(overrides.items())))
        if key not in cache:
            cache[key] = simulate(scenario, seed=seed, duration=duration, overrides=overrides)
        return cache[key]

    return get


@pytest.fixture(scope="session")
def log_cache(tmp_path_factory: pytest.TempPathFactory,
              sim_cache: Callable[..., Simulation]) -> Callable[..., Path]:
    """``get(scenario, seed=0, **overrides)``: the path of a cached simulated log."""
    cache: dict[tuple[Any, ...], Path] = {}
    folder = tmp_path_factory.mktemp("simlogs")

    def get(scenario: str, seed: int = 0, **overrides: Any) -> Path:
        key = (scenario, seed, tuple(sorted(overrides.items())))
        if key not in cache:
            path = folder / f"log{len(cache)}.mcap"
            write_log(sim_cache(scenario, seed, **overrides), path)
            cache[key] = path
        return cache[key]

    return get
