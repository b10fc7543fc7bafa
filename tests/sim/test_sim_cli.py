"""``lgvtool simulate`` on the command line."""

from __future__ import annotations

from pathlib import Path

import click

from lgvtool.commands.simulate import simulate


def test_simulate_is_a_group_that_runs_without_a_subcommand() -> None:
    assert isinstance(simulate, click.Group)
    assert simulate.invoke_without_command


def test_list_describes_every_scenario(run_cli) -> None:
    out = run_cli("simulate", "--list")
    assert out.returncode == 0, out.stderr
    for name in ("paper-circle", "warehouse", "fast", "degraded"):
        assert f"{name}\n" in out.stdout


def test_bad_input_is_one_line_and_exit_2(run_cli, tmp_path: Path) -> None:
    out_file = tmp_path / "x.mcap"
    for args in (["--scenario", "nope", "-o", out_file],
                 ["--scenario", "paper-circle", "--set", "nav.nope=1", "-o", out_file],
                 ["--scenario", "paper-circle", "--set", "vehicle.nope=1", "-o", out_file],
                 ["--scenario", "paper-circle", "--set", "novalue", "-o", out_file],
                 ["--scenario", "paper-circle"]):
        out = run_cli("simulate", *args)
        assert out.returncode == 2, (args, out.stderr)
        assert len(out.stderr.strip().splitlines()) == 1, out.stderr
        assert "Traceback" not in out.stderr


def test_simulate_writes_a_log(run_cli, tmp_path: Path) -> None:
    out_file = tmp_path / "w.mcap"
    out = run_cli("simulate", "--scenario", "warehouse", "--seed", "3", "--duration", "30",
                  "--set", "nav.latency_s=0.02", "-o", out_file)
    assert out.returncode == 0, out.stderr
    assert out_file.exists() and "wrote" in out.stdout
    info = run_cli("info", out_file, "--json")
    assert '"/truth/pose"' in info.stdout and '"/nav/pose"' in info.stdout
    # a NAV200 delivers poses only: its reflector scans are the paper's setup, asked for
    assert '"/nav/reflectors"' not in info.stdout


def test_help_stays_light() -> None:
    import subprocess
    import sys

    code = ("import sys\nfrom lgvtool.cli import main\ntry:\n    main(['simulate', '--help'])\n"
            "except SystemExit:\n    pass\n"
            "print('HEAVY', [m for m in ('numpy', 'mcap', 'pandas') if m in sys.modules])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60)
    assert "HEAVY []" in out.stdout, out.stdout + out.stderr
