"""The same seed gives the same messages; the sample logs regenerate to the same messages.

On one machine the same seed gives the same log bit for bit. Across processors the last bits of
vectorised trigonometry differ (numpy picks SIMD kernels per CPU), so the regenerated sample
logs are compared field by field: topics, log times, integers, strings, raw bytes and
timestamps exactly, floats to a relative 1e-9 (and 1e-12 absolute near zero).
"""

from __future__ import annotations

import json
import math
import shlex
from pathlib import Path
from typing import Any

import pytest

from lgvtool.cli import main
from lgvtool.log import LogReader
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate

SAMPLE_LOGS = Path(__file__).resolve().parents[2] / "sample_logs"


REL = 1e-9
"""Relative tolerance of floats regenerated on another processor."""
ABS = 1e-12
"""Absolute tolerance of floats near zero (m, rad, s)."""


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    return [(m.topic, m.log_time_ns, m.data) for m in LogReader(path).raw_messages()]


def _differences(a: Any, b: Any, where: str = "") -> list[str]:
    """Where two decoded JSON values differ: anything but floats exactly, floats to REL/ABS."""
    if isinstance(a, float) or isinstance(b, float):
        if not (isinstance(a, float) and isinstance(b, float)):
            return [f"{where}: {a!r} != {b!r}"]
        if math.isnan(a) and math.isnan(b):
            return []
        return [] if math.isclose(a, b, rel_tol=REL, abs_tol=ABS) else [f"{where}: {a!r} != {b!r}"]
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return [f"{where}: keys {sorted(a)} != {sorted(b)}"]
        return [d for k in a for d in _differences(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: {len(a)} items != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b, strict=True))
                for d in _differences(x, y, f"{where}[{i}]")]
    return [] if (type(a) is type(b) and a == b) else [f"{where}: {a!r} != {b!r}"]


def _same_log(out: Path, committed: Path) -> list[str]:
    """Differences between the messages and the simulator metadata of two logs (see above)."""
    got, want = _messages(out), _messages(committed)
    if len(got) != len(want):
        return [f"{len(got)} messages != {len(want)}"]
    diffs: list[str] = []
    for i, ((t1, n1, d1), (t2, n2, d2)) in enumerate(zip(got, want, strict=True)):
        if (t1, n1) != (t2, n2):
            diffs.append(f"message {i}: {t1} at {n1} != {t2} at {n2}")
        elif d1 != d2:
            diffs.extend(_differences(json.loads(d1), json.loads(d2), f"message {i} {t1}"))
        if len(diffs) > 5:
            break
    meta = (LogReader(out).metadata["simulator"], LogReader(committed).metadata["simulator"])
    return diffs + _differences(*meta, "metadata simulator")


def test_the_comparison_tolerates_last_bits_and_nothing_more() -> None:
    x = {"t": {"sec": 3, "nsec": 5}, "r": 12.345678901234, "ids": [1, 2], "s": "a"}
    last_bits = {**x, "r": 12.345678901234 * (1 + 3e-15)}
    assert _differences(x, last_bits) == []
    assert _differences(x, {**x, "r": 12.3457}) != []
    assert _differences(x, {**x, "t": {"sec": 3, "nsec": 6}}) != []
    assert _differences(x, {**x, "ids": [1, 3]}) != []
    assert _differences(x, {**x, "s": "b"}) != []
    assert _differences({"v": 1}, {"v": 1.0}) != []  # an integer field stays an integer


def test_same_seed_same_messages(tmp_path: Path) -> None:
    # on one machine: bit for bit
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


def test_readme_lists_every_sample_log() -> None:
    names = {Path(o).name for o, _ in _commands()}
    assert {"paper-circle.mcap", "degraded.mcap", "warehouse-nav350.mcap"} <= names


@pytest.mark.parametrize("name", ["paper-circle.mcap", "degraded.mcap", "warehouse-nav350.mcap"])
def test_sample_logs_regenerate_to_the_same_messages(tmp_path: Path, name: str) -> None:
    committed = SAMPLE_LOGS / name
    if not committed.exists():
        pytest.skip(f"{committed} is not present")
    args = next(a for o, a in _commands() if Path(o).name == name)
    out = tmp_path / name
    args[args.index("-o") + 1] = str(out)
    main(args)
    assert _same_log(out, committed) == []
