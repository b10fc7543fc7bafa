"""The checks of the reference MCAP CLI's ``mcap doctor``, on the ``mcap`` package's records.

Independent of lgvtool's own reader: every record is parsed by the ``mcap`` PyPI package.
:func:`diagnose` returns the errors and warnings ``mcap doctor`` reports for a file (same
checks, same wording), so that the tests hold every file lgvtool writes to the reference
checker's standard where its binary is not installed; :func:`doctor_binary` runs the binary
itself when it is on PATH.
"""

from __future__ import annotations

import shutil
import subprocess
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lz4.frame
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    Schema,
    Statistics,
)
from mcap.stream_reader import StreamReader


@dataclass
class Diagnosis:
    """What ``mcap doctor`` would say of a file, and the messages it counted."""

    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    message_count: int = 0
    channel_counts: dict[int, int] = field(default_factory=dict)
    min_log_time: int | None = None
    max_log_time: int = 0
    statistics: Statistics | None = None

    @property
    def clean(self) -> bool:
        """No error and no warning."""
        return not self.errors and not self.warnings


class _Doctor:
    def __init__(self) -> None:
        self.d = Diagnosis()
        self.schemas: dict[int, Schema] = {}
        self.channels: dict[int, Channel] = {}
        self.summary_schemas: set[int] = set()
        self.summary_channels: set[int] = set()
        self.chunk_channels: dict[int, set[int]] = {}
        self.in_summary = False
        self._content: dict[str, dict[int, tuple[Any, ...]]] = {}

    def _seen(self, kind: str, rec: Any, content: tuple[Any, ...], data: dict[int, Any],
              summary: set[int]) -> None:
        """A schema or channel record: same content as an earlier one of its id, and once in
        the data section (a duplicate there is warned of), again in the summary."""
        d = self.d
        prev = data.get(rec.id)
        key = self._content.setdefault(kind, {})
        if prev is not None and key[rec.id] != content:
            d.errors.append(f"Two {kind} records with same ID {rec.id} but different content")
        if self.in_summary:
            if prev is None:
                d.errors.append(f"{kind.title()} with ID {rec.id} in summary section does not "
                                "exist in data section")
            summary.add(rec.id)
        else:
            if prev is not None:
                d.warnings.append(f"Duplicate {kind} records in data section with ID {rec.id}")
            data[rec.id] = rec
            key[rec.id] = content

    def schema(self, s: Schema) -> None:
        d = self.d
        if s.encoding == "":
            if s.data:
                d.errors.append(f"Schema with ID: {s.id} has empty Encoding but Data")
            else:
                d.warnings.append(f"Schema with ID: {s.id} has empty Encoding and Data fields")
        if s.id == 0:
            d.errors.append("Schema.ID 0 is reserved")
        self._seen("schema", s, (s.name, s.encoding, s.data), self.schemas,
                   self.summary_schemas)

    def channel(self, c: Channel) -> None:
        d = self.d
        self._seen("channel", c, (c.schema_id, c.topic, c.message_encoding, c.metadata),
                   self.channels, self.summary_channels)
        if c.schema_id != 0 and c.schema_id not in self.schemas:
            d.errors.append(f"Encountered Channel ({c.id}) with unknown Schema ({c.schema_id})")

    def chunk(self, chunk: Chunk, offset: int, indexes: dict[int, MessageIndex]) -> None:
        d = self.d
        if chunk.compression == "zstd":
            data = zstandard.ZstdDecompressor().decompress(
                chunk.data, max_output_size=chunk.uncompressed_size)
        elif chunk.compression == "lz4":
            data = lz4.frame.decompress(chunk.data)
        elif chunk.compression == "":
            data = chunk.data
        else:
            d.errors.append(f"Unsupported compression format: {chunk.compression!r}")
            return
        if len(data) != chunk.uncompressed_size:
            d.errors.append("Uncompressed chunk data size != Chunk.uncompressed_size")
            return
        if chunk.uncompressed_crc != 0 and zlib.crc32(data) != chunk.uncompressed_crc:
            d.errors.append("invalid CRC")
            return
        import io

        stream = ReadDataStream(io.BytesIO(data))
        lo, hi, n = None, 0, 0
        referenced: set[int] = set()
        while stream.count < len(data):
            at = stream.count
            opcode = stream.read1()
            length = stream.read8()
            if opcode == 0x03:
                self.schema(Schema.read(stream))
            elif opcode == 0x04:
                self.channel(Channel.read(stream))
            elif opcode == 0x05:
                m = Message.read(stream, length)
                referenced.add(m.channel_id)
                ch = self.channels.get(m.channel_id)
                if ch is None:
                    d.errors.append(f"Got a Message record for channel: {m.channel_id} before a "
                                    "channel record.")
                topic = ch.topic if ch else "?"
                if m.log_time < d.max_log_time:
                    d.warnings.append(f"Message.log_time {m.log_time} on {topic!r} is less than "
                                      f"the latest log time {d.max_log_time}")
                lo = m.log_time if lo is None else min(lo, m.log_time)
                hi = max(hi, m.log_time)
                d.max_log_time = max(d.max_log_time, m.log_time)
                n += 1
                d.message_count += 1
                d.channel_counts[m.channel_id] = d.channel_counts.get(m.channel_id, 0) + 1
                mi = indexes.get(m.channel_id)
                if mi is None:
                    d.warnings.append(f"No MessageIndex record found for channel {m.channel_id}")
                else:
                    hits = [t for t, o in mi.records if o == at]
                    if not hits:
                        d.warnings.append(f"No MessageIndex entry found for message channel "
                                          f"{m.channel_id} at offset {at}")
                    elif hits[0] != m.log_time:
                        d.errors.append(f"MessageIndex entry for channel {m.channel_id} at "
                                        f"offset {at} has timestamp {hits[0]}, but message has "
                                        f"timestamp {m.log_time}")
            else:
                d.errors.append(f"Illegal record in chunk: {opcode}")
                stream.read(length)
        if n:
            if lo != chunk.message_start_time:
                d.errors.append(f"Chunk.message_start_time {chunk.message_start_time} does not "
                                f"match the earliest message log time {lo}")
            if hi != chunk.message_end_time:
                d.errors.append(f"Chunk.message_end_time {chunk.message_end_time} does not "
                                f"match the latest message log time {hi}")
            assert lo is not None
            d.min_log_time = lo if d.min_log_time is None else min(d.min_log_time, lo)
        self.chunk_channels[offset] = referenced


