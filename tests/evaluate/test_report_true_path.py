"""The report says how far the true path departs from the reference circle, a real figure on
the honest world's sample log, and the verdict says which observations the paper's setup used."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from inprocess import run_command

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "paper-circle.mcap"


def test_the_report_gives_the_true_paths_departure(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_command(capsys, "evaluate", SAMPLE, "-e", "laser,ekf", "-o",
                                 tmp_path / "rep")
    assert code == 0, err
    html = (tmp_path / "rep" / "report.html").read_text(encoding="utf-8")
    found = re.search(r"true path departs from that circle by ([0-9.]+) mm RMS", html)
    assert found is not None
    assert 3.0 <= float(found.group(1)) <= 30.0  # the drive model's departure, not 0.00
    # the verdict names the observations: the paper's setup, not a NAV200 recording's
    assert "NAV200 scans (the paper's setup)" in out
