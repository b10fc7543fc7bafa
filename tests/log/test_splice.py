"""``replay``'s copy of its input as byte ranges (lgvtool.log.splice, LogReader.record_chunks):
the merged records are those of a message-by-message merge, the columns of a chunk's records
are found through its message indexes or, where those do not account for every record, by
walking it, and a chunk whose records do not frame is skipped alone."""

from __future__ import annotations

import io
import random
import warnings
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from simlogs import simulate_log

from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.foxglove import pose_in_frame_many
from lgvtool.log.mcap_chunks import (
    CorruptChunkError,
    RecordColumns,
    chunk_window,
    record_columns,
    verified_records,
)
from lgvtool.log.mcap_records import OP_MESSAGE, ChunkIndex, read_summary
from lgvtool.log.mcap_writer import McapWriter, framed_records
from lgvtool.log.splice import spliced

T0 = 1_700_000_000_000_000_000


def _records(rng: random.Random, n: int, *, ties: bool) -> tuple[list[int], list[int],
                                                                  list[bytes]]:
    times = sorted(T0 + rng.randrange(0, 40 if ties else 10**9) for _ in range(n))
    cids = [rng.choice((1, 2, 3)) for _ in range(n)]
    datas = [bytes(rng.randrange(256) for _ in range(rng.randrange(0, 40))) for _ in range(n)]
    return cids, times, datas


@pytest.mark.parametrize("seed", range(6))
def test_spliced_records_are_the_message_by_message_merge(seed: int) -> None:
    """Input records with non-message records between them (a channel record), some dropped,
    added records at equal times too: the block is the merge by (time, input first, order)."""
    rng = random.Random(seed)
    ties = seed % 2 == 0
    c_in, t_in, d_in = _records(rng, rng.randrange(0, 300), ties=ties)
    c_add, t_add, d_add = _records(rng, rng.randrange(0, 300), ties=ties)
    blob, cids, times, sizes = framed_records(c_in, t_in, d_in)
    # a foreign record (opcode 4, a channel) before every 7th message, as chunks hold them
    parts, offsets, at = [], [], 0
    for k in range(len(d_in)):
        if k % 7 == 3:
            extra = bytes([4]) + (5).to_bytes(8, "little") + b"abcde"
            parts.append(extra)
            at += len(extra)
        lo = int(sizes[:k].sum())
        parts.append(blob[lo:lo + int(sizes[k])])
        offsets.append(at)
        at += int(sizes[k])
    records = b"".join(parts)
    keep = np.array([rng.random() > 0.2 for _ in range(len(d_in))], dtype=bool)
    cols = (cids, times, np.array(offsets, dtype=np.int64), sizes)
    block, out_c, out_t, out_s = spliced(records, cols, keep, framed_records(c_add, t_add, d_add))
    want = sorted([(t, 0, k, c, d) for k, (c, t, d) in enumerate(zip(c_in, t_in, d_in,
                                                                     strict=True)) if keep[k]]
                  + [(t, 1, k, c, d) for k, (c, t, d) in enumerate(zip(c_add, t_add, d_add,
                                                                       strict=True))])
    assert out_t.tolist() == [w[0] for w in want]
    assert out_c.tolist() == [w[3] for w in want]
    assert block == framed_records([w[3] for w in want], [w[0] for w in want],
                                   [w[4] for w in want])[0]
    assert int(out_s.sum()) == len(block)


def test_spliced_with_nothing_on_either_side() -> None:
    none = (np.zeros(0, np.uint16), np.zeros(0, np.int64), np.zeros(0, np.int64),
            np.zeros(0, np.int64))
    one = framed_records([1], [T0], [b"x"])
    block, _c, t, _s = spliced(b"", none, None, one)
    assert block == one[0] and t.tolist() == [T0]
    cols = (one[1], one[2], np.zeros(1, np.int64), one[3])
    block, _c, t, _s = spliced(one[0], cols, None, framed_records([], [], []))
    assert block == one[0] and t.tolist() == [T0]
    block, _c, t, _s = spliced(b"", none, None, framed_records([], [], []))
    assert block == b"" and len(t) == 0


