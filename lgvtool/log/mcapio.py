"""A lean MCAP writer and chunk reader for lgvtool's hot paths.

The ``mcap`` package's own Writer and Reader are correct but spend tens of microseconds per
message; a one-hour log holds about 200 000 messages. This module packs message records
directly into the chunk buffer, reads chunks with one decompression and a tight
``struct.unpack_from`` loop, and copies whole chunks of another file verbatim (no decoding),
which is what ``replay`` and ``decode`` do with the input's messages. Records that occur rarely
(schemas, channels, metadata, summary) are written with the ``mcap`` package's record classes.
Files written here are ordinary MCAP (checked by the ``mcap`` package's reader in the tests).
"""

from __future__ import annotations

import heapq
import struct
import zlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import IO

import lz4.frame
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

MAGIC = b"\x89MCAP0\r\n"
_MSG_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish
_REC_HEAD = struct.Struct("<BQ")
_MSG_FIELDS = struct.Struct("<HIQQ")
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, crc
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")


def _compress(kind: str, data: bytes) -> bytes:
    if kind == "zstd":
        return zstandard.ZstdCompressor(level=3).compress(data)
    if kind == "lz4":
        return bytes(lz4.frame.compress(data))
    return data


def decompress(kind: str, data: bytes, size: int) -> bytes:
    """Uncompressed records of a chunk compressed with ``kind`` ('', 'zstd', 'lz4')."""
    if kind == "zstd":
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if kind == "lz4":
        return bytes(lz4.frame.decompress(data))
    if kind == "":
        return data
    raise ValueError(f"unsupported chunk compression {kind!r}")


@dataclass
class _OpenChunk:
    buf: bytearray = field(default_factory=bytearray)
    start: int = 0
    end: int = 0
    count: int = 0
    index: dict[int, list[tuple[int, int]]] = field(default_factory=dict)


