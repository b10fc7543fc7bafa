"""The command line: light start-up, one-line errors, exit codes."""

from __future__ import annotations

import subprocess
import sys

import pytest

from lgvtool.cli import COMMANDS

HEAVY = ("numpy", "pandas", "plotly", "dask", "distributed", "pyarrow", "serial", "mcap")


@pytest.mark.parametrize("args", [["--help"], ["--version"]])
def test_help_and_version_import_nothing_heavy(args: list[str]) -> None:
    code = (
        "import sys\n"
        "from lgvtool.cli import main\n"
        "try:\n"
        f"    main({args!r})\n"
        "except SystemExit:\n"
        "    pass\n"
        f"heavy = [m for m in {HEAVY!r} if m in sys.modules]\n"
        "print('HEAVY', heavy)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "HEAVY []" in out.stdout, out.stdout + out.stderr


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_command_has_help(name: str, run_cli) -> None:
    out = run_cli(name, "--help")
    assert out.returncode == 0, out.stderr
    assert "Usage:" in out.stdout


def test_unknown_command_and_option_are_one_line_exit_2(run_cli) -> None:
    out = run_cli("frobnicate")
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and "No such command" in out.stderr
    out = run_cli("info", "--bogus", "x.mcap")
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and "bogus" in out.stderr
