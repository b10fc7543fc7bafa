"""The reader's two sources (lgvtool.log.sources) read the same messages: every reading method of
LogReader, through a sample log's index and through a walk of the same file (the salvage a file
without a usable summary gets), gives the same messages in the same order; and a cut copy, a
copy with a corrupt chunk and a file whose messages lie outside chunks are read alike by every
method, with the messages the ``mcap`` package's stream reader finds."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import orjson
import pandas as pd
import pytest
from mcap.writer import CompressionType, Writer
from test_salvage import chunks_of, cut, reference
from test_verified_reading import flip

from lgvtool.log import LogReader, topics
from lgvtool.log import mcap_scan as S
from lgvtool.log.mcap_chunks import chunk_messages, load_chunk, records_of
from lgvtool.log.mcap_records import OP_CHANNEL
from lgvtool.log.sources import IndexedSource, LogSource, SalvagedSource, open_source

pytestmark = pytest.mark.filterwarnings("ignore::lgvtool.log.reader.LogWarning")

SAMPLE_LOGS = Path(__file__).resolve().parents[2] / "sample_logs"
SAMPLES = sorted(p.name for p in SAMPLE_LOGS.glob("*.mcap"))

Msg = tuple[str, int, bytes]  # topic, log time (ns), JSON bytes


def stated(path: Path) -> tuple[int, int]:
    """The messages and chunks the file's summary states, read by the ``mcap`` package."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    return summary.statistics.message_count, len(summary.chunk_indexes)


def opened(path: Path, monkeypatch: pytest.MonkeyPatch, *, salvage: bool) -> LogReader:
    """``path`` read through its index, or (``salvage``) as if it had none: walked."""
    with warnings.catch_warnings(), monkeypatch.context() as m:
        warnings.simplefilter("ignore")
        if salvage:
            m.setattr(IndexedSource, "open", staticmethod(lambda *_a: None))
        return LogReader(path)


def readings(reader: LogReader) -> dict[str, Any]:
    """What every reading method gives, as (topic, log time, data) where it can be."""
    names = reader.topic_names()
    out: dict[str, Any] = {}
    out["raw_messages"] = [(m.topic, m.log_time_ns, m.data) for m in reader.raw_messages()]
    out["raw_blocks"] = [(reader.channel_topic(cid)[0], t, d)
                         for block in reader.raw_blocks() for t, cid, _pub, d in block]
    groups = reader.record_chunks()
    out["record_chunks"] = None if groups is None else [
        (reader.channel_topic(cid)[0], t, records[o + 31:o + n])  # 31: a message's head
        for records, cols in groups
        for cid, t, o, n in zip(*(c.tolist() for c in cols), strict=True)]
    out["messages"] = [(m.topic, m.log_time_ns, m.data) for m in reader.messages()]
    out["raw_messages_of"] = {t: [(m.log_time_ns, m.data) for m in reader.raw_messages([t])]
                              for t in names}
    out["raw_columns"] = {t: list(zip(ts.tolist(), ds, strict=True))
                          for t, (ts, ds) in reader.raw_columns(names).items()}
    out["raw_column_chunks"] = [{t: (ts.tolist(), ds) for t, (ts, ds) in block.items()}
                                for block in reader.raw_column_chunks(names)]
    out["topics"] = reader.topics()
    out["dataframes"] = reader.dataframes(names)
    out["verify_chunks"] = reader.verify_chunks()
    out["corrupt_chunks"] = dict(reader.corrupt_chunks)
    out["registrations"] = reader.registrations()
    out["metadata"] = reader.metadata
    return out


def agree(a: dict[str, Any], b: dict[str, Any]) -> None:
    """Two readings the same, method by method."""
    assert a.keys() == b.keys()
    for key in a:
        if key == "dataframes":
            assert a[key].keys() == b[key].keys()
            for t in a[key]:
                pd.testing.assert_frame_equal(a[key][t], b[key][t])
        else:
            assert a[key] == b[key], key


