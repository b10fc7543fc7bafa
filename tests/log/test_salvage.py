"""A log without a usable summary (cut off by a crash or a power loss): its chunks found by one
walk of the file and read a chunk at a time, with the messages that the ``mcap`` package's
stream reader finds in it; messages written outside chunks read by the same walk, in runs."""

from __future__ import annotations

import struct
import warnings
from pathlib import Path

import pytest
from mcap.exceptions import McapError
from mcap.records import Channel, Message
from mcap.stream_reader import StreamReader
from simlogs import simulate_log, write_topic_log

from lgvtool.log import LogReader, topics
from lgvtool.log.mcap_records import read_summary

pytestmark = pytest.mark.filterwarnings("ignore::lgvtool.log.reader.LogWarning")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_log(tmp_path_factory.mktemp("sim") / "run.mcap", 30, 4)


def reference(path: Path) -> list[tuple[str, int, bytes]]:
    """(topic, log time, data) of every message of ``path``'s complete chunks, read by the
    ``mcap`` package's stream reader up to the cut, in log-time order (ties in file order)."""
    channels: dict[int, str] = {}
    found: list[Message] = []
    with open(path, "rb") as f:
        try:
            for rec in StreamReader(f, skip_magic=False).records:
                if isinstance(rec, Channel):
                    channels.setdefault(rec.id, rec.topic)
                elif isinstance(rec, Message):
                    found.append(rec)
        except (McapError, EOFError, ValueError, struct.error):  # the cut
            pass
    found.sort(key=lambda m: m.log_time)
    return [(channels[m.channel_id], m.log_time, m.data) for m in found]


def read(path: Path) -> tuple[LogReader, list[tuple[str, int, bytes]]]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(path)
        return reader, [(m.topic, m.log_time_ns, m.data) for m in reader.raw_messages()]


def cut(src: Path, dst: Path, size: int, tail: bytes = b"") -> Path:
    dst.write_bytes(src.read_bytes()[:size] + tail)
    return dst


def chunks_of(path: Path) -> list:
    with open(path, "rb") as f:
        summary = read_summary(f)
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)


@pytest.mark.parametrize("fraction", [0.2, 0.5, 0.93])
def test_a_cut_log_is_read_a_chunk_at_a_time_with_every_complete_message(
        simulated: Path, tmp_path: Path, fraction: float) -> None:
    broken = cut(simulated, tmp_path / "cut.mcap", int(simulated.stat().st_size * fraction))
    reader, got = read(broken)
    assert not reader.complete
    want = reference(broken)
    assert got == want and got
    said = [w for w in reader.warnings if "incomplete log" in w]
    assert len(said) == 1 and f"salvaged {len(want)} complete messages" in said[0]
    assert f"last message at {want[-1][1] / 1e9:.3f} s" in said[0]
    # the messages are not held: a topic comes a chunk at a time, as from a complete log
    blocks = list(reader.raw_column_chunks([topics.MCU_FRAME]))
    n_mcu = sum(1 for t, _, _ in want if t == topics.MCU_FRAME)
    assert sum(len(b[topics.MCU_FRAME][0]) for b in blocks) == n_mcu
    assert len(blocks) > 1
    assert reader.metadata == LogReader(simulated).metadata
    info = reader.topics()
    assert {t: i.count for t, i in info.items() if i.count} == {
        t: sum(1 for m in want if m[0] == t) for t in {m[0] for m in want}}


