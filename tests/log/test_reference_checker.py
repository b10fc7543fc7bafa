"""Every kind of file lgvtool writes passes the reference MCAP checker's checks (``mcap doctor``):
no error, no warning a writer can avoid, and a Statistics record that matches the messages,
all read with the ``mcap`` package (not lgvtool's reader)."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from mcap_doctor import (
    assert_reference_clean,
    diagnose,
    doctor_binary,
    run_doctor,
    schema_errors,
    statistics_errors,
)

from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.mcap_writer import McapWriter
from lgvtool.log.messages import pose_in_frame

T0 = 1_704_067_200_000_000_000


def _many_chunks(path: Path, n: int = 3000) -> None:
    """A log of ``n`` poses and odometry messages over ``n`` x 10 ms in chunks of about 8 KiB."""
    with LogWriter(path, chunk_seconds=None, chunk_bytes=8192) as w:
        for i in range(n):
            ns = T0 + 5_000_000 + i * 10_000_000
            w.write(topics.TRUTH, pose_in_frame(ns, 0.001 * i, 0.0, 0.0), ns)
            if i % 3 == 0:
                w.write(topics.ODOM, {"timestamp": {"sec": ns // 10**9, "nsec": ns % 10**9},
                                      "v": 0.1, "omega": 0.0}, ns + 1)


def test_written_log_is_clean(tmp_path: Path) -> None:
    path = tmp_path / "a.mcap"
    _many_chunks(path)
    assert len(LogReader(path)._chunk_indexes) > 10
    assert_reference_clean(path)


def test_verbatim_copy_keeps_statistics_and_has_no_duplicate_records(tmp_path: Path) -> None:
    """Copied chunks used to overwrite the file's first time with each chunk's (the copy
    started at its last chunk) and their schemas and channels were written twice."""
    src, out = tmp_path / "src.mcap", tmp_path / "out.mcap"
    _many_chunks(src)
    with LogWriter(out, chunk_seconds=None) as w:
        assert w.copy_from(LogReader(src)) == 4000
    assert_reference_clean(out)
    d = diagnose(out)
    assert d.statistics is not None and d.statistics.message_start_time == T0 + 5_000_000


def test_merged_copy_is_in_log_time_order(tmp_path: Path) -> None:
    src, out = tmp_path / "src.mcap", tmp_path / "out.mcap"
    _many_chunks(src, n=1000)
    extra_t = [T0 + i * 10_000_000 + 7 for i in range(0, 1000, 4)]
    extra = ([topics.estimate_pose("pf")] * len(extra_t),
             [b'{"timestamp":{"sec":0,"nsec":0},"frame_id":"map","pose":{"position":'
              b'{"x":0,"y":0,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}}'] * len(extra_t),
             extra_t)
    with LogWriter(out, chunk_seconds=None, chunk_bytes=8192) as w:
        assert w.copy_from(LogReader(src), extra=extra) == 1334
    assert_reference_clean(out)
    assert LogReader(out).topics()[topics.estimate_pose("pf")].count == len(extra_t)


def test_merged_copy_keeps_a_foreign_channel_and_its_schema(tmp_path: Path) -> None:
    src, out = tmp_path / "src.mcap", tmp_path / "out.mcap"
    with LogWriter(src, chunk_seconds=None) as w:
        w.write(topics.TRUTH, pose_in_frame(T0, 0.0, 0.0, 0.0), T0)
        raw = w._writer
        cid = raw.add_channel("/x/thing", "json", raw.add_schema("x.Thing", "jsonschema",
                                                                 b'{"type":"object"}'))
        raw.add_message(cid, T0 + 5, b'{"a":1}')
    with LogWriter(out, chunk_seconds=None) as w:
        w.copy_from(LogReader(src), extra=([topics.estimate_pose("pf")], [
            b'{"timestamp":{"sec":0,"nsec":0},"frame_id":"map","pose":{"position":'
            b'{"x":0,"y":0,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}}'], [T0 + 3]))
    assert_reference_clean(out)
    got = [(m.topic, m.schema, m.data) for m in LogReader(out).raw_messages()]
    assert got[-1] == ("/x/thing", "x.Thing", b'{"a":1}')
    assert [t for t, _s, _d in got] == [topics.TRUTH, topics.estimate_pose("pf"), "/x/thing"]


def test_disorder_within_a_chunk_is_sorted_out(tmp_path: Path) -> None:
    """Messages a recorder's threads hand over slightly out of order (and a channel first
    used by a late message) are written in log-time order within their chunk."""
    import random

    path = tmp_path / "local.mcap"
    times = [T0 + i * 1_000_000 for i in range(2000)]
    rng = random.Random(5)
    shuffled = times[:]
    for i in rng.sample(range(len(times) - 3), 400):  # a message handed over 1-3 places late
        j = i + rng.randint(1, 3)
        shuffled[i], shuffled[j] = shuffled[j], shuffled[i]
    with LogWriter(path, chunk_seconds=None) as w:
        for k, ns in enumerate(shuffled):
            w.write(topics.ODOM, {"timestamp": {"sec": ns // 10**9, "nsec": ns % 10**9},
                                  "v": 0.0, "omega": 0.0}, ns)
            if k == 1000:  # a new channel, its first message older than the one before
                w.write(topics.TRUTH, pose_in_frame(ns - 500, 0.0, 0.0, 0.0), ns - 500)
        # the batched path too
        w.flush()
        w._chunk_ns = None
        w.write_encoded_many([topics.ODOM] * 3, [b'{"timestamp":{"sec":0,"nsec":0},"v":0.0,'
                                                 b'"omega":0.0}'] * 3,
                             [times[-1] + 30, times[-1] + 10, times[-1] + 20])
    assert_reference_clean(path)
    got = [m.log_time_ns for m in LogReader(path).raw_messages()]
    assert got == sorted(got) and len(got) == 2004


def test_a_recorder_s_disorder_across_chunk_closes_is_sorted_out(tmp_path: Path) -> None:
    """A time-chunked writer (a recorder) closing a chunk every 0.1 s keeps its newest
    messages for the next chunk, so messages handed over up to 50 ms late stay in order."""
    import random

    path = tmp_path / "rec.mcap"
    rng = random.Random(6)
    times = [T0 + i * 3_000_000 for i in range(3000)]  # 9 s at 333 Hz
    late = [t + rng.choice((0, 0, 0, 20_000_000, 45_000_000)) for t in times]  # handed late
    order = sorted(range(len(times)), key=lambda i: late[i])
    with LogWriter(path, chunk_seconds=0.1) as w:
        for i in order:
            ns = times[i]
            w.write(topics.ODOM, {"timestamp": {"sec": ns // 10**9, "nsec": ns % 10**9},
                                  "v": 0.0, "omega": 0.0}, ns)
    assert len(LogReader(path)._chunk_indexes) > 50
    assert_reference_clean(path)


def _two_chunks(path: Path, first: int, second: int, start: int | None = None) -> None:
    """A file of one message at ``first`` and one at ``second`` (ns), in two chunks; with
    ``start``, a Statistics record claiming that first time instead of the true one."""
    buf = io.BytesIO()
    w = McapWriter(buf, compression="none", library="test")
    cid = w.add_channel("/x", "json", w.add_schema("x", "jsonschema", b"{}"))
    w.add_message(cid, first, b"{}")
    w.close_chunk()
    w.add_message(cid, second, b"{}")
    w.close_chunk()
    if start is not None:
        w._start = start
    w.finish()
    path.write_bytes(buf.getvalue())


def test_checker_sees_disorder_and_wrong_statistics(tmp_path: Path) -> None:
    """The checks can fail: a chunk older than the one before it, and statistics that do
    not match, are reported."""
    path = tmp_path / "bad.mcap"
    _two_chunks(path, T0 + 100, T0 + 50)
    d = diagnose(path)
    assert any("less than the latest log time" in x for x in d.warnings)
    assert d.errors == [] and statistics_errors(path) == []
    # a Statistics record whose start time is not the first message's (what the old writer
    # did with copied chunks)
    bad = tmp_path / "bad2.mcap"
    _two_chunks(bad, T0 + 10, T0 + 30, start=T0 + 20)
    assert any("message start time" in e for e in diagnose(bad).errors)
    assert statistics_errors(bad)


@pytest.fixture(scope="module")
def outputs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated run and what simulate, replay, decode and recover write of it."""
    import subprocess
    import sys

    d = tmp_path_factory.mktemp("outputs")

    def cli(*args: object) -> None:
        p = subprocess.run([sys.executable, "-m", "lgvtool", *map(str, args)],
                           capture_output=True, text=True, timeout=300, check=False)
        assert p.returncode == 0, p.stderr

    out = {k: d / f"{k}.mcap" for k in ("simulate", "replay", "decode", "recover")}
    cli("simulate", "-s", "degraded", "--duration", 40, "-o", out["simulate"])
    cli("replay", out["simulate"], "-o", out["replay"], "-e", "ekf", "-e", "pf",
        "--particles", 200)
    cli("decode", out["simulate"], "-o", out["decode"])
    cut = d / "cut.mcap"
    raw = out["simulate"].read_bytes()
    cut.write_bytes(raw[: len(raw) * 2 // 3])
    cli("recover", cut, "-o", out["recover"])
    return out


@pytest.mark.parametrize("kind", ["simulate", "replay", "decode", "recover"])
def test_command_output_is_clean(outputs: dict[str, Path], kind: str) -> None:
    assert_reference_clean(outputs[kind])


@pytest.mark.parametrize("kind", ["simulate", "replay", "decode", "recover"])
def test_command_output_validates_against_its_schemas(outputs: dict[str, Path],
                                                      kind: str) -> None:
    """Every message validates against the schema embedded with it (Foxglove's own for the
    foxglove.* ones, required lists included), read with the ``mcap`` package."""
    errors = schema_errors(outputs[kind])
    assert errors == [], errors[:5]


@pytest.mark.skipif(doctor_binary() is None, reason="the reference mcap CLI is not on PATH")
@pytest.mark.parametrize("kind", ["simulate", "replay", "decode", "recover"])
def test_reference_doctor_binary(outputs: dict[str, Path], kind: str) -> None:
    p = run_doctor(outputs[kind])
    assert p.returncode == 0, p.stdout + p.stderr
    text = p.stdout + p.stderr
    assert "Duplicate" not in text and "less than the latest log time" not in text, text
