"""The lean MCAP layer: files are standard MCAP; verbatim copies; time order across chunks."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from mcap.reader import make_reader

from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.timestamps import stamp

T0 = 1_700_000_000_000_000_000


def _write(path: Path, n: int = 2000, chunk_bytes: int = 8192) -> None:
    with LogWriter(path, chunk_seconds=None, chunk_bytes=chunk_bytes) as w:
        for i in range(n):
            ns = T0 + i * 10_000_000
            w.write(topics.TRUTH, pose_in_frame(ns, i * 0.001, 0.0, 0.0), ns)
            if i % 5 == 0:
                w.write(topics.ODOM, {"timestamp": stamp(ns), "v": 0.1, "omega": 0.01}, ns + 1)


def test_files_read_by_the_reference_mcap_reader(tmp_path: Path) -> None:
    path = tmp_path / "a.mcap"
    _write(path)
    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count == 2400
        assert len(summary.chunk_indexes) > 10
        msgs = list(reader.iter_messages(log_time_order=True))
        assert len(msgs) == 2400
        names = {r.name for r in reader.iter_metadata()}
        assert "lgvtool" in names
    ours = [(m.topic, m.log_time_ns, m.data) for m in LogReader(path).raw_messages()]
    ref = [(c.topic, m.log_time, m.data) for _, c, m in msgs]
    assert ours == ref


def test_verbatim_copy_equals_source_plus_new_messages(tmp_path: Path) -> None:
    src = tmp_path / "src.mcap"
    _write(src)
    out = tmp_path / "out.mcap"
    reader = LogReader(src)
    with LogWriter(out, chunk_seconds=None) as w:
        assert w.copy_from(reader) == 2400
        for i in range(0, 2000, 7):  # new messages interleave in time with the copied ones
            ns = T0 + i * 10_000_000 + 5
            w.write(topics.estimate_pose("pf"), pose_in_frame(ns, 1.0, 2.0, 0.0), ns)
    copied = LogReader(out)
    assert copied.complete
    got = list(copied.raw_messages())
    assert [m.log_time_ns for m in got] == sorted(m.log_time_ns for m in got)
    assert [m for m in got if m.topic != topics.estimate_pose("pf")] == list(reader.raw_messages())
    assert sum(1 for m in got if m.topic == topics.estimate_pose("pf")) == len(range(0, 2000, 7))
    with open(out, "rb") as f:
        ref = list(make_reader(f).iter_messages(log_time_order=True))
    assert len(ref) == len(got)
    assert copied.topics()[topics.TRUTH].count == 2000


def test_copy_with_skipped_topic_falls_back_to_message_copy(tmp_path: Path) -> None:
    src = tmp_path / "src.mcap"
    _write(src, n=300)
    out = tmp_path / "out.mcap"
    with LogWriter(out) as w:
        n = w.copy_from(LogReader(src), skip_topics=frozenset({topics.ODOM}))
    assert n == 300
    assert LogReader(out).topic_names() == [topics.TRUTH]


def test_messages_written_out_of_order_come_back_sorted(tmp_path: Path) -> None:
    path = tmp_path / "shuffled.mcap"
    times = [T0 + i * 1000 for i in range(3000)]
    rng = random.Random(4)
    shuffled = times[:]
    # local disorder, as threads of a recorder produce
    for i in range(0, len(shuffled) - 5, 5):
        block = shuffled[i : i + 5]
        rng.shuffle(block)
        shuffled[i : i + 5] = block
    with LogWriter(path, chunk_seconds=None, chunk_bytes=4096) as w:
        for ns in shuffled:
            w.write(topics.ODOM, {"timestamp": stamp(ns), "v": 0.0, "omega": 0.0}, ns)
    assert [m.log_time_ns for m in LogReader(path).raw_messages()] == times


def test_framed_records_pack_each_head_as_struct_does() -> None:
    """The heads packed as one array are ``struct``'s, at the ends of each field's range
    (channel 0 and 65535, times 0 and 2**63 - 1 ns, empty and long payloads); a time before
    1970 is refused, never wrapped."""
    import struct

    from lgvtool.log.mcap_writer import framed_records

    cases = [(0, 0, b""), (65535, 2**63 - 1, b"x" * 70_000), (7, T0, b'{"a":1}'),
             (1, T0, b"")]
    blob, cids, times, sizes = framed_records(*map(list, zip(*cases, strict=True)))
    head = struct.Struct("<BQHIQQ")
    assert blob == b"".join(head.pack(5, 22 + len(d), c, 0, t, t) + d for c, t, d in cases)
    assert cids.tolist() == [c for c, _, _ in cases]
    assert times.tolist() == [t for _, t, _ in cases]
    assert sizes.tolist() == [31 + len(d) for _, _, d in cases]
    with pytest.raises(ValueError, match="before 1970"):
        framed_records([1, 1], [T0, -1], [b"", b""])


@pytest.mark.parametrize("chunk_bytes", [20_000, 400_000])
def test_many_messages_at_once_write_the_file_of_one_at_a_time(chunk_bytes: int) -> None:
    """``add_messages`` (headers packed as an array, chunk boundaries from cumulative sizes)
    writes the same bytes as ``add_message`` per message: chunks closing mid-batch and on a
    batch's last message, three channels interleaved (new ones appearing mid-chunk), times out
    of order (the chunk is then sorted), empty payloads, several batches into one chunk; with
    small chunks (a hundred messages each) and large ones (more than
    two thousand messages each)."""
    import io

    from lgvtool.log.mcap_writer import McapWriter

    rng = random.Random(5)
    msgs = []
    for i in range(3000):
        cid_pick = rng.choice((0, 0, 0, 1, 2)) if i > 40 else 0
        t = T0 + i * 1_000_000 + (rng.randrange(-3_000_000, 0) if i % 97 == 0 else 0)
        data = b"" if i % 211 == 0 else bytes(rng.randrange(256) for _ in range(rng.randrange(1, 300)))
        msgs.append((cid_pick, t, data))

    def build(batched: bool) -> bytes:
        buf = io.BytesIO()
        w = McapWriter(buf, compression="none", chunk_bytes=chunk_bytes, library="test")
        sid = w.add_schema("x", "jsonschema", b"{}")
        ids = [w.add_channel(f"/c{k}", "json", sid) for k in range(3)]
        if batched:
            for a, b in ((0, 1), (1, 7), (7, 1500), (1500, 1500), (1500, 3000)):
                part = msgs[a:b]
                w.add_messages([ids[c] for c, _, _ in part], [t for _, t, _ in part],
                               [d for _, _, d in part])
        else:
            for c, t, d in msgs:
                w.add_message(ids[c], t, d)
        w.finish()
        return buf.getvalue()

    one, many = build(False), build(True)
    assert many == one
    reader = make_reader(io.BytesIO(many))
    assert len(list(reader.iter_messages())) == len(msgs)


def test_many_messages_close_chunks_where_one_at_a_time_does() -> None:
    """Records of one size end exactly at the chunk size for some sizes: the chunk closes
    after the record that reaches it, as with ``add_message``."""
    import io

    from lgvtool.log.mcap_writer import McapWriter

    def build(size: int, batched: bool) -> bytes:
        buf = io.BytesIO()
        w = McapWriter(buf, compression="none", chunk_bytes=2000, library="test")
        cid = w.add_channel("/c", "json", w.add_schema("x", "jsonschema", b"{}"))
        times = [T0 + i for i in range(120)]
        if batched:
            w.add_messages([cid] * len(times), times, [b"x" * size] * len(times))
        else:
            for t in times:
                w.add_message(cid, t, b"x" * size)
        w.finish()
        return buf.getvalue()

    for size in range(1, 90):
        assert build(size, True) == build(size, False), size


def test_background_compression_writes_the_same_file() -> None:
    """A writer that compresses each chunk on a worker thread writes the bytes of one that
    compresses in place: chunks closed by size, a metadata record between chunks (the pending
    chunk goes first), the summary."""
    import io

    from lgvtool.log.mcap_writer import McapWriter

    rng = random.Random(3)
    payloads = [bytes(rng.randrange(256) for _ in range(rng.randrange(50, 400)))
                for _ in range(800)]

    def build(background: bool, compression: str) -> bytes:
        buf = io.BytesIO()
        w = McapWriter(buf, compression=compression, chunk_bytes=9000, library="test",
                       background=background)
        cid = w.add_channel("/c", "json", w.add_schema("x", "jsonschema", b"{}"))
        for i, data in enumerate(payloads):
            w.add_message(cid, T0 + i, data)
            if i == 500:
                w.add_metadata("m", {"k": "v"})
        w.finish()
        return buf.getvalue()

    for compression in ("zstd", "lz4", "none"):
        plain, background = build(False, compression), build(True, compression)
        assert background == plain, compression
        assert len(list(make_reader(io.BytesIO(background)).iter_messages())) == len(payloads)


def test_the_writer_holds_little_per_chunk_written() -> None:
    """A recorder's writer runs for a whole shift: what it keeps per chunk written (the summary's
    chunk index) is the packed record, about 170 bytes with five channels, not an object with
    a dict (690 bytes)."""
    import tracemalloc

    from lgvtool.log.mcap_writer import McapWriter

    class Sink:
        def write(self, data: bytes) -> int:
            return len(data)

        def flush(self) -> None:
            pass

    w = McapWriter(Sink(), compression="none", chunk_bytes=1 << 20)  # type: ignore[arg-type]
    sid = w.add_schema("s", "jsonschema", b"{}")
    cids = [w.add_channel(f"/t{i}", "json", sid) for i in range(5)]

    def chunks(k0: int, n: int) -> None:  # 5 messages of about 50 bytes: one chunk
        for k in range(k0, k0 + n):
            for c in cids:
                w.add_message(c, 10**18 + k * 10**6 + c, b'{"k":%d,"pad":"%s"}' % (k, b"x" * 20))
            w.close_chunk()

    chunks(0, 200)
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    chunks(200, 2000)
    grown = tracemalloc.get_traced_memory()[0] - before
    tracemalloc.stop()
    w.finish()
    assert grown / 2000 < 400, grown / 2000
