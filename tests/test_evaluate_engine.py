"""`lgvtool evaluate LOG...` over several logs runs on the fleet engine (a local Dask cluster)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

SAMPLE_LOGS = Path(__file__).resolve().parent.parent / "sample_logs"



def test_several_logs_on_the_engine_match_one_at_a_time(tmp_path: Path, run_cli) -> None:
    a, b = tmp_path / "a.mcap", tmp_path / "b.mcap"
    shutil.copy(SAMPLE_LOGS / "paper-circle.mcap", a)
    shutil.copy(SAMPLE_LOGS / "degraded.mcap", b)
    both = run_cli("evaluate", a, b, "-e", "laser", "-e", "ekf", "--workers", "2", "--json",
                   timeout=400)
    assert both.returncode == 0, both.stderr
    doc = json.loads(both.stdout)
    per_log = {d["log"]["name"]: d for d in doc["per_log"]}
    for path in (a, b):
        one = run_cli("evaluate", path, "-e", "laser", "-e", "ekf", "--json", timeout=400)
        assert one.returncode == 0, one.stderr
        single = json.loads(one.stdout)
        for name in ("laser", "ekf"):
            # a worker may run on another processor: the same figure to its last bits
            assert (per_log[path.stem]["estimators"][name]["circle"]["rmse_mm"]
                    == pytest.approx(single["estimators"][name]["circle"]["rmse_mm"], rel=1e-9))


def test_a_bad_log_among_several_is_one_line_exit_2(tmp_path: Path, run_cli) -> None:
    good = tmp_path / "good.mcap"
    shutil.copy(SAMPLE_LOGS / "paper-circle.mcap", good)
    bad = tmp_path / "bad.mcap"
    bad.write_text("not a log\n")
    out = run_cli("evaluate", good, bad, "-e", "laser", "--workers", "1", timeout=400)
    assert out.returncode == 2
    errors = [line for line in out.stderr.splitlines() if "error" in line]
    assert errors == [f"lgvtool: error: {bad}: not an MCAP file"], out.stderr
