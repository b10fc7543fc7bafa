"""``benchmarks/mrclam_global.py`` (docs/mrclam.md "Global localisation of `pf`") runs on the
synthetic dataset of ``conftest.py``: one run from a uniform start gives the time to localise,
the wrong-lock flag and the error trace, and the table reads them (no real data needed)."""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType
from typing import Any

from benchmark_modules import benchmark


def _global() -> ModuleType:
    """``benchmarks/mrclam_global.py``."""
    return benchmark("mrclam_global")


def test_a_global_run_and_its_table(synthetic: Any, tmp_path: Path) -> None:
    from lgvtool.importers.mrclam_log import import_robot

    m = _global()
    log = tmp_path / "r1.mcap"
    import_robot(synthetic.root, 1, log)
    run = m.global_run(log, 0, 20.0, {"pf.start_particles": 0, "pf.particles": 200})
    assert set(run) >= {"localised_s", "wrong_lock", "final_error_m", "trace"}
    assert run["trace"] and math.isfinite(run["final_error_m"])
    errors = [e for _, e, _ in run["trace"]]
    assert run["final_error_m"] == errors[-1]
    table = m.global_table(synthetic.root, [1], 1, 20.0, tmp_path / "cache",
                           {"pf.start_particles": 0, "pf.particles": 200})
    assert "| Robot1 |" in table