def diagnose(path: str | Path) -> Diagnosis:
    """The errors and warnings ``mcap doctor`` reports for the MCAP file ``path``."""
    doc = _Doctor()
    d = doc.d
    raw = Path(path).read_bytes()
    chunk_offsets: list[int] = []
    # a second pass over the raw bytes gives each chunk's offset (the stream reader hides it)
    pos = 8
    while pos + 9 <= len(raw):
        opcode = raw[pos]
        length = int.from_bytes(raw[pos + 1:pos + 9], "little")
        if opcode == 0x06:
            chunk_offsets.append(pos)
        if opcode == 0x02:
            break
        pos += 9 + length
    records = list(StreamReader(str(path), emit_chunks=True, validate_crcs=True).records)
    chunk_indexes: dict[int, ChunkIndex] = {}
    pending: tuple[Chunk, int, dict[int, MessageIndex]] | None = None
    data_end = footer = None
    n_chunk = 0
    for r in records:
        if not isinstance(r, MessageIndex) and pending is not None:
            doc.chunk(*pending)
            pending = None
        if isinstance(r, Header):
            if r.library == "":
                d.warnings.append("Set the Header.library field")
            if r.profile not in ("", "ros1", "ros2"):
                d.warnings.append(f"Header.profile field {r.profile!r} is not a well-known "
                                  "profile.")
        elif isinstance(r, Schema):
            doc.schema(r)
        elif isinstance(r, Channel):
            doc.channel(r)
        elif isinstance(r, Message):
            d.errors.append("Message record outside a chunk")
        elif isinstance(r, Chunk):
            pending = (r, chunk_offsets[n_chunk], {})
            n_chunk += 1
        elif isinstance(r, MessageIndex):
            if pending is None:
                d.errors.append("Message index found but no chunk before it")
            elif r.channel_id in pending[2]:
                d.warnings.append(f"Duplicate message index found for channel {r.channel_id}")
            else:
                pending[2][r.channel_id] = r
        elif isinstance(r, ChunkIndex):
            if r.chunk_start_offset in chunk_indexes:
                d.errors.append(f"Multiple chunk indexes found for chunk at offset "
                                f"{r.chunk_start_offset}")
            chunk_indexes[r.chunk_start_offset] = r
        elif isinstance(r, Statistics):
            if d.statistics is not None:
                d.errors.append("File contains multiple Statistics records")
            d.statistics = r
        elif isinstance(r, DataEnd):
            data_end = r
            doc.in_summary = True
        elif isinstance(r, Footer):
            footer = r
    if pending is not None:
        doc.chunk(*pending)
    if data_end is None:
        d.errors.append("File does not contain a DataEnd record")
    if footer is None:
        d.errors.append("File does not contain a Footer record")
    by_offset = dict(zip(chunk_offsets, [r for r in records if isinstance(r, Chunk)],
                         strict=True))
    for offset, ci in chunk_indexes.items():
        for cid in doc.chunk_channels.get(offset, set()):
            if cid not in doc.summary_channels:
                d.errors.append(f"Indexed chunk at offset {offset} contains messages "
                                f"referencing channel ({cid}) not duplicated in summary section")
            ch = doc.channels.get(cid)
            if ch is not None and ch.schema_id not in doc.summary_schemas:
                d.errors.append(f"Indexed chunk at offset {offset} contains messages "
                                f"referencing schema ({ch.schema_id}) not duplicated in summary "
                                "section")
        chunk = by_offset.get(offset)
        if chunk is None:
            d.errors.append(f"Chunk index points to offset {offset} but no chunk is there")
            continue
        length = int.from_bytes(raw[offset + 1:offset + 9], "little")
        if ci.chunk_length != 9 + length:
            d.errors.append(f"Chunk index {offset} length mismatch")
        for what, a, b in (("message start time", chunk.message_start_time,
                            ci.message_start_time),
                           ("message end time", chunk.message_end_time, ci.message_end_time),
                           ("compression", chunk.compression, ci.compression),
                           ("compressed size", len(chunk.data), ci.compressed_size),
                           ("uncompressed size", chunk.uncompressed_size,
                            ci.uncompressed_size)):
            if a != b:
                d.errors.append(f"Chunk at offset {offset} has {what} {a}, but its chunk index "
                                f"has {what} {b}")
    st = d.statistics
    if st is not None:
        if d.message_count > 0:
            if st.message_start_time != d.min_log_time:
                d.errors.append(f"Statistics has message start time {st.message_start_time}, "
                                f"but the minimum message start time is {d.min_log_time}")
            if st.message_end_time != d.max_log_time:
                d.errors.append(f"Statistics has message end time {st.message_end_time}, but "
                                f"the maximum message end time is {d.max_log_time}")
        if st.message_count != d.message_count:
            d.errors.append(f"Statistics has message count {st.message_count}, but actual "
                            f"number of messages is {d.message_count}")
        for cid, n in d.channel_counts.items():
            if st.channel_message_counts.get(cid, 0) != n:
                d.errors.append(f"Statistics has message count "
                                f"{st.channel_message_counts.get(cid, 0)} for channel {cid}, "
                                f"but actual number of messages is {n}")
    return d