def consistent(got: dict[str, Any]) -> list[Msg]:
    """The messages of one reading, checked to be the same for every method of it."""
    msgs: list[Msg] = got["raw_messages"]
    assert got["raw_blocks"] == msgs
    if got["record_chunks"] is not None:
        assert got["record_chunks"] == msgs
    assert [(t, n, orjson.loads(d)) for t, n, d in msgs] == got["messages"]
    by_topic: dict[str, list[tuple[int, bytes]]] = {}
    for t, n, d in msgs:
        by_topic.setdefault(t, []).append((n, d))
    assert {t: m for t, m in got["raw_messages_of"].items() if m} == by_topic
    assert got["raw_columns"] == by_topic
    chunked: dict[str, list[tuple[int, bytes]]] = {}
    for block in got["raw_column_chunks"]:
        for t, (ts, ds) in block.items():
            chunked.setdefault(t, []).extend(zip(ts, ds, strict=True))
    # a chunk at a time, each in stored order: the same messages, in time order when the
    # chunks do not overlap
    assert {t: sorted(m) for t, m in chunked.items()} == {t: sorted(m)
                                                          for t, m in by_topic.items()}
    assert {t: (i.count, i.start_ns, i.end_ns) for t, i in got["topics"].items() if i.count} \
        == {t: (len(m), m[0][0], m[-1][0]) for t, m in by_topic.items()}
    return msgs


def test_there_are_sample_logs() -> None:
    assert {"paper-circle.mcap", "degraded.mcap"} <= set(SAMPLES)


