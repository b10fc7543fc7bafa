"""Short simulated logs for tests that need real traffic (built in the test, never the
sample logs)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def simulate_log(path: Path, duration: float, seed: int, scenario: str = "paper-circle") -> Path:
    """Simulate ``scenario`` for ``duration`` s into ``path`` with ``lgvtool simulate``."""
    subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario", scenario,
                    "--duration", str(duration), "--seed", str(seed), "-o", str(path)],
                   check=True, capture_output=True)
    return path
