"""The same seed gives the same messages; the sample logs regenerate to the same messages."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from lgvtool.cli import main
from lgvtool.log import LogReader
from lgvtool.sim.logfile import write_log
from lgvtool.sim.run import simulate

SAMPLE_LOGS = Path(__file__).resolve().parents[2] / "sample_logs"


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    return [(m.topic, m.log_time_ns, m.data) for m in LogReader(path).raw_messages()]


def test_same_seed_same_messages(tmp_path: Path) -> None:
    a, b, c = tmp_path / "a.mcap", tmp_path / "b.mcap", tmp_path / "c.mcap"
    write_log(simulate("degraded", seed=7, duration=40.0), a)
    write_log(simulate("degraded", seed=7, duration=40.0), b, compression="none")
    write_log(simulate("degraded", seed=8, duration=40.0), c)
    assert _messages(a) == _messages(b)
    assert _messages(a) != _messages(c)
    assert LogReader(a).metadata["simulator"] == LogReader(b).metadata["simulator"]


def _commands() -> list[tuple[str, list[str]]]:
    readme = (SAMPLE_LOGS / "README.md").read_text(encoding="utf-8")
    out = []
    for line in readme.splitlines():
        line = line.strip().strip("`")
        if line.startswith("lgvtool simulate"):
            args = shlex.split(line)[1:]
            out.append((args[args.index("-o") + 1], args))
    return out


def test_readme_lists_both_sample_logs() -> None:
    names = {Path(o).name for o, _ in _commands()}
    assert {"paper-circle.mcap", "degraded.mcap"} <= names


@pytest.mark.parametrize("name", ["paper-circle.mcap", "degraded.mcap"])
def test_sample_logs_regenerate_to_the_same_messages(tmp_path: Path, name: str) -> None:
    committed = SAMPLE_LOGS / name
    if not committed.exists():
        pytest.skip(f"{committed} is not present")
    args = next(a for o, a in _commands() if Path(o).name == name)
    out = tmp_path / name
    args[args.index("-o") + 1] = str(out)
    main(args)
    assert _messages(out) == _messages(committed)
    assert LogReader(out).metadata["simulator"] == LogReader(committed).metadata["simulator"]