def doctor_binary() -> str | None:
    """The reference ``mcap`` CLI on PATH, or None."""
    return shutil.which("mcap")


def run_doctor(path: str | Path) -> subprocess.CompletedProcess[str]:
    """``mcap doctor PATH`` of the reference CLI (which must be on PATH)."""
    exe = doctor_binary()
    assert exe is not None
    return subprocess.run([exe, "doctor", str(path)], capture_output=True, text=True,
                          timeout=120, check=False)


def statistics_errors(path: str | Path) -> list[str]:
    """Where the Statistics record of ``path`` disagrees with the messages in the file (first
    and last log time, total and per-channel counts), read by the ``mcap`` package's reader."""
    from mcap.reader import make_reader

    with open(path, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        st = summary.statistics if summary is not None else None
        if st is None:
            return ["no Statistics record"]
        counts: dict[int, int] = {}
        lo: int | None = None
        hi: int | None = None
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            counts[channel.id] = counts.get(channel.id, 0) + 1
            lo = message.log_time if lo is None else min(lo, message.log_time)
            hi = message.log_time if hi is None else max(hi, message.log_time)
    out = []
    if counts and (st.message_start_time, st.message_end_time) != (lo, hi):
        out.append(f"Statistics spans {st.message_start_time}..{st.message_end_time} ns, the "
                   f"messages {lo}..{hi} ns")
    if st.message_count != sum(counts.values()):
        out.append(f"Statistics counts {st.message_count} messages, the file holds "
                   f"{sum(counts.values())}")
    stated = {k: v for k, v in st.channel_message_counts.items() if v}
    if stated != counts:
        out.append(f"Statistics counts per channel {stated}, the file holds {counts}")
    if st.channel_count != len(summary.channels) or st.schema_count != len(summary.schemas):
        out.append("Statistics channel or schema count differs from the summary's records")
    if st.chunk_count != len(summary.chunk_indexes):
        out.append("Statistics chunk count differs from the chunk indexes")
    return out


def assert_reference_clean(path: str | Path) -> None:
    """``path`` passes ``mcap doctor``'s checks with no error and no warning, and its
    Statistics record matches its messages."""
    d = diagnose(path)
    assert d.errors == [] and d.warnings == [], (d.errors[:5], d.warnings[:5],
                                                 len(d.warnings))
    assert statistics_errors(path) == []


def schema_errors(path: str | Path) -> list[str]:
    """Messages of ``path`` that do not validate against the JSON Schema embedded with their
    channel (one line each: topic, log time, the validator's message), via the ``mcap``
    package's reader."""
    import json

    import jsonschema
    from mcap.reader import make_reader

    validators: dict[int, jsonschema.protocols.Validator] = {}
    out = []
    with open(path, "rb") as f:
        for schema, channel, message in make_reader(f).iter_messages(log_time_order=False):
            assert schema is not None and schema.encoding == "jsonschema"
            v = validators.get(schema.id)
            if v is None:
                v = validators[schema.id] = jsonschema.Draft202012Validator(
                    json.loads(schema.data))
            for e in v.iter_errors(json.loads(message.data)):
                out.append(f"{channel.topic} @ {message.log_time}: {e.message}")
    return out
