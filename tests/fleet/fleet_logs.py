"""Small simulated logs and a Dask-friendly way to define task functions in tests."""

from __future__ import annotations

import sys
from pathlib import Path

import cloudpickle

from lgvtool.sim import simulate, write_log

DURATION_S = 14.0
"""Length of each test log, s: short, so a replay takes a fraction of a second."""


def make_log(path: Path, seed: int, duration_s: float = DURATION_S) -> Path:
    """Simulate the paper's circle drive for ``duration_s`` into ``path``."""
    write_log(simulate("paper-circle", seed=seed, duration=duration_s), path)
    return path


def make_corrupt_log(path: Path, size: int = 4096) -> Path:
    """A file named like a log whose bytes are not MCAP."""
    path.write_bytes(bytes((i * 7919) % 251 for i in range(size)))
    return path


def ship_by_value(module_name: str) -> None:
    """Let Dask workers (fresh processes that cannot import a test module) receive the
    functions of ``module_name`` by value."""
    cloudpickle.register_pickle_by_value(sys.modules[module_name])