@pytest.mark.parametrize("name", SAMPLES)
def test_a_sample_log_reads_the_same_through_its_index_and_walked(
        name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    path = SAMPLE_LOGS / name
    indexed = opened(path, monkeypatch, salvage=False)
    walked = opened(path, monkeypatch, salvage=True)
    assert indexed.complete and not indexed.warnings
    assert not walked.complete and any("incomplete log" in w for w in walked.warnings)
    # the walk finds the chunks the summary indexes, each with its message indexes
    assert walked._chunk_indexes == indexed._chunk_indexes
    got = readings(indexed)
    agree(got, readings(walked))
    msgs = consistent(got)
    assert msgs == reference(path)
    assert (len(msgs), len(indexed._chunk_indexes)) == stated(path)
    assert len(msgs) > 5000 and len(indexed._chunk_indexes) > 100
    assert got["record_chunks"] is not None and got["verify_chunks"]
    # only a whole file's chunks are copied as they are
    assert indexed.verbatim_plan() is not None and walked.verbatim_plan() is None


@pytest.mark.parametrize("name", SAMPLES)
def test_a_cut_copy_reads_every_complete_message_by_every_method(
        name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    src = SAMPLE_LOGS / name
    broken = cut(src, tmp_path / "cut.mcap", src.stat().st_size // 2)
    reader = opened(broken, monkeypatch, salvage=False)
    assert not reader.complete
    msgs = consistent(readings(reader))
    assert msgs == reference(broken)
    assert 0.3 < len(msgs) / stated(src)[0] < 0.7
    # the whole log's messages of the chunks before the cut, in the same order
    kept = set(msgs)
    whole = opened(src, monkeypatch, salvage=False)
    assert msgs == [(m.topic, m.log_time_ns, m.data) for m in whole.raw_messages()
                    if (m.topic, m.log_time_ns, m.data) in kept]


@pytest.mark.parametrize("name", SAMPLES)
def test_a_copy_with_a_corrupt_chunk_reads_the_same_indexed_and_walked(
        name: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    src = SAMPLE_LOGS / name
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(src.read_bytes())
    offset = flip(bad, 2, 0.5)
    indexed = opened(bad, monkeypatch, salvage=False)
    walked = opened(bad, monkeypatch, salvage=True)
    assert indexed.complete and not walked.complete
    assert list(walked.corrupt_chunks) == [offset]  # found by the walk, when opening
    got = readings(indexed)
    agree(got, readings(walked))
    assert got["corrupt_chunks"].keys() == {offset} and not got["verify_chunks"]
    assert indexed.verbatim_plan() is None
    msgs = consistent(got)
    # every message but those of the corrupt chunk
    with open(src, "rb") as f:
        (ci,) = [c for c in chunks_of(src) if c.chunk_start_offset == offset]
        lost = chunk_messages(load_chunk(f, ci).records, None)
    whole = readings(opened(src, monkeypatch, salvage=False))["raw_messages"]
    assert lost and len(msgs) == len(whole) - len(lost)
    gone = {(indexed.channel_topic(cid)[0], t, d) for t, cid, _p, d in lost}
    assert msgs == [m for m in whole if m not in gone]


def loose_log(path: Path, n: int) -> Path:
    """A log written without chunks (allowed by MCAP): its messages lie outside chunks."""
    with open(path, "wb") as f:
        w = Writer(f, use_chunking=False)
        w.start()
        cid = w.register_channel(topics.ODOM, "json",
                                 w.register_schema("lgvtool.Odometry", "jsonschema", b"{}"))
        for i in range(n):
            t = 1_704_067_200_000_000_000 + i * 10**8
            w.add_message(cid, t, b'{"timestamp":{"sec":%d,"nsec":%d},"v":0.1,"omega":0.0}'
                          % (t // 10**9, t % 10**9), t)
        w.finish()
    return path


def test_messages_outside_chunks_are_read_in_runs_by_every_method(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The walk gathers the messages written outside chunks into runs read from the file one
    at a time as chunks are (never all held): many runs when they are long."""
    path = loose_log(tmp_path / "loose.mcap", 400)
    broken = cut(path, tmp_path / "cut.mcap", int(path.stat().st_size * 0.7))
    whole = consistent(readings(opened(broken, monkeypatch, salvage=False)))
    monkeypatch.setattr(S, "LOOSE_RUN_BYTES", 1000)
    reader = opened(broken, monkeypatch, salvage=False)
    assert not reader.complete and len(reader._chunk_indexes) > 10
    got = readings(reader)
    assert consistent(got) == whole == reference(broken) and 200 < len(whole) < 400
    assert len(got["raw_column_chunks"]) == len(reader._chunk_indexes)


def test_both_sources_are_log_sources(tmp_path: Path) -> None:
    """open_source picks the index when the file has a usable one, else the walk, and says
    what the walk salvaged."""
    said: list[str] = []
    sample = SAMPLE_LOGS / "paper-circle.mcap"
    source: LogSource = open_source(sample, sample.stat().st_size, lambda *_a: None,
                                    said.append)
    assert isinstance(source, IndexedSource) and source.complete and not said
    assert source.copy_counts() is not None and not source.unknown_channels
    broken = cut(sample, tmp_path / "cut.mcap", 300_000)
    source = open_source(broken, 300_000, lambda *_a: None, said.append)
    assert isinstance(source, SalvagedSource) and not source.complete
    assert source.copy_counts() is None
    assert source.sound == {ci.chunk_start_offset for ci in source.chunk_indexes}
    assert len(said) == 1 and "incomplete log" in said[0]


def test_messages_on_a_channel_whose_definition_was_lost_are_left_out_by_every_method(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A cut log whose second channel is defined in a chunk that is corrupt: every method
    reads the first channel's messages of the sound chunks, and the warning counts and dates
    those (the second channel's come later, and cannot be read)."""
    path = tmp_path / "two.mcap"
    t0 = 1_704_067_200_000_000_000
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=2000, compression=CompressionType.ZSTD)
        w.start()
        odom = w.register_channel(topics.ODOM, "json",
                                  w.register_schema("lgvtool.Odometry", "jsonschema", b"{}"))
        for i in range(600):
            t = t0 + i * 10**7
            if i == 100:
                pose = w.register_channel(topics.NAV_POSE, "json", w.register_schema(
                    "lgvtool.NavPose", "jsonschema", b"{}"))
            w.add_message(odom, t, b'{"v":%d}' % i, t)
            if i >= 100:
                w.add_message(pose, t + 5 * 10**6, b'{"x":1}', t + 5 * 10**6)
        w.finish()
    chunks = chunks_of(path)
    with open(path, "rb") as f:
        holder = next(ci for ci in chunks[1:] if any(
            op == OP_CHANNEL for _p, op, _n in records_of(load_chunk(f, ci).records)))
        size = int(path.stat().st_size * 0.8)
        kept = [ci for ci in chunks
                if ci.chunk_start_offset + ci.chunk_length <= size and ci is not holder]
        want = sorted((topics.ODOM, t, d) for ci in kept
                      for t, _c, _p, d in chunk_messages(load_chunk(f, ci).records, {odom}))
    raw = bytearray(path.read_bytes()[:size])
    raw[holder.chunk_start_offset + holder.chunk_length - holder.compressed_size // 2] ^= 0x10
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    reader = opened(bad, monkeypatch, salvage=False)
    assert reader.topic_names() == [topics.ODOM]
    assert list(reader.corrupt_chunks) == [holder.chunk_start_offset]
    got = readings(reader)
    assert got["record_chunks"] is None  # its records hold messages that cannot be read
    msgs = consistent(got)
    assert msgs == want and 300 < len(want) < 500
    said = next(w for w in reader.warnings if "incomplete log" in w)
    assert (f"salvaged {len(msgs)} complete messages, last message at "
            f"{msgs[-1][1] / 1e9:.3f} s") in said