@pytest.fixture(scope="module")
def sim(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_log(tmp_path_factory.mktemp("splice") / "run.mcap", 20, 4)


def _chunks(path: Path) -> list[tuple[bytes, ChunkIndex, bytes]]:
    with open(path, "rb") as f:
        summary = read_summary(f)
        assert summary is not None
        out = []
        for ci in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            buf, local = chunk_window(f, ci)
            out.append((buf, local, verified_records(buf, local)))
    return out


def _messages_of(records: bytes, cols: RecordColumns) -> list[tuple[int, int, bytes]]:
    cids, times, offsets, sizes = cols
    return [(int(c), int(t), records[o + 31:o + s]) for c, t, o, s in
            zip(cids, times, offsets, sizes, strict=True)]


def test_record_columns_from_the_indexes_are_the_walked_ones(sim: Path) -> None:
    chunks = _chunks(sim)
    records, cols = record_columns(chunks)
    # the same chunks without their message indexes: walked
    bare = [(buf, ChunkIndex(ci.message_start_time, ci.message_end_time, ci.chunk_start_offset,
                             ci.chunk_length, {}, 0, ci.compression, ci.compressed_size,
                             ci.uncompressed_size), r) for buf, ci, r in chunks]
    walked_records, walked = record_columns(bare)
    assert walked_records == records
    for k in range(4):
        assert cols[k].tolist() == walked[k].tolist()
    assert len(cols[0]) == sum(i.count for i in LogReader(sim).topics().values()) > 1000
    times = cols[1]
    assert (np.diff(times) >= 0).all()
    rec = np.frombuffer(records, np.uint8)
    assert (rec[cols[2]] == OP_MESSAGE).all()


def test_an_index_that_leaves_a_message_out_is_not_trusted(sim: Path) -> None:
    """A chunk whose message index misses a message: found by the walk of the gaps, the
    chunk is walked instead and no message is lost."""
    chunks = _chunks(sim)
    buf, ci, records = chunks[3]
    _cid, off = next(iter(ci.message_index_offsets.items()))
    # shorten that channel's index by one entry (the array length field, 16 bytes a pair)
    raw = bytearray(buf)
    n = int.from_bytes(raw[off + 11:off + 15], "little")
    assert n >= 32
    raw[off + 11:off + 15] = (n - 16).to_bytes(4, "little")
    broken = [(bytes(raw), ci, records)]
    _r, cols = record_columns(broken)
    _r2, whole = record_columns([chunks[3]])
    assert len(cols[0]) == len(whole[0])
    assert _messages_of(_r, cols) == _messages_of(_r2, whole)


def test_a_chunk_that_does_not_frame_is_skipped_alone(sim: Path) -> None:
    chunks = _chunks(sim)[:6]
    buf, ci, records = chunks[2]
    bad = records[:-3]  # cut inside its last record
    unindexed = ChunkIndex(ci.message_start_time, ci.message_end_time, ci.chunk_start_offset,
                         ci.chunk_length, {}, 0, ci.compression, ci.compressed_size, len(bad))
    group = [*chunks[:2], (buf, unindexed, bad), *chunks[3:]]
    seen: list[int] = []
    records_out, cols = record_columns(group, lambda k, reason: seen.append(k))
    assert seen == [2]
    rest = chunks[:2] + chunks[3:]
    want_records, want = record_columns(rest)
    assert records_out == want_records
    assert _messages_of(records_out, cols) == _messages_of(want_records, want)
    with pytest.raises(CorruptChunkError):
        record_columns(group)


def _copy(src: Path, dst: Path, *, spliced_path: bool) -> list[tuple[str, int, int, bytes]]:
    """``src`` copied with further pose messages merged in; by the splice (a fresh writer
    chunked by size) or message by message (a writer chunked by time)."""
    reader = LogReader(src)
    infos = reader.topics()
    lo = min(i.start_ns for i in infos.values() if i.count)
    hi = max(i.end_ns for i in infos.values() if i.count)
    t = sorted({lo - 5, lo, *range(lo, hi + 10**9, 37_000_000), hi, hi + 1})
    z = np.zeros(len(t))
    batches = iter([([topics.estimate_pose("pf")] * len(t[a:b]),
                     pose_in_frame_many(t[a:b], z[a:b], z[a:b], z[a:b]), t[a:b])
                    for a, b in ((0, 10), (10, 10), (10, 200), (200, len(t)))])
    with LogWriter(dst, chunk_seconds=None if spliced_path else 3600.0) as w:
        w.copy_from(reader, skip_topics=frozenset({topics.NAV_POSE}), extra=batches)
    with open(dst, "rb") as f:
        out = make_reader(f, validate_crcs=True)
        stats = out.get_summary().statistics
        msgs = [(ch.topic, m.log_time, m.publish_time, m.data)
                for _s, ch, m in out.iter_messages(log_time_order=False)]
    assert stats.message_count == len(msgs)
    return msgs


def test_replay_s_copy_is_the_message_by_message_merge(sim: Path, tmp_path: Path) -> None:
    """Further messages before, at and after the input's times, a skipped topic: the splice
    writes the messages of the message-by-message merge in the same order (read back by the
    mcap package with CRC checks)."""
    a = _copy(sim, tmp_path / "a.mcap", spliced_path=True)
    b = _copy(sim, tmp_path / "b.mcap", spliced_path=False)
    assert a == b
    assert topics.NAV_POSE not in {m[0] for m in a}
    assert [m[1] for m in a] == sorted(m[1] for m in a)


def test_overlapping_chunks_are_copied_message_by_message(tmp_path: Path) -> None:
    """Chunks whose times overlap (another writer's): no record runs (the merge's order is not
    the chunks'), and the copy still merges every message in order."""
    path = tmp_path / "overlap.mcap"
    buf = io.BytesIO()
    w = McapWriter(buf, compression="none", library="test")
    sid = w.add_schema("foxglove.PoseInFrame", "jsonschema", b"{}")
    cid = w.add_channel(topics.TRUTH, "json", sid)
    pose = (b'{"timestamp":{"sec":0,"nsec":0},"frame_id":"map","pose":{"position":{"x":0,'
            b'"y":0,"z":0},"orientation":{"x":0,"y":0,"z":0,"w":1}}}')
    for k in range(0, 40, 2):
        w.add_message(cid, T0 + k * 10**8, pose)
    w.close_chunk()
    for k in range(1, 40, 2):
        w.add_message(cid, T0 + k * 10**8, pose)
    w.finish()
    path.write_bytes(buf.getvalue())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(path)
        assert reader.record_chunks() is None
    out = tmp_path / "out.mcap"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with LogWriter(out, chunk_seconds=None) as lw:
            t = [T0 + k * 10**8 + 1 for k in range(40)]
            z = np.zeros(40)
            lw.copy_from(reader, extra=([topics.estimate_pose("pf")] * 40,
                                        pose_in_frame_many(t, z, z, z), t))
    with open(out, "rb") as f:
        times = [m.log_time for _s, _c, m in make_reader(f).iter_messages(log_time_order=False)]
    assert len(times) == 80 and times == sorted(times)
