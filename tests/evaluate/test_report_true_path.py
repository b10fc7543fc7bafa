"""The report says how far the true path departs from the reference circle, a real figure on
the honest world's sample log, and the verdict and the tables say which observations the paper's
setup used."""

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
    # the verdict and every table name the observations: the paper's setup, not a NAV200
    # recording's
    assert "NAV200 scans (the paper's setup)" in out
    note = "Observations: ekf weighed the NAV200's reflector scans of the paper's setup"
    assert note in (tmp_path / "rep" / "table1.md").read_text(encoding="utf-8")
    assert "the paper's setup" in (tmp_path / "rep" / "table1.tex").read_text(encoding="utf-8")
    assert "Observations: ekf weighed" in out
