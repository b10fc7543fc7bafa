"""Simulated drives with known installation errors, shared by the calibration tests."""

from __future__ import annotations

from pathlib import Path

import pytest
from calibrate_cases import ERRORS

from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate


@pytest.fixture(scope="session")
def installed_logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """A 70 s circle drive and a 110 s warehouse drive of a vehicle with :data:`ERRORS`."""
    out = tmp_path_factory.mktemp("calibrate")
    paths = []
    for scenario, seed, duration in (("paper-circle", 11, 70.0), ("warehouse", 12, 110.0)):
        sim = simulate(scenario, seed=seed, duration=duration, overrides=ERRORS)
        path = out / f"{scenario}.mcap"
        write_log(sim, path)
        paths.append(path)
    return paths