class McapWriter:
    """Write an MCAP file: chunked, indexed, with a summary. Times in ns.

    :param stream: a binary stream opened for writing.
    :param compression: 'zstd', 'lz4' or 'none'.
    :param chunk_bytes: close a chunk once it holds this many uncompressed bytes.
    """

    def __init__(self, stream: IO[bytes], *, compression: str = "zstd",
                 chunk_bytes: int = 4 * 1024 * 1024, profile: str = "", library: str = "") -> None:
        self._out = stream
        self._compression = "" if compression == "none" else compression
        self._chunk_bytes = chunk_bytes
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._message_count = 0
        self._start = 0
        self._end = 0
        self._chunk = _OpenChunk()
        self._pos = 0
        self._emit(MAGIC)
        b = RecordBuilder()
        Header(profile=profile, library=library).write(b)
        self._emit(b.end())

    def _emit(self, data: bytes | bytearray | memoryview) -> None:
        self._out.write(data)
        self._pos += len(data)

    # ------------------------------------------------------------------ registration
    def add_schema(self, name: str, encoding: str, data: bytes, schema_id: int | None = None) -> int:
        """Register a schema (written into the next chunk and the summary); returns its id."""
        sid = schema_id if schema_id is not None else max(self._schemas, default=0) + 1
        if sid in self._schemas:
            raise ValueError(f"schema id {sid} is taken")
        schema = Schema(id=sid, name=name, encoding=encoding, data=data)
        self._schemas[sid] = schema
        self._put_record(schema)
        return sid

    def add_channel(self, topic: str, message_encoding: str, schema_id: int,
                    channel_id: int | None = None, metadata: dict[str, str] | None = None) -> int:
        """Register a channel (written into the next chunk and the summary); returns its id."""
        cid = channel_id if channel_id is not None else max(self._channels, default=0) + 1
        if cid in self._channels:
            raise ValueError(f"channel id {cid} is taken")
        channel = Channel(id=cid, topic=topic, message_encoding=message_encoding,
                          schema_id=schema_id, metadata=metadata or {})
        self._channels[cid] = channel
        self._put_record(channel)
        return cid

    def _put_record(self, record: Schema | Channel) -> None:
        b = RecordBuilder()
        record.write(b)
        self._chunk.buf += b.end()

    # ------------------------------------------------------------------ messages
    def add_message(self, channel_id: int, log_time: int, data: bytes,
                    publish_time: int | None = None, sequence: int = 0) -> None:
        """Append one message record to the open chunk."""
        c = self._chunk
        if c.count == 0:
            c.start = c.end = log_time
        elif log_time < c.start:
            c.start = log_time
        elif log_time > c.end:
            c.end = log_time
        entries = c.index.get(channel_id)
        if entries is None:
            entries = c.index[channel_id] = []
        entries.append((log_time, len(c.buf)))
        c.buf += _MSG_HEAD.pack(5, 22 + len(data), channel_id, sequence, log_time,
                                log_time if publish_time is None else publish_time)
        c.buf += data
        c.count += 1
        self._counts[channel_id] = self._counts.get(channel_id, 0) + 1
        if len(c.buf) >= self._chunk_bytes:
            self.close_chunk()

    @property
    def chunk_open(self) -> bool:
        """Whether the open chunk holds any message."""
        return self._chunk.count > 0

    def close_chunk(self) -> None:
        """Compress and write the open chunk and its message indexes (no-op when empty)."""
        c = self._chunk
        if c.count == 0:
            return
        data = bytes(c.buf)
        compressed = _compress(self._compression, data)
        start_offset = self._pos
        b = RecordBuilder()
        Chunk(message_start_time=c.start, message_end_time=c.end, uncompressed_size=len(data),
              uncompressed_crc=zlib.crc32(data), compression=self._compression,
              data=compressed).write(b)
        chunk_record = b.end()
        self._emit(chunk_record)
        mi_start = self._pos
        offsets: dict[int, int] = {}
        parts: list[bytes] = []
        for cid, entries in c.index.items():
            offsets[cid] = self._pos + sum(len(p) for p in parts)
            body = b"".join(_U64.pack(t) + _U64.pack(o) for t, o in entries)
            parts.append(struct.pack("<BQHI", Opcode.MESSAGE_INDEX, 6 + len(body), cid, len(body))
                         + body)
        blob = b"".join(parts)
        self._emit(blob)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=c.start, message_end_time=c.end, chunk_start_offset=start_offset,
            chunk_length=len(chunk_record), message_index_offsets=offsets,
            message_index_length=self._pos - mi_start, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=len(data)))
        self._note_times(c.start, c.end, c.count)
        self._chunk = _OpenChunk()

    def _note_times(self, start: int, end: int, count: int) -> None:
        if self._message_count == 0:
            self._start, self._end = start, end
        else:
            self._start = min(self._start, start)
            self._end = max(self._end, end)
        self._message_count += count

    def copy_chunks(self, source: IO[bytes], chunk_indexes: Iterable[ChunkIndex],
                    channel_counts: dict[int, int]) -> None:
        """Copy whole chunks of another MCAP file verbatim, with their message indexes.

        The caller must have registered the source's schemas and channels here under the same
        ids; ``channel_counts`` (from the source's statistics) adds to this file's statistics.
        """
        self.close_chunk()
        count = 0
        for ci in chunk_indexes:
            source.seek(ci.chunk_start_offset)
            record = source.read(ci.chunk_length)
            mi_old = min(ci.message_index_offsets.values(), default=ci.chunk_start_offset
                         + ci.chunk_length)
            source.seek(mi_old)
            indexes = source.read(ci.message_index_length)
            new_start = self._pos
            self._emit(record)
            new_mi = self._pos
            self._emit(indexes)
            self._chunk_indexes.append(ChunkIndex(
                message_start_time=ci.message_start_time, message_end_time=ci.message_end_time,
                chunk_start_offset=new_start, chunk_length=ci.chunk_length,
                message_index_offsets={k: v - mi_old + new_mi
                                       for k, v in ci.message_index_offsets.items()},
                message_index_length=ci.message_index_length, compression=ci.compression,
                compressed_size=ci.compressed_size, uncompressed_size=ci.uncompressed_size))
            if ci.message_index_offsets:
                self._note_times(ci.message_start_time, ci.message_end_time, 0)
        for cid, n in channel_counts.items():
            self._counts[cid] = self._counts.get(cid, 0) + n
            count += n
        self._message_count += count

    # ------------------------------------------------------------------ metadata, end
    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a metadata record (closes the open chunk first, to keep time order)."""
        self.close_chunk()
        b = RecordBuilder()
        Metadata(name=name, metadata=data).write(b)
        record = b.end()
        self._metadata_indexes.append(MetadataIndex(offset=self._pos, length=len(record), name=name))
        self._emit(record)

    def finish(self) -> None:
        """Close the open chunk and write the summary, footer and closing magic."""
        self.close_chunk()
        b = RecordBuilder()
        DataEnd(data_section_crc=0).write(b)
        self._emit(b.end())
        summary_start = self._pos
        s = RecordBuilder()
        offsets: list[SummaryOffset] = []

        def group(opcode: Opcode, records: Iterable[object]) -> None:
            begin = s.count
            for r in records:
                r.write(s)  # type: ignore[attr-defined]
            if s.count > begin:
                offsets.append(SummaryOffset(group_opcode=opcode, group_start=summary_start + begin,
                                             group_length=s.count - begin))

        group(Opcode.SCHEMA, self._schemas.values())
        group(Opcode.CHANNEL, self._channels.values())
        group(Opcode.STATISTICS, [Statistics(
            message_count=self._message_count, schema_count=len(self._schemas),
            channel_count=len(self._channels), attachment_count=0,
            metadata_count=len(self._metadata_indexes), chunk_count=len(self._chunk_indexes),
            message_start_time=self._start, message_end_time=self._end,
            channel_message_counts=dict(self._counts))])
        group(Opcode.CHUNK_INDEX, self._chunk_indexes)
        group(Opcode.METADATA_INDEX, self._metadata_indexes)
        offset_start = summary_start + s.count
        for o in offsets:
            o.write(s)
        summary = s.end()
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start, offset_start), crc)
        self._emit(summary)
        f = RecordBuilder()
        Footer(summary_start=summary_start, summary_offset_start=offset_start, summary_crc=crc).write(f)
        self._emit(f.end())
        self._emit(MAGIC)
        self._out.flush()


# ---------------------------------------------------------------------- reading


def chunk_messages(records: bytes, wanted: set[int] | None) -> list[tuple[int, int, int, bytes]]:
    """The message records in a chunk's uncompressed ``records``, as
    (log_time, channel_id, publish_time, data), in stored order; only ``wanted`` channels."""
    out = []
    pos, n = 0, len(records)
    rec_head, fields = _REC_HEAD.unpack_from, _MSG_FIELDS.unpack_from
    while pos + 9 <= n:
        opcode, length = rec_head(records, pos)
        body = pos + 9
        if opcode == 5:
            cid, _seq, log_time, pub = fields(records, body)
            if wanted is None or cid in wanted:
                out.append((log_time, cid, pub, records[body + 22 : body + length]))
        pos = body + length
    return out


def iter_indexed(stream: IO[bytes], chunk_indexes: list[ChunkIndex],
                 wanted: set[int] | None) -> Iterator[tuple[int, int, int, bytes]]:
    """Messages of the ``wanted`` channels in log-time order across (possibly overlapping)
    chunks: (log_time, channel_id, publish_time, data). Chunks are read lazily."""
    order = sorted((ci for ci in chunk_indexes
                    if wanted is None or not ci.message_index_offsets
                    or wanted & ci.message_index_offsets.keys()),
                   key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))

    def load(ci: ChunkIndex) -> list[tuple[int, int, int, bytes]]:
        stream.seek(ci.chunk_start_offset + 9)
        head = stream.read(_CHUNK_HEAD.size + 4)
        _s, _e, size, _crc = _CHUNK_HEAD.unpack_from(head)
        (clen,) = _U32.unpack_from(head, _CHUNK_HEAD.size)
        kind = stream.read(clen).decode()
        (dlen,) = _U64.unpack(stream.read(8))
        msgs = chunk_messages(decompress(kind, stream.read(dlen), size), wanted)
        msgs.sort(key=lambda m: m[0])
        return msgs

    heap: list[tuple[int, int, int, int, int, bytes]] = []
    seq = 0
    i = 0
    while i < len(order) or heap:
        if not heap and i < len(order):
            ci = order[i]
            i += 1
            msgs = load(ci)
            # fast path: this chunk ends before the next one starts -> no merging needed
            if i >= len(order) or ci.message_end_time < order[i].message_start_time:
                yield from msgs
                continue
            for m in msgs:
                heapq.heappush(heap, (m[0], seq, m[1], m[2], 0, m[3]))
                seq += 1
            continue
        t = heap[0][0]
        while i < len(order) and order[i].message_start_time <= t:
            for m in load(order[i]):
                heapq.heappush(heap, (m[0], seq, m[1], m[2], 0, m[3]))
                seq += 1
            i += 1
        lt, _, cid, pub, _, data = heapq.heappop(heap)
        yield lt, cid, pub, data
