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


def test_only_the_process_entry_spares_its_exit_the_final_collection(monkeypatch) -> None:
    """``main()`` run as the process (no argv) freezes the objects left once its command has
    ended, on success and on failure alike, so the interpreter's last collection skips them;
    ``main(argv)`` run inside another program (these tests) leaves its collector alone."""
    import gc

    from lgvtool.cli import main

    frozen: list[int] = []
    monkeypatch.setattr(gc, "freeze", lambda: frozen.append(1))
    monkeypatch.setattr(sys, "argv", ["lgvtool", "--version"])
    main()
    assert frozen == [1]
    monkeypatch.setattr(sys, "argv", ["lgvtool", "frobnicate"])
    with pytest.raises(SystemExit) as exc:
        main()
    assert exc.value.code == 2 and frozen == [1, 1]
    main(["--version"])
    with pytest.raises(SystemExit):
        main(["frobnicate"])
    assert frozen == [1, 1]
