"""A short simulated circle drive shared by the interop tests (built once per session)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate

DURATION_S = 45.0
"""Long enough for one complete rotation of the paper's circle after the standstill."""


@pytest.fixture(scope="session")
def sim_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A simulated paper-circle drive: MCU, NAV200 poses, reflector scans, truth."""
    path = tmp_path_factory.mktemp("interop") / "drive.mcap"
    write_log(simulate("paper-circle", seed=3, duration=DURATION_S,
                             overrides={"sim.paper_scans": True}), path)
    return path


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str, str]]:
    """``cli(*args)``: run ``lgvtool ARGS`` in this process -> (exit code, stdout, stderr)."""
    from inprocess import run_command

    def run(*args: object) -> tuple[int, str, str]:
        return run_command(capsys, *args)

    return run