def test_message_indexes_cut_off_after_their_chunk_are_not_trusted(
        simulated: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The cut falls inside the message indexes that follow a chunk: that chunk is read by
    walking its records, and every count still matches the messages read; the counts come
    from the other chunks' indexes and that one chunk, not from reading every message."""
    ci = chunks_of(simulated)[10]
    end = ci.chunk_start_offset + ci.chunk_length
    assert len(ci.message_index_offsets) > 2
    broken = cut(simulated, tmp_path / "cut.mcap", end + ci.message_index_length // 2)
    reader, got = read(broken)
    assert got == reference(broken)
    last = max(reader._chunk_indexes, key=lambda c: c.chunk_start_offset)
    assert last.chunk_start_offset == ci.chunk_start_offset
    assert last.message_index_offsets == {}
    assert all(c.message_index_offsets for c in reader._chunk_indexes if c is not last)
    monkeypatch.setattr(LogReader, "_read_topic_times", None)  # not called
    counts = {t: i.count for t, i in reader.topics().items() if i.count}
    assert counts == {t: sum(1 for m in got if m[0] == t) for t in {m[0] for m in got}}


def test_a_corrupt_chunk_before_the_cut_is_skipped_and_said(simulated: Path,
                                                            tmp_path: Path) -> None:
    ci = chunks_of(simulated)[3]
    raw = bytearray(simulated.read_bytes()[:int(simulated.stat().st_size * 0.6)])
    raw[ci.chunk_start_offset + ci.chunk_length - ci.compressed_size // 2] ^= 0x40
    broken = tmp_path / "bad.mcap"
    broken.write_bytes(bytes(raw))
    reader, got = read(broken)
    assert list(reader.corrupt_chunks) == [ci.chunk_start_offset]
    assert any(f"chunk at byte {ci.chunk_start_offset} is corrupt" in w for w in reader.warnings)
    whole = reference(cut(simulated, tmp_path / "cut.mcap", len(raw)))
    lost = [m for m in whole if m not in got]
    assert got and lost and all(ci.message_start_time <= m[1] <= ci.message_end_time
                                for m in lost)


def test_a_zero_filled_tail_ends_the_walk(simulated: Path, tmp_path: Path) -> None:
    """A file system may leave zeros after the last write that reached the disk."""
    size = int(simulated.stat().st_size * 0.4)
    plain = read(cut(simulated, tmp_path / "a.mcap", size))[1]
    reader, zeros = read(cut(simulated, tmp_path / "b.mcap", size, bytes(64 * 1024)))
    assert zeros == plain and zeros
    # the walk stops at the zeros (a record cut off and filled with zeros may end in them)
    assert reader.salvaged_bytes < size + 16 * 1024


def test_messages_outside_chunks_are_read_by_the_same_walk(tmp_path: Path) -> None:
    """A writer that does not chunk (allowed by MCAP): the walk gathers its messages into runs
    that are read as chunks are (tests/log/test_reader_sources.py: by every method)."""
    from mcap.writer import Writer

    path = tmp_path / "loose.mcap"
    with open(path, "wb") as f:
        w = Writer(f, use_chunking=False)
        w.start()
        cid = w.register_channel(topics.ODOM, "json",
                                 w.register_schema("lgvtool.Odometry", "jsonschema", b"{}"))
        for i in range(50):
            t = 1_704_067_200_000_000_000 + i * 10**8
            w.add_message(cid, t, b'{"timestamp":{"sec":%d,"nsec":%d},"v":0.1,"omega":0.0}'
                          % (t // 10**9, t % 10**9), t)
        w.finish()
    broken = cut(path, tmp_path / "cut.mcap", int(path.stat().st_size * 0.7))
    reader, got = read(broken)
    assert not reader.complete
    assert got == reference(broken) and 20 < len(got) < 50


def test_a_summary_that_fails_its_crc_is_read_through_the_chunks(tmp_path: Path) -> None:
    """A foreign file whose summary is damaged: its chunks are found by the walk, which stops
    at the end of the data section (the summary's copies of the records are not read)."""
    path = write_topic_log(tmp_path / "one.mcap", topics.ODOM, "lgvtool.Odometry",
                           [b'{"v":0.1,"omega":0.0}'] * 300)
    raw = bytearray(path.read_bytes())
    (summary_start,) = struct.unpack_from("<Q", raw, len(raw) - 8 - 20)  # the footer's
    raw[len(raw) - 8 - 29 - 1] ^= 0xFF  # the last byte of the summary section
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    reader, got = read(bad)
    assert not reader.complete
    assert len(got) == 300
    assert reader.salvaged_bytes == summary_start  # the end of the data end record


def test_recover_copies_every_intact_message_and_reports_them(simulated: Path,
                                                              tmp_path: Path) -> None:
    """``recover`` of a cut log: the intact chunks' messages, read back by the ``mcap``
    package's reader, and a report whose counts and times are those messages'."""
    from mcap.reader import make_reader

    from lgvtool.log.salvage import recover

    broken = cut(simulated, tmp_path / "cut.mcap", int(simulated.stat().st_size * 0.7))
    want = reference(broken)
    fixed = tmp_path / "fixed.mcap"
    report = recover(broken, fixed)
    with open(fixed, "rb") as f:
        got = [(c.topic, m.log_time, m.data) for _s, c, m in make_reader(f).iter_messages()]
    assert got == want
    assert report.messages == len(want) == sum(report.topics.values())
    assert report.topics == {t: sum(1 for m in want if m[0] == t) for t in {m[0] for m in want}}
    assert report.first_s == pytest.approx(want[0][1] / 1e9, abs=1e-6)
    assert report.last_s == pytest.approx(want[-1][1] / 1e9, abs=1e-6)
    assert not report.was_complete and report.intact_bytes < broken.stat().st_size


@pytest.mark.parametrize("compression", ["lz4", "none"])
def test_recover_compresses_as_asked_also_a_complete_log(simulated: Path, tmp_path: Path,
                                                         compression: str) -> None:
    """The records are put into new chunks compressed as ``--compression`` says, also when
    the input is complete (its chunks are not copied byte for byte)."""
    from lgvtool.log.salvage import recover

    fixed = tmp_path / "fixed.mcap"
    report = recover(simulated, fixed, compression=compression)
    assert report.was_complete
    assert {c.compression for c in chunks_of(fixed)} == {"" if compression == "none"
                                                          else compression}
    assert read(fixed)[1] == read(simulated)[1]


def test_damaged_cut_logs_open_or_are_refused_in_one_line(simulated: Path,
                                                          tmp_path: Path) -> None:
    """Cut at random sizes and with random bytes flipped, a log is opened (its damaged chunks
    skipped) or refused with a LogFormatError, never another exception; cut only, it yields
    exactly the messages of the ``mcap`` package's stream reader. (Run with 1 500 trials once
    by hand: the same.)"""
    import numpy as np

    from lgvtool.errors import LogFormatError

    rng = np.random.default_rng(7)
    data = simulated.read_bytes()
    path = tmp_path / "damaged.mcap"
    for trial in range(60):
        # every fifth file whole (only flipped: its summary may be what is damaged)
        size = len(data) if trial % 5 == 4 else int(rng.integers(9, len(data)))
        raw = bytearray(data[:size])
        flips = 0 if trial % 3 == 0 else int(rng.integers(1, 4))
        for at in rng.integers(8, size, flips):
            raw[int(at)] ^= int(rng.integers(1, 256))
        path.write_bytes(bytes(raw))
        try:
            reader, got = read(path)
            reader.topics()
        except LogFormatError:
            assert flips or size < 200, (trial, size)
            continue
        if not flips:
            assert got == reference(path), (trial, size)
