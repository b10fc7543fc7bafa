"""``replay`` encodes what it adds one window of log time at a time: the output does not
depend on the window, and ``LogWriter.copy_from`` merges batches taken as it reaches them."""

from __future__ import annotations

import subprocess
import sys
from itertools import pairwise
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from click.testing import CliRunner

from lgvtool.commands.replay import replay
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log import windows as W
from lgvtool.log.foxglove import pose_in_frame_many

T0 = 1_700_000_000_000_000_000


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("windowed")
    p = subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "-s", "paper-circle",
                        "--duration", "20", "--set", "sim.paper_scans=true", "-o",
                        str(d / "sim.mcap")],
                       capture_output=True, text=True, timeout=300, check=False)
    assert p.returncode == 0, p.stderr
    return d / "sim.mcap"


def _replay(sim: Path, out: Path, window_ns: int, monkeypatch: pytest.MonkeyPatch,
            *extra: str) -> list[tuple[str, int, bytes]]:
    batches: list[int] = []
    real_iter = W.WindowedMerge.__iter__

    def counting(self: W.WindowedMerge):  # type: ignore[no-untyped-def,unused-ignore]
        for b in real_iter(self):
            batches.append(len(b[2]))
            yield b

    monkeypatch.setattr(W, "WINDOW_NS", window_ns)
    monkeypatch.setattr(W.WindowedMerge, "__iter__", counting)
    res = CliRunner().invoke(replay, [str(sim), "-o", str(out), "--particles", "100",
                                      "--no-progress", *extra])
    assert res.exit_code == 0, res.output
    monkeypatch.undo()
    msgs = [(m.topic, m.log_time_ns, m.data) for m in LogReader(out).raw_messages()]
    _replay.batches = batches  # type: ignore[attr-defined]
    return msgs


@pytest.mark.parametrize("view", ["--view", "--no-view"])
def test_windowed_output_is_the_one_window_output(sim: Path, tmp_path: Path, view: str,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    whole = _replay(sim, tmp_path / "whole.mcap", 10**18, monkeypatch, view)
    assert len(_replay.batches) == 1  # type: ignore[attr-defined]
    # 0.7 s windows: cut through every stream, many windows without a scan or a cloud
    small = _replay(sim, tmp_path / "small.mcap", 700_000_000, monkeypatch, view)
    assert len(_replay.batches) > 20  # type: ignore[attr-defined]
    assert len(small) == len(whole)
    for i, (a, b) in enumerate(zip(small, whole, strict=True)):
        assert a == b, f"message {i} differs: {a[:2]} vs {b[:2]}"
    added = {t for t, _n, _d in whole} - set(LogReader(sim).topics())
    assert topics.estimate_pose("pf") in added
    assert (topics.NAV_SCAN in added) == (view == "--view")
    times = [n for _t, n, _d in small]
    assert times == sorted(times)


def _pose_batch(t: list[int]) -> tuple[list[str], list[bytes], list[int]]:
    z = np.zeros(len(t))
    return [topics.estimate_pose("pf")] * len(t), pose_in_frame_many(t, z, z, z), t


def test_copy_from_merges_batches_as_one_sorted_extra(tmp_path: Path) -> None:
    src = tmp_path / "src.mcap"
    with LogWriter(src, chunk_seconds=None) as w:
        for i in range(200):
            w.write(topics.TRUTH, {"timestamp": {"sec": 0, "nsec": 0}, "frame_id": "map",
                                   "pose": {"position": {"x": 0, "y": 0, "z": 0},
                                            "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}},
                    T0 + i * 10_000_000)
    t = [T0 + i * 3_000_000 for i in range(900)]  # runs past the input's last message
    cuts = [0, 1, 1, 50, 333, 334, 700, 900]  # empty batches too
    outs = []
    batches: dict[str, Any] = {"one": _pose_batch(t),
                               "many": iter([_pose_batch(t[a:b]) for a, b in pairwise(cuts)])}
    for name, extra in batches.items():
        out = tmp_path / f"{name}.mcap"
        with LogWriter(out, chunk_seconds=None) as w:
            assert w.copy_from(LogReader(src), extra=extra) == 200
        outs.append([(m.topic, m.log_time_ns, m.data) for m in LogReader(out).raw_messages()])
    assert outs[0] == outs[1]
    assert len(outs[0]) == 1100
    assert [n for _t, n, _d in outs[0]] == sorted(n for _t, n, _d in outs[0])


def test_windowed_merge_orders_ties_by_source_then_row() -> None:
    def src(topic: str, t: list[int]) -> W.Source:
        arr = np.array(t, dtype=np.int64)
        return W.source(topic, arr, lambda idx: (arr[idx].tolist(),
                                                 [b"%d" % i for i in idx.tolist()]))

    a = src(topics.estimate_pose("a"), [5, 5, 9, 30])
    b = src(topics.estimate_pose("b"), [5, 12, 12])
    got = [(n, d) for batch in W.WindowedMerge([a, b], 10) for n, d in zip(batch[2], batch[1],
                                                                             strict=True)]
    assert got == [(5, b"0"), (5, b"1"), (5, b"0"), (9, b"2"), (12, b"1"), (12, b"2"),
                   (30, b"3")]
    # windows from the first time on: [5, 15), then (after an empty one) [25, 35)
    assert [batch[2] for batch in W.WindowedMerge([a, b], 10)] == [[5, 5, 5, 9, 12, 12], [30]]
    far = src(topics.estimate_pose("c"), [0, 10**18])  # a gap of 30 years: two windows
    assert [batch[2] for batch in W.WindowedMerge([far], 1)] == [[0], [10**18]]
