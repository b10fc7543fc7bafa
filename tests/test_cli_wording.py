"""What the command line says, said one way: calibrate's refusal in one short line (details
with --json or LGVTOOL_DEBUG), recover's times as info prints them, shell completion of
estimator and scenario names, one vocabulary of metavars, one spelling of "localisation"."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import click
import pytest

from lgvtool.cli import cli, main

REPO = Path(__file__).resolve().parents[1]
SAMPLE = str(REPO / "sample_logs" / "paper-circle.mcap")


def _run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    capsys.readouterr()
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    out, err = capsys.readouterr()
    return code, out, err


# --------------------------------------------------------------------------- calibrate


def test_calibrate_refusal_is_one_short_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    """The sample log is one steady circle: it cannot tell the mounting, the wheels or the
    track. The line says what and what to do; the 1-sigma and the reasons come on request."""
    pytest.importorskip("scipy")
    monkeypatch.delenv("LGVTOOL_DEBUG", raising=False)
    out = tmp_path / "v.toml"
    argv = ["calibrate", SAMPLE, "-o", str(out), "--compare", "none", "--no-progress"]
    code, stdout, err = _run(argv, capsys)
    assert code == 2 and stdout == "" and err.count("\n") == 1
    message = err.removeprefix("lgvtool: error: ").strip()
    assert len(message) <= 200, message
    assert message.startswith("the drives cannot observe nav_x, nav_y, nav_yaw")
    assert "--fix" in message and "--allow-unobservable" in message and "--json" in message
    assert "1-sigma" not in message and not out.exists()

    code, stdout, err = _run([*argv, "--json"], capsys)
    assert code == 2 and err.count("\n") == 1
    doc = json.loads(stdout)
    assert doc["error"] == message and doc["exit_code"] == 2
    nav_x = doc["details"]["unobservable"]["nav_x"]
    assert nav_x["unit"] == "mm" and nav_x["sigma"] > 20.0 and "turning" in nav_x["needs"]
    assert nav_x["sigma_si"] == pytest.approx(nav_x["sigma"] / 1e3)

    monkeypatch.setenv("LGVTOOL_DEBUG", "1")
    code, _, err = _run(argv, capsys)
    lines = err.splitlines()
    assert code == 2 and lines[0] == f"lgvtool: error: {message}"
    assert any(re.fullmatch(r"lgvtool: detail: nav_x: 1-sigma [\d.]+ mm; needs turning.*", line)
               for line in lines[1:]), lines


# --------------------------------------------------------------------------- recover


def test_recover_prints_times_as_info_does(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(Path(SAMPLE).read_bytes()[:30000])
    fixed = tmp_path / "fixed.mcap"
    code, said, err = _run(["recover", str(cut), "-o", str(fixed)], capsys)
    assert code == 0, err
    times = [line for line in said.splitlines() if line.startswith("time:")]
    assert len(times) == 1
    assert re.fullmatch(r"time: +2024-01-01T00:00:00\.000Z \.\. 2024-01-01T00:00:0\d\.\d{3}Z "
                        r"\(\d+\.\d{3} s\)", times[0]), times
    assert "17040" not in said  # no raw Unix seconds
    code, info, _ = _run(["info", str(fixed)], capsys)
    assert code == 0 and times[0] in info.splitlines()  # the same line, by the same formatter
    code, doc, _ = _run(["recover", str(cut), "-o", str(fixed), "--force", "--json"], capsys)
    assert code == 0 and json.loads(doc)["first_s"] == 1704067200.0  # JSON: s, as info --json


# --------------------------------------------------------------------------- completion


def _complete(words: str) -> list[str]:
    """What bash completion offers for the last word of ``words`` (click's own machinery)."""
    parts = words.split(" ")
    env = dict(os.environ, _LGVTOOL_COMPLETE="bash_complete", COMP_WORDS=words,
               COMP_CWORD=str(len(parts) - 1))
    res = subprocess.run([sys.executable, "-m", "lgvtool"], env=env, capture_output=True,
                         text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    return [line.partition(",")[2] for line in res.stdout.splitlines()]


def test_shell_completion_of_estimators_and_scenarios() -> None:
    assert _complete("lgvtool replay x.mcap -e pf") == ["pf-paper", "pf"]
    assert _complete("lgvtool evaluate x.mcap --estimator ") == [
        "laser", "deadreckoning", "ekf", "pf-paper", "pf"]
    # after a comma: the list so far kept, names already in it not offered again
    assert _complete("lgvtool sweep x.mcap -e laser,pf-") == ["laser,pf-paper"]
    assert _complete("lgvtool export x.mcap -e laser,") == [
        "laser,deadreckoning", "laser,ekf", "laser,pf-paper", "laser,pf"]
    assert _complete("lgvtool simulate -s wa") == ["warehouse"]
    assert _complete("lgvtool simulate serve --scenario ") == [
        "paper-circle", "warehouse", "fast", "degraded"]
    assert _complete("lgvtool calibrate x.mcap --compare laser,ek") == ["laser,ekf"]


# --------------------------------------------------------------------------- metavars

#: commands whose options another part of the project words (evaluate, record, import ros2)
OTHERS = {"evaluate", "record", "import ros2"}

#: the one vocabulary of paths: FILE a file, DIR a directory, LOG an input log
PATH_METAVARS = {"FILE", "[FILE]", "DIR", "LOG", "[LOG]", "LOG...", "FILE|DIR", "LOG_OR_DIR..."}


def _commands(command: click.Command, path: tuple[str, ...], ctx: click.Context
              ) -> list[tuple[str, click.Command]]:
    """Every command under ``command`` but those of :data:`OTHERS` (not even imported)."""
    found = [(" ".join(path), command)] if path else []
    if isinstance(command, click.Group):
        for name in command.list_commands(ctx):
            if " ".join((*path, name)) in OTHERS:
                continue
            sub = command.get_command(ctx, name)
            assert sub is not None
            found += _commands(sub, (*path, name), ctx)
    return found


def test_paths_have_one_vocabulary() -> None:
    ctx = click.Context(cli, info_name="lgvtool")
    seen: dict[str, set[str]] = {}
    for name, command in _commands(cli, (), ctx):
        sub = click.Context(command, info_name=name)
        for param in command.params:
            if isinstance(param.type, click.Path):
                seen.setdefault(param.make_metavar(sub), set()).add(f"{name} {param.name}")
    assert set(seen) <= PATH_METAVARS, {k: v for k, v in seen.items() if k not in PATH_METAVARS}
    assert {"FILE", "DIR", "LOG"} <= set(seen)


# --------------------------------------------------------------------------- spelling

#: the American spelling (but "localize", the name of the package lgvtool.localize)
AMERICAN = re.compile(r"\blocaliz(ation|ations|er|ers|ed|es|ing)\b", re.IGNORECASE)
#: the MRCLAM dataset's published title keeps its own spelling
TITLE = re.compile(r"cooperative localization|^\W*localization and mapping dataset",
                   re.IGNORECASE)


def test_localisation_is_spelt_one_way() -> None:
    files = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md")),
             *sorted((REPO / "lgvtool").rglob("*.py"))]
    found = []
    for path in files:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if AMERICAN.search(line) and not TITLE.search(line):
                found.append(f"{path.relative_to(REPO)}:{number}: {line.strip()}")
    assert not found, "\n".join(found)
