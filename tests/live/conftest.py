"""Fixtures of the live-view tests: a short simulated log made in the test run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest


@pytest.fixture(scope="module")
def circle_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """30 s of the paper's circle drive, simulated now."""
    out = tmp_path_factory.mktemp("live") / "circle.mcap"
    subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "-s", "paper-circle",
                    "--duration", "30", "--set", "sim.paper_scans=true", "-o", str(out)],
                   check=True, capture_output=True, timeout=120)
    return out
