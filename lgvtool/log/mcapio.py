"""A lean MCAP writer and chunk reader for lgvtool's hot paths.

The ``mcap`` package's own Writer and Reader are correct but spend tens of microseconds per
message; a one-hour log holds about 200 000 messages. This module packs message records
directly into the chunk buffer, reads chunks with one decompression and a tight
``struct.unpack_from`` loop, and copies whole chunks of another file verbatim (no decoding),
which is what ``replay`` and ``decode`` do with the input's messages. The other records
(header, schemas, channels, metadata, summary, footer) are packed and parsed here too, so
that reading and writing an indexed file does not import the ``mcap`` package (only the
salvage of a cut-off file uses its stream reader). Files written here are ordinary MCAP
(checked by the ``mcap`` package's reader in the tests).
"""

from __future__ import annotations

import heapq
import os
import struct
import zlib
from array import array
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import IO, TYPE_CHECKING, Any

import lz4.frame
import zstandard

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

MAGIC = b"\x89MCAP0\r\n"
_MSG_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish
#: the same head as a packed numpy record (31 bytes), to pack many at once
_MSG_HEAD_DTYPE = [("opcode", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"),
                   ("log_time", "<u8"), ("publish_time", "<u8")]
_REC_HEAD = struct.Struct("<BQ")
_MSG_FIELDS = struct.Struct("<HIQQ")
_CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, crc
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_U64 = struct.Struct("<Q")
_MI_HEAD = struct.Struct("<BQHI")  # message index: opcode, record length, channel, array bytes
_MAP_ENTRY = struct.Struct("<HQ")  # channel id -> u64 (chunk index offsets, statistics counts)

# record opcodes (MCAP specification)
OP_HEADER = 0x01
OP_FOOTER = 0x02
OP_SCHEMA = 0x03
OP_CHANNEL = 0x04
OP_MESSAGE = 0x05
OP_CHUNK = 0x06
OP_MESSAGE_INDEX = 0x07
OP_CHUNK_INDEX = 0x08
OP_STATISTICS = 0x0B
OP_METADATA = 0x0C
OP_METADATA_INDEX = 0x0D
OP_SUMMARY_OFFSET = 0x0E
OP_DATA_END = 0x0F


class _Record:
    """A plain record: the fields ``_fields`` (in order), set by position or keyword."""

    __slots__: tuple[str, ...] = ()
    _fields: tuple[str, ...] = ()

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        for name, value in zip(self._fields, args, strict=False):
            setattr(self, name, value)
        for name, value in kwargs.items():
            setattr(self, name, value)

    def __repr__(self) -> str:
        fields = ", ".join(f"{n}={getattr(self, n)!r}" for n in self._fields)
        return f"{type(self).__name__}({fields})"

    def __eq__(self, other: object) -> bool:
        return type(other) is type(self) and all(
            getattr(self, n) == getattr(other, n) for n in self._fields)

    __hash__ = None  # type: ignore[assignment]


class Schema(_Record):
    """A schema record."""

    _fields = ("id", "name", "encoding", "data")
    __slots__ = ("data", "encoding", "id", "name")
    id: int
    name: str
    encoding: str
    data: bytes


class Channel(_Record):
    """A channel record."""

    _fields = ("id", "topic", "message_encoding", "schema_id", "metadata")
    __slots__ = ("id", "message_encoding", "metadata", "schema_id", "topic")
    id: int
    topic: str
    message_encoding: str
    schema_id: int
    metadata: dict[str, str]


class Metadata(_Record):
    """A metadata record: its name and string map."""

    _fields = ("name", "metadata")
    __slots__ = ("metadata", "name")
    name: str
    metadata: dict[str, str]


class MetadataIndex(_Record):
    """Where a metadata record is: file offset and length in bytes, and its name."""

    _fields = ("offset", "length", "name")
    __slots__ = ("length", "name", "offset")
    offset: int
    length: int
    name: str


class ChunkIndex(_Record):
    """A chunk index record: times in ns, offsets and sizes in bytes."""

    _fields = ("message_start_time", "message_end_time", "chunk_start_offset", "chunk_length",
               "message_index_offsets", "message_index_length", "compression",
               "compressed_size", "uncompressed_size")
    __slots__ = ("chunk_length", "chunk_start_offset", "compressed_size", "compression",
                 "message_end_time", "message_index_length", "message_index_offsets",
                 "message_start_time", "uncompressed_size")
    def __init__(self, message_start_time: int, message_end_time: int,
                 chunk_start_offset: int, chunk_length: int,
                 message_index_offsets: dict[int, int], message_index_length: int,
                 compression: str, compressed_size: int, uncompressed_size: int) -> None:
        self.message_start_time = message_start_time
        self.message_end_time = message_end_time
        self.chunk_start_offset = chunk_start_offset
        self.chunk_length = chunk_length
        self.message_index_offsets = message_index_offsets
        self.message_index_length = message_index_length
        self.compression = compression
        self.compressed_size = compressed_size
        self.uncompressed_size = uncompressed_size


class Summary(_Record):
    """The summary section of an indexed file. ``channel_message_counts`` is None when the
    file has no statistics record."""

    _fields = ("schemas", "channels", "chunk_indexes", "metadata_indexes",
               "channel_message_counts")
    __slots__ = ("channel_message_counts", "channels", "chunk_indexes", "metadata_indexes",
                 "schemas")
    schemas: dict[int, Schema]
    channels: dict[int, Channel]
    chunk_indexes: list[ChunkIndex]
    metadata_indexes: list[MetadataIndex]
    channel_message_counts: dict[int, int] | None


# ---------------------------------------------------------------------- packing


def _str(text: str) -> bytes:
    raw = text.encode()
    return _U32.pack(len(raw)) + raw


def _string_map(entries: Mapping[str, str]) -> bytes:
    body = b"".join(_str(k) + _str(v) for k, v in entries.items())
    return _U32.pack(len(body)) + body


def _id_map(entries: Mapping[int, int]) -> bytes:
    return _U32.pack(10 * len(entries)) + b"".join(_MAP_ENTRY.pack(k, v)
                                                   for k, v in entries.items())


def record(opcode: int, body: bytes) -> bytes:
    """One MCAP record: opcode, length and ``body``."""
    return _REC_HEAD.pack(opcode, len(body)) + body


def schema_record(s: Schema) -> bytes:
    """The record of a schema."""
    return record(OP_SCHEMA, _U16.pack(s.id) + _str(s.name) + _str(s.encoding)
                  + _U32.pack(len(s.data)) + s.data)


def channel_record(c: Channel) -> bytes:
    """The record of a channel."""
    return record(OP_CHANNEL, _U16.pack(c.id) + _U16.pack(c.schema_id) + _str(c.topic)
                  + _str(c.message_encoding) + _string_map(c.metadata))


_CHUNK_INDEX_LAYOUTS: dict[tuple[int, int], struct.Struct] = {}


def chunk_index_record(ci: ChunkIndex) -> bytes:
    """The record of a chunk index."""
    kind = ci.compression.encode()
    key = (len(ci.message_index_offsets), len(kind))
    layout = _CHUNK_INDEX_LAYOUTS.get(key)
    if layout is None:
        n, k = key
        layout = _CHUNK_INDEX_LAYOUTS[key] = struct.Struct(
            f"<BQQQQQI{'HQ' * n}QI{k}sQQ")
    offsets = [v for item in ci.message_index_offsets.items() for v in item]
    return layout.pack(OP_CHUNK_INDEX, layout.size - 9, ci.message_start_time,
                       ci.message_end_time, ci.chunk_start_offset, ci.chunk_length,
                       10 * key[0], *offsets, ci.message_index_length, key[1], kind,
                       ci.compressed_size, ci.uncompressed_size)


# ---------------------------------------------------------------------- parsing


class _Cursor:
    """Reads MCAP primitives from a buffer."""

    __slots__ = ("buf", "pos")

    def __init__(self, buf: Any, pos: int = 0) -> None:
        self.buf = buf
        self.pos = pos

    def u8(self) -> int:
        v: int = self.buf[self.pos]
        self.pos += 1
        return v

    def u16(self) -> int:
        (v,) = _U16.unpack_from(self.buf, self.pos)
        self.pos += 2
        return int(v)

    def u32(self) -> int:
        (v,) = _U32.unpack_from(self.buf, self.pos)
        self.pos += 4
        return int(v)

    def u64(self) -> int:
        (v,) = _U64.unpack_from(self.buf, self.pos)
        self.pos += 8
        return int(v)

    def raw(self, n: int) -> bytes:
        v = bytes(self.buf[self.pos:self.pos + n])
        self.pos += n
        return v

    def string(self) -> str:
        return self.raw(self.u32()).decode()

    def string_map(self) -> dict[str, str]:
        end = self.pos + 4 + self.u32()
        out: dict[str, str] = {}
        while self.pos < end:
            k = self.string()
            out[k] = self.string()
        return out

    def id_map(self) -> dict[int, int]:
        n = self.u32()
        layout = _ID_MAPS.get(n)
        if layout is None:
            layout = _ID_MAPS[n] = struct.Struct("<" + "HQ" * (n // 10))
        flat = layout.unpack_from(self.buf, self.pos)
        self.pos += n
        return dict(zip(flat[0::2], flat[1::2], strict=True))


_ID_MAPS: dict[int, struct.Struct] = {}


def read_summary(f: IO[bytes]) -> Summary | None:
    """The summary section of an indexed MCAP file; None when it has none (or no footer)."""
    f.seek(0, os.SEEK_END)
    size = f.tell()
    tail = 9 + 20 + len(MAGIC)
    if size < len(MAGIC) + tail:
        return None
    f.seek(size - tail)
    foot = f.read(tail)
    if foot[-len(MAGIC):] != MAGIC or foot[0] != OP_FOOTER:
        return None
    summary_start, _offsets, _crc = struct.unpack_from("<QQI", foot, 9)
    if summary_start == 0:
        return None
    f.seek(summary_start)
    buf = f.read(size - tail - summary_start)
    check_summary_crc(buf, foot)
    out = Summary({}, {}, [], [], None)
    c = _Cursor(buf)
    while c.pos + 9 <= len(buf):
        opcode, length = _REC_HEAD.unpack_from(buf, c.pos)
        c.pos += 9
        end = c.pos + length
        if opcode == OP_CHUNK_INDEX:
            start_t, end_t, offset, clen = struct.unpack_from("<QQQQ", buf, c.pos)
            c.pos += 32
            offsets = c.id_map()
            milen = c.u64()
            kind = c.string()
            csize, usize = struct.unpack_from("<QQ", buf, c.pos)
            out.chunk_indexes.append(ChunkIndex(start_t, end_t, offset, clen, offsets, milen,
                                                kind, csize, usize))
        elif opcode == OP_SCHEMA:
            sid = c.u16()
            name, enc = c.string(), c.string()
            out.schemas[sid] = Schema(sid, name, enc, c.raw(c.u32()))
        elif opcode == OP_CHANNEL:
            cid, sid = c.u16(), c.u16()
            topic, enc = c.string(), c.string()
            out.channels[cid] = Channel(cid, topic, enc, sid, c.string_map())
        elif opcode == OP_STATISTICS:
            c.pos += 8 + 2 + 4 * 4 + 16
            out.channel_message_counts = c.id_map()
        elif opcode == OP_METADATA_INDEX:
            off, mlen = c.u64(), c.u64()
            out.metadata_indexes.append(MetadataIndex(off, mlen, c.string()))
        c.pos = end
    return out


class CorruptSummaryError(ValueError):
    """The summary section does not match the CRC-32 its footer gives."""


def check_summary_crc(summary: bytes, footer: bytes) -> None:
    """Check the summary section against the footer's CRC-32 (0: not computed).

    :param summary: the bytes from the summary start up to the footer record.
    :param footer: the footer record and closing magic.
    :raises CorruptSummaryError: the CRC differs.
    """
    (crc,) = _U32.unpack_from(footer, 9 + 16)
    if crc and zlib.crc32(footer[:9 + 16], zlib.crc32(summary)) != crc:
        raise CorruptSummaryError("the summary section does not match its CRC-32")


def data_section_crc(buf: Any, summary_start: int) -> tuple[int, int] | None:
    """The data section's stored CRC-32 (from the data end record before ``summary_start``)
    and the CRC-32 computed over the file up to that record; None when the file has no data
    end record there or its CRC is 0 ("not computed")."""
    end = summary_start - 13
    if end < len(MAGIC) or buf[end] != OP_DATA_END:
        return None
    (stored,) = _U32.unpack_from(buf, end + 9)
    if stored == 0:
        return None
    with memoryview(buf)[:end] as data:
        return stored, zlib.crc32(data)


def read_metadata(f: IO[bytes], index: MetadataIndex) -> Metadata:
    """The metadata record that ``index`` points at."""
    f.seek(index.offset)
    buf = f.read(index.length)
    c = _Cursor(buf, 9)
    name = c.string()
    return Metadata(name, c.string_map())


ZSTD_LEVEL = 1
"""zstd level of the chunks written: on lgvtool's logs (JSON messages) level 1 compresses
about twice as fast as level 3 and as small or smaller (docs/performance.md)."""

BACKGROUND_DEPTH = 4
"""Chunks a background-compressing writer may have waiting for its worker thread (4 MiB each
by default): bursts of fast filling (a copied log's chunks) then do not wait for the worker;
the file is the same."""


def _compress_with_crc(kind: str, data: bytes | bytearray) -> tuple[bytes, int]:
    """``data`` compressed, and its CRC-32 (both release the GIL for large buffers)."""
    return _compress(kind, data), zlib.crc32(data)


def _compress(kind: str, data: bytes | bytearray) -> bytes:
    if kind == "zstd":
        return zstandard.ZstdCompressor(level=ZSTD_LEVEL).compress(data)
    if kind == "lz4":
        return bytes(lz4.frame.compress(data))
    return bytes(data)


def decompress(kind: str, data: bytes | memoryview, size: int) -> bytes:
    """Uncompressed records of a chunk compressed with ``kind`` ('', 'zstd', 'lz4')."""
    if kind == "zstd":
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if kind == "lz4":
        return bytes(lz4.frame.decompress(data))
    if kind == "":
        return bytes(data)
    raise ValueError(f"unsupported chunk compression {kind!r}")


class _OpenChunk:
    """The chunk being filled: records, time span (ns), message count, the message index as
    three columns in record order (channel id, log time in ns, offset of the record in
    ``buf``), the last message's log time and whether the messages are in log-time order so
    far."""

    __slots__ = ("buf", "cids", "count", "end", "last", "offsets", "ordered", "start", "times")

    def __init__(self) -> None:
        self.buf = bytearray()
        self.start = 0
        self.end = 0
        self.count = 0
        self.last = 0
        self.ordered = True
        self.cids = array("H")
        self.times = array("Q")
        self.offsets = array("Q")

    def columns(self) -> tuple[NDArray[np.uint16], NDArray[np.uint64], NDArray[np.uint64]]:
        """The index columns as arrays (views of the columns, not copies)."""
        import numpy as np

        return (np.frombuffer(self.cids, np.uint16), np.frombuffer(self.times, np.uint64),
                np.frombuffer(self.offsets, np.uint64))

    def _set_index(self, cids: Any, times: Any, offsets: Any) -> None:
        self.cids = array("H", cids.astype("<u2").tobytes())
        self.times = array("Q", times.astype("<u8").tobytes())
        self.offsets = array("Q", offsets.astype("<u8").tobytes())
        self.count = len(self.cids)

    def sort(self) -> None:
        """Put the messages in log-time order (stable), after the schema and channel records
        (which move to the front, so each still precedes its channel's messages)."""
        import numpy as np

        buf = self.buf
        cids, times, offsets = self.columns()
        order = np.lexsort((offsets, times))
        out = bytearray()
        pos = 0
        while pos + 9 <= len(buf):
            opcode, length = _REC_HEAD.unpack_from(buf, pos)
            if opcode != OP_MESSAGE:
                out += buf[pos:pos + 9 + length]
            pos += 9 + length
        new_offsets = np.empty(len(order), np.uint64)
        for k, at in enumerate(offsets[order].tolist()):
            (length,) = _U64.unpack_from(buf, at + 1)
            new_offsets[k] = len(out)
            out += buf[at:at + 9 + length]
        self.buf = out
        self._set_index(cids[order], times[order], new_offsets)
        self.ordered = True

    def split_after(self, cutoff: int) -> _OpenChunk | None:
        """Move the messages newer than ``cutoff`` (ns), with every record after the first of
        them, into a new chunk and return it; None (nothing moved) when none is newer or none
        would stay. The messages must be in log-time order."""
        import numpy as np

        cids, times, offsets = self.columns()
        newer = times > cutoff
        if not newer.any() or newer.all():
            return None
        at = int(offsets[newer].min())
        moved = offsets >= at
        tail = _OpenChunk()
        tail.buf = self.buf[at:]
        del self.buf[at:]
        tail._set_index(cids[moved], times[moved], offsets[moved] - np.uint64(at))
        self._set_index(cids[~moved], times[~moved], offsets[~moved])
        self.start, self.end = int(times[~moved].min()), int(times[~moved].max())
        tail.start = int(times[moved].min())
        tail.end = tail.last = int(times[moved].max())
        return tail

    def message_indexes(self, at: int) -> tuple[dict[int, int], bytes]:
        """The Message Index records of this chunk, to be written at file offset ``at``: the
        offset of each channel's record (channels in order of their first message) and the
        records. Each lists the channel's messages in record order."""
        import numpy as np

        cids, times, offsets = self.columns()
        if not len(cids):
            return {}, b""
        order = np.argsort(cids, kind="stable")
        pairs = np.empty((len(order), 2), "<u8")
        pairs[:, 0] = times[order]
        pairs[:, 1] = offsets[order]
        flat = pairs.tobytes()
        ids, first, counts = np.unique(cids[order], return_index=True, return_counts=True)
        firsts = order[first]  # each channel's first message in record order
        out: dict[int, int] = {}
        parts: list[bytes] = []
        pos = at
        for k in np.argsort(firsts, kind="stable").tolist():
            cid, lo, n = int(ids[k]), int(first[k]), int(counts[k])
            body = flat[16 * lo:16 * (lo + n)]
            out[cid] = pos
            rec = _MI_HEAD.pack(OP_MESSAGE_INDEX, 6 + len(body), cid, len(body)) + body
            parts.append(rec)
            pos += len(rec)
        return out, b"".join(parts)


FramedRecords = tuple[bytes, "NDArray[np.uint16]", "NDArray[np.int64]", "NDArray[np.int64]"]
"""Message records one after the other, and their channel ids, log times (ns) and sizes
(bytes, opcode and length included)."""


def framed_records(channel_ids: Sequence[int], log_times: Sequence[int],
                   datas: Sequence[bytes]) -> FramedRecords:
    """The message records of ``datas`` (publish time = log time, sequence 0), one after the
    other, with their columns. The records' heads are packed as one array (the bytes of
    ``_MSG_HEAD.pack`` each; times must lie in 0 .. 2**63 - 1 ns)."""
    import numpy as np

    n = len(datas)
    sizes = np.fromiter(map(len, datas), np.int64, n)
    cids = np.asarray(channel_ids, dtype=np.uint16).reshape(n)
    times = np.asarray(log_times, dtype=np.int64).reshape(n)
    if n and int(times.min()) < 0:
        raise ValueError("a message's log time is before 1970 (negative ns)")
    heads = np.zeros(n, _MSG_HEAD_DTYPE)
    heads["opcode"] = OP_MESSAGE
    heads["length"] = sizes + (_MSG_HEAD.size - 9)
    heads["channel"] = cids
    heads["log_time"] = times
    heads["publish_time"] = times
    k = _MSG_HEAD.size
    parts: list[bytes] = [b""] * (2 * n)
    parts[0::2] = heads.view(f"V{k}").tolist()  # each head as bytes (a void item's bytes)
    parts[1::2] = datas
    return b"".join(parts), cids, times, sizes + k


class McapWriter:
    """Write an MCAP file: chunked, indexed, with a summary. Times in ns.

    :param stream: a binary stream opened for writing.
    :param compression: 'zstd', 'lz4' or 'none'.
    :param chunk_bytes: close a chunk once it holds this many uncompressed bytes.
    """

    def __init__(self, stream: IO[bytes], *, compression: str = "zstd",
                 chunk_bytes: int = 4 * 1024 * 1024, profile: str = "", library: str = "",
                 background: bool = False) -> None:
        self._out = stream
        #: compress each chunk on a worker thread while the next ones fill (the same bytes; a
        #: closed chunk reaches the stream once compressed, at a later close, at a metadata
        #: record or at the end)
        self._background = background
        self._pool: ThreadPoolExecutor | None = None
        # the chunks being compressed, oldest first (at most BACKGROUND_DEPTH)
        self._pending: deque[tuple[Future[tuple[bytes, int]], _OpenChunk, int]] = deque()
        self._compression = "" if compression == "none" else compression
        self._chunk_bytes = chunk_bytes
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._message_count = 0
        self._timed = False  # whether _start and _end hold a message's time yet
        self._start = 0
        self._end = 0
        self._chunk = _OpenChunk()
        self._pos = 0
        self._emit(MAGIC)
        self._emit(record(OP_HEADER, _str(profile) + _str(library)))

    def _emit(self, data: bytes | bytearray | memoryview) -> None:
        self._out.write(data)
        self._pos += len(data)

    # ------------------------------------------------------------------ registration
    def add_schema(self, name: str, encoding: str, data: bytes, schema_id: int | None = None,
                   *, in_data: bool = True) -> int:
        """Register a schema (written into the next chunk and the summary); returns its id.
        ``in_data=False``: the summary only (chunks copied from another file carry it)."""
        sid = schema_id if schema_id is not None else max(self._schemas, default=0) + 1
        if sid in self._schemas:
            raise ValueError(f"schema id {sid} is taken")
        schema = Schema(sid, name, encoding, data)
        self._schemas[sid] = schema
        if in_data:
            self._chunk.buf += schema_record(schema)
        return sid

    def add_channel(self, topic: str, message_encoding: str, schema_id: int,
                    channel_id: int | None = None, metadata: dict[str, str] | None = None,
                    *, in_data: bool = True) -> int:
        """Register a channel (written into the next chunk and the summary); returns its id.
        ``in_data=False``: the summary only (chunks copied from another file carry it)."""
        cid = channel_id if channel_id is not None else max(self._channels, default=0) + 1
        if cid in self._channels:
            raise ValueError(f"channel id {cid} is taken")
        channel = Channel(cid, topic, message_encoding, schema_id, dict(metadata or {}))
        self._channels[cid] = channel
        if in_data:
            self._chunk.buf += channel_record(channel)
        return cid

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
        if c.count and log_time < c.last:
            c.ordered = False
        c.last = log_time
        c.cids.append(channel_id)
        c.times.append(log_time)
        c.offsets.append(len(c.buf))
        c.buf += _MSG_HEAD.pack(5, 22 + len(data), channel_id, sequence, log_time,
                                log_time if publish_time is None else publish_time)
        c.buf += data
        c.count += 1
        self._counts[channel_id] = self._counts.get(channel_id, 0) + 1
        if len(c.buf) >= self._chunk_bytes:
            self.close_chunk()

    def add_messages(self, channel_ids: Sequence[int], log_times: Sequence[int],
                     datas: Sequence[bytes]) -> None:
        """Append many message records (publish time = log time): the same file as
        :meth:`add_message` one after the other (:meth:`add_records` of
        :func:`framed_records`)."""
        if len(datas):
            self.add_records(*framed_records(channel_ids, log_times, datas))

    def add_records(self, block: bytes | bytearray | memoryview, channel_ids: ArrayLike,
                    log_times: ArrayLike, sizes: ArrayLike) -> None:
        """Append framed message records: ``block`` holds them one after the other,
        ``sizes[i]`` bytes each (opcode and length included), of channels ``channel_ids`` at
        ``log_times`` (ns). The open chunk closes once it holds ``chunk_bytes``, after the
        record that reaches it, as with :meth:`add_message`; the index is kept as columns."""
        import numpy as np

        cid_a = np.asarray(channel_ids, dtype=np.uint16).reshape(-1)
        t_a = np.asarray(log_times, dtype=np.int64).reshape(-1)
        size_a = np.asarray(sizes, dtype=np.int64).reshape(-1)
        n = len(cid_a)
        if n == 0:
            return
        ends = np.cumsum(size_a)  # end of each record in ``block``
        if len(t_a) != n or len(size_a) != n or int(ends[-1]) != len(block):
            raise ValueError("add_records: the records and their columns do not match")
        ids, first, counts = np.unique(cid_a, return_index=True, return_counts=True)
        for k in np.argsort(first).tolist():  # the channels in order of their first message
            cid = int(ids[k])
            self._counts[cid] = self._counts.get(cid, 0) + int(counts[k])
        view = memoryview(block)
        i = 0
        while i < n:
            c = self._chunk
            pos = len(c.buf)
            base = int(ends[i - 1]) if i else 0
            # the records that go into this chunk: it closes once it holds chunk_bytes
            j = int(np.searchsorted(ends, base + self._chunk_bytes - pos, "left")) + 1
            j = min(max(j, i + 1), n)
            c.buf += view[base:int(ends[j - 1])]
            t = t_a[i:j]
            c.cids.frombytes(cid_a[i:j].tobytes())
            c.times.frombytes(t.astype(np.uint64).tobytes())
            c.offsets.frombytes((ends[i:j] - size_a[i:j] + (pos - base)).astype(np.uint64)
                                .tobytes())
            lo, hi, t0 = int(t.min()), int(t.max()), int(t[0])
            if c.ordered and ((c.count and t0 < c.last) or bool((t[1:] < t[:-1]).any())):
                c.ordered = False
            c.last = int(t[-1])
            if c.count == 0:
                c.start, c.end = lo, hi
            else:
                c.start, c.end = min(c.start, lo), max(c.end, hi)
            c.count += j - i
            if len(c.buf) >= self._chunk_bytes:
                self.close_chunk()
            i = j
        view.release()

    def close_chunk(self, hold_ns: int = 0) -> None:
        """Compress and write the open chunk and its message indexes (no-op when empty).

        ``hold_ns``: keep the messages less than this much older than the newest one (ns) in
        the open chunk, unless that would keep all of them: a live recorder's threads hand
        over messages slightly out of order, and a message a little older than the newest
        written one then still lands in log-time order (the reference checker warns of any
        message older than one before it in the file)."""
        c = self._chunk
        if c.count == 0:
            return
        if not c.ordered:
            # readers (the reference checker among them) expect log-time order in a chunk
            c.sort()
        held = c.split_after(c.end - hold_ns) if hold_ns > 0 else None
        # the records leave the chunk (only its index is kept until the chunk is written)
        data, c.buf = c.buf, bytearray()
        self._chunk = held if held is not None else _OpenChunk()
        if self._background:
            pending = self._pending
            # write the chunks compressed by now, and the oldest ones beyond the depth
            while pending and (pending[0][0].done() or len(pending) >= BACKGROUND_DEPTH):
                self._write_pending()
            if self._pool is None:
                self._pool = ThreadPoolExecutor(1, thread_name_prefix="mcap-chunk")
            pending.append((self._pool.submit(_compress_with_crc, self._compression, data), c,
                            len(data)))
            return
        self._write_chunk(c, len(data), *_compress_with_crc(self._compression, data))

    def drain(self) -> None:
        """Write the chunks a worker thread is compressing, if any, in order (a no-op unless
        the writer compresses in the background)."""
        while self._pending:
            self._write_pending()

    def _write_pending(self) -> None:
        """Write the oldest chunk handed to the worker thread (waiting for it if need be)."""
        future, c, size = self._pending.popleft()
        self._write_chunk(c, size, *future.result())

    def _write_chunk(self, c: _OpenChunk, size: int, compressed: bytes, crc: int) -> None:
        """Write the chunk record of ``c`` (``size`` bytes uncompressed, their CRC-32
        ``crc``), its message indexes and its chunk index entry."""
        start_offset = self._pos
        head = (_CHUNK_HEAD.pack(c.start, c.end, size, crc)
                + _str(self._compression) + _U64.pack(len(compressed)))
        self._emit(_REC_HEAD.pack(OP_CHUNK, len(head) + len(compressed)) + head)
        self._emit(compressed)
        mi_start = self._pos
        offsets, blob = c.message_indexes(mi_start)
        self._emit(blob)
        self._chunk_indexes.append(ChunkIndex(
            message_start_time=c.start, message_end_time=c.end, chunk_start_offset=start_offset,
            chunk_length=9 + len(head) + len(compressed), message_index_offsets=offsets,
            message_index_length=self._pos - mi_start, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=size))
        self._note_times(c.start, c.end, c.count)

    @property
    def open_chunk_start(self) -> int | None:
        """Log time (ns) of the oldest message in the open chunk; None when it holds none."""
        return self._chunk.start if self._chunk.count else None

    def _note_times(self, start: int, end: int, count: int) -> None:
        """Widen the file's message time span (ns) by a chunk's and add its message count."""
        if not self._timed:
            self._start, self._end = start, end
            self._timed = True
        else:
            self._start = min(self._start, start)
            self._end = max(self._end, end)
        self._message_count += count

    def copy_chunks(self, source: IO[bytes], chunk_indexes: Iterable[ChunkIndex],
                    channel_counts: dict[int, int]) -> None:
        """Copy whole chunks of another MCAP file verbatim, with their message indexes.

        The caller must have registered the source's schemas and channels here under the same
        ids, with ``in_data=False`` (the copied chunks hold their records); ``channel_counts``
        (from the source's statistics) adds to this file's statistics. Messages written after
        the copy should not be older than the copied ones (readers of the reference CLI warn
        of every message older than one before it in the file).
        Chunks that follow each other in the source (each with its message indexes right
        after it, as this writer lays them out) are copied as one run of bytes.
        """
        self.close_chunk()
        self.drain()
        runs: list[list[int]] = []  # [source start, source end, output start]
        for ci in chunk_indexes:
            chunk_end = ci.chunk_start_offset + ci.chunk_length
            mi_old = min(ci.message_index_offsets.values(), default=chunk_end)
            if mi_old == chunk_end:
                spans = [(ci.chunk_start_offset, chunk_end + ci.message_index_length)]
            else:
                spans = [(ci.chunk_start_offset, chunk_end),
                         (mi_old, mi_old + ci.message_index_length)]
            new_start = new_mi = -1
            for a, b in spans:
                if runs and runs[-1][1] == a:
                    runs[-1][1] = b
                else:
                    out = runs[-1][2] + runs[-1][1] - runs[-1][0] if runs else self._pos
                    runs.append([a, b, out])
                run = runs[-1]
                at = run[2] + a - run[0]
                if new_start < 0:
                    new_start = at
                new_mi = at + (chunk_end - a if len(spans) == 1 else 0)
            self._chunk_indexes.append(ChunkIndex(
                ci.message_start_time, ci.message_end_time, new_start, ci.chunk_length,
                {k: v - mi_old + new_mi for k, v in ci.message_index_offsets.items()},
                ci.message_index_length, ci.compression, ci.compressed_size,
                ci.uncompressed_size))
            if ci.message_index_offsets or ci.message_start_time or ci.message_end_time:
                self._note_times(ci.message_start_time, ci.message_end_time, 0)
        for a, b, at in runs:
            assert at == self._pos
            self._copy_range(source, a, b - a)
        count = 0
        for cid, n in channel_counts.items():
            self._counts[cid] = self._counts.get(cid, 0) + n
            count += n
        self._message_count += count

    def _copy_range(self, source: IO[bytes], offset: int, length: int) -> None:
        """Append ``length`` bytes of ``source`` from ``offset``: in the kernel when both are
        files (``os.copy_file_range``), else through memory."""
        done = 0
        try:
            src_fd, dst_fd = source.fileno(), self._out.fileno()
        except (AttributeError, OSError, ValueError):
            src_fd = dst_fd = -1
        if src_fd >= 0 and hasattr(os, "copy_file_range"):
            self._out.flush()
            try:
                while done < length:
                    n = os.copy_file_range(src_fd, dst_fd, length - done, offset + done)
                    if n <= 0:
                        break
                    done += n
            except OSError:
                pass
            self._out.seek(0, os.SEEK_END)
            self._pos += done
        while done < length:
            source.seek(offset + done)
            data = source.read(min(length - done, 1 << 22))
            if not data:
                raise ValueError("source file ends inside a chunk")
            self._emit(data)
            done += len(data)

    # ------------------------------------------------------------------ metadata, end
    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        """Write a metadata record (closes the open chunk first, to keep time order)."""
        self.close_chunk()
        self.drain()
        rec = record(OP_METADATA, _str(name) + _string_map(data))
        self._metadata_indexes.append(MetadataIndex(self._pos, len(rec), name))
        self._emit(rec)

    def finish(self) -> None:
        """Close the open chunk and write the summary, footer and closing magic."""
        self.close_chunk()
        self.drain()
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        self._emit(record(OP_DATA_END, _U32.pack(0)))
        summary_start = self._pos
        parts: list[bytes] = []
        offsets: list[tuple[int, int, int]] = []
        size = 0

        def group(opcode: int, records: list[bytes]) -> None:
            nonlocal size
            if records:
                blob = b"".join(records)
                offsets.append((opcode, summary_start + size, len(blob)))
                parts.append(blob)
                size += len(blob)

        group(OP_SCHEMA, [schema_record(x) for x in self._schemas.values()])
        group(OP_CHANNEL, [channel_record(x) for x in self._channels.values()])
        group(OP_STATISTICS, [record(OP_STATISTICS, struct.pack(
            "<QHIIIIQQ", self._message_count, len(self._schemas), len(self._channels), 0,
            len(self._metadata_indexes), len(self._chunk_indexes), self._start, self._end)
            + _id_map(self._counts))])
        group(OP_CHUNK_INDEX, [chunk_index_record(x) for x in self._chunk_indexes])
        group(OP_METADATA_INDEX, [record(OP_METADATA_INDEX, _U64.pack(x.offset)
                                         + _U64.pack(x.length) + _str(x.name))
                                  for x in self._metadata_indexes])
        offset_start = summary_start + size
        parts.extend(record(OP_SUMMARY_OFFSET, struct.pack("<BQQ", *o)) for o in offsets)
        summary = b"".join(parts)
        crc = zlib.crc32(summary)
        crc = zlib.crc32(struct.pack("<BQQQ", OP_FOOTER, 20, summary_start, offset_start), crc)
        self._emit(summary)
        self._emit(record(OP_FOOTER, struct.pack("<QQI", summary_start, offset_start, crc)))
        self._emit(MAGIC)
        self._out.flush()


# ---------------------------------------------------------------------- reading


class CorruptChunkError(ValueError):
    """A chunk that cannot be read as stored: it does not decompress, its records do not
    match the CRC-32 or the size its header gives, or a record runs past its end.

    :param offset: file offset of the chunk record, bytes (-1: not known here).
    :param reason: what is wrong, one phrase.
    """

    def __init__(self, offset: int, reason: str) -> None:
        super().__init__(f"chunk at byte {offset}: {reason}" if offset >= 0 else reason)
        self.offset = offset
        self.reason = reason


#: called with a chunk that is skipped and the reason (see :class:`CorruptChunkError`)
OnCorrupt = Callable[[ChunkIndex, str], None]


def _records_of(records: bytes) -> Iterator[tuple[int, int, int]]:
    """``(offset, opcode, length)`` of every record in a chunk's uncompressed ``records``.

    :raises CorruptChunkError: a record runs past the end of ``records`` (or a message record
        is too short for its fields).
    """
    pos, n = 0, len(records)
    rec_head = _REC_HEAD.unpack_from
    while pos + 9 <= n:
        opcode, length = rec_head(records, pos)
        if pos + 9 + length > n or (opcode == OP_MESSAGE and length < 22):
            raise CorruptChunkError(-1, f"a record at byte {pos} of the chunk runs past its end")
        yield pos, opcode, length
        pos += 9 + length
    if pos != n:
        raise CorruptChunkError(-1, "the chunk ends inside a record")


def chunk_messages(records: bytes, wanted: set[int] | None) -> list[tuple[int, int, int, bytes]]:
    """The message records in a chunk's uncompressed ``records``, as
    (log_time, channel_id, publish_time, data), in stored order; only ``wanted`` channels.

    :raises CorruptChunkError: a record runs past the end of ``records``.
    """
    out = []
    fields = _MSG_FIELDS.unpack_from
    for pos, opcode, length in _records_of(records):
        if opcode == OP_MESSAGE:
            cid, _seq, log_time, pub = fields(records, pos + 9)
            if wanted is None or cid in wanted:
                out.append((log_time, cid, pub, records[pos + 31 : pos + 9 + length]))
    return out


def _chunk_frame(buf: Any, ci: ChunkIndex) -> tuple[str, int, int, int]:
    """Compression, offset and length (bytes) of the compressed records of the chunk ``ci``
    of a file held in ``buf``, and the CRC-32 of its uncompressed records (0: none).

    :raises CorruptChunkError: the chunk record lies outside the file or its header does not
        parse.
    """
    at = ci.chunk_start_offset
    if at < 0 or at + 9 + _CHUNK_HEAD.size + 4 > len(buf) or buf[at] != OP_CHUNK:
        raise CorruptChunkError(at, "no chunk record where the index points")
    pos = at + 9 + _CHUNK_HEAD.size
    crc = _CHUNK_HEAD.unpack_from(buf, at + 9)[3]
    (clen,) = _U32.unpack_from(buf, pos)
    if pos + 4 + clen + 8 > len(buf):
        raise CorruptChunkError(at, "chunk header runs past the end of the file")
    try:
        kind = bytes(buf[pos + 4:pos + 4 + clen]).decode()
    except UnicodeDecodeError:
        raise CorruptChunkError(at, "unreadable compression name") from None
    pos += 4 + clen
    (dlen,) = _U64.unpack_from(buf, pos)
    if pos + 8 + dlen > len(buf):
        raise CorruptChunkError(at, "chunk data runs past the end of the file")
    return kind, pos + 8, dlen, crc


def verified_records(buf: Any, ci: ChunkIndex,
                     zstd: zstandard.ZstdDecompressor | None = None) -> bytes:
    """The uncompressed records of the chunk ``ci`` of a file held in ``buf``, checked: they
    decompress, have the size the index gives and match the chunk's CRC-32 (when it is not 0,
    which MCAP uses for "not computed").

    :raises CorruptChunkError: any of those checks fails.
    """
    kind, at, size, crc = _chunk_frame(buf, ci)
    # released on return even if something (a sampling profiler) keeps this frame alive
    with memoryview(buf)[at:at + size] as data:
        return checked_records(kind, data, ci.uncompressed_size, crc, zstd,
                               offset=ci.chunk_start_offset)


def checked_records(kind: str, data: bytes | memoryview, size: int, crc: int,
                    zstd: zstandard.ZstdDecompressor | None = None, *, offset: int = -1
                    ) -> bytes:
    """Decompress a chunk's ``data`` (compression ``kind``) and check that the records have
    ``size`` bytes and, when ``crc`` is not 0, that CRC-32.

    :raises CorruptChunkError: they do not decompress, or the size or CRC differs.
    """
    try:
        if kind == "zstd" and zstd is not None:
            records = zstd.decompress(data, max_output_size=size)
        else:
            records = bytes(decompress(kind, data, size))
    except Exception as exc:  # zstd, lz4 and the size guard each raise their own kind
        name = kind or "uncompressed"
        raise CorruptChunkError(offset, f"{name} data does not decompress ({exc})") from None
    if len(records) != size:
        raise CorruptChunkError(offset, f"{len(records)} bytes of records, the header says "
                                        f"{size}")
    if crc and zlib.crc32(records) != crc:
        raise CorruptChunkError(offset, "CRC-32 of its records does not match")
    return records


def _indexed_payloads(buf: Any, records: bytes, off: int, cid: int
                      ) -> tuple[NDArray[np.uint64], list[bytes]] | None:
    """The log times and data of channel ``cid``'s messages in ``records`` found through its
    message index at file offset ``off``; None when the index does not fit the records (the
    chunk is then walked instead)."""
    import numpy as np

    entries = _index_entries(buf, off, cid)
    if entries is None:
        return None
    pairs = np.frombuffer(entries, dtype="<u8")
    times = pairs[0::2].copy()
    ats = pairs[1::2].tolist()
    del pairs
    n = len(records)
    unpack = _U64.unpack_from
    out: list[bytes] = []
    for at in ats:
        if at + 31 > n or records[at] != OP_MESSAGE:
            return None
        (length,) = unpack(records, at + 1)
        if length < 22 or at + 9 + length > n:
            return None
        out.append(records[at + 31:at + 9 + length])
    return times, out


RecordColumns = tuple["NDArray[np.uint16]", "NDArray[np.int64]", "NDArray[np.int64]",
                      "NDArray[np.int64]"]
"""The message records of a chunk as columns: channel id, log time (ns), offset of the record
in the chunk's records and its size (bytes, opcode and length included)."""


def record_columns(chunks: Sequence[tuple[Any, ChunkIndex, bytes]],
                   on_corrupt: Callable[[int, str], None] | None = None
                   ) -> tuple[bytes, RecordColumns]:
    """The uncompressed records of consecutive chunks joined (``chunks``: per chunk a buffer
    holding it and, at its index's offsets, its message indexes, as :func:`chunk_window` reads
    them, the index, and the chunk's records), and the columns of their message records in
    log-time order (ties in stored order), offsets into the joined records. Found through the
    message indexes when they account for every message record, else by walking the records.
    A chunk whose records do not frame is passed to ``on_corrupt`` (its position in
    ``chunks`` and the reason) and left out; without ``on_corrupt`` it raises.

    :raises CorruptChunkError: a record runs past the end of its chunk (no ``on_corrupt``).
    """
    import numpy as np

    def joined(parts: Sequence[bytes]) -> tuple[bytes, list[int]]:
        return b"".join(parts), np.cumsum([0] + [len(r) for r in parts[:-1]]).tolist()

    records, bases = joined([r for _b, _ci, r in chunks])
    cols = _indexed_columns([(buf, ci, base) for (buf, ci, _r), base in
                             zip(chunks, bases, strict=True)], records)
    if cols is None:
        good: list[tuple[bytes, RecordColumns]] = []
        for k, (buf, ci, r) in enumerate(chunks):
            try:
                good.append((r, _indexed_columns([(buf, ci, 0)], r) or _walked_columns(r)))
            except CorruptChunkError as exc:
                if on_corrupt is None:
                    raise
                on_corrupt(k, exc.reason)
        records, bases = joined([r for r, _c in good] or [b""])
        parts = [c for _r, c in good] or [_walked_columns(b"")]
        cols = (np.concatenate([c[0] for c in parts]), np.concatenate([c[1] for c in parts]),
                np.concatenate([c[2] + base for c, base in zip(parts, bases, strict=True)]),
                np.concatenate([c[3] for c in parts]))
    cids, times, offsets, sizes = cols
    if len(times) > 1 and bool((np.diff(times) < 0).any()):
        order = np.lexsort((offsets, times))
        cids, times, offsets, sizes = cids[order], times[order], offsets[order], sizes[order]
    return records, (cids, times, offsets, sizes)


def _walked_columns(records: bytes) -> RecordColumns:
    """:func:`record_columns` by walking every record (stored order)."""
    import numpy as np

    cids: list[int] = []
    times: list[int] = []
    offsets: list[int] = []
    sizes: list[int] = []
    fields = _MSG_FIELDS.unpack_from
    for pos, opcode, length in _records_of(records):
        if opcode == OP_MESSAGE:
            cid, _seq, log_time, _pub = fields(records, pos + 9)
            cids.append(cid)
            times.append(log_time)
            offsets.append(pos)
            sizes.append(9 + length)
    return (np.array(cids, dtype=np.uint16), np.array(times, dtype=np.uint64).astype(np.int64),
            np.array(offsets, dtype=np.int64), np.array(sizes, dtype=np.int64))


def _index_entries(buf: Any, at: int, cid: int) -> bytes | None:
    """The (log time, offset) pairs, as bytes (u64 each, 16 a pair), of the Message Index
    record of channel ``cid`` at ``at`` in ``buf``; None when no such record is there."""
    if at < 0 or at + 15 > len(buf) or buf[at] != OP_MESSAGE_INDEX:
        return None
    (got,) = _U16.unpack_from(buf, at + 9)
    (nbytes,) = _U32.unpack_from(buf, at + 11)
    if got != cid or nbytes % 16 or at + 15 + nbytes > len(buf):
        return None
    return bytes(buf[at + 15:at + 15 + nbytes])


def _indexed_columns(chunks: Sequence[tuple[Any, ChunkIndex, int]], records: bytes
                     ) -> RecordColumns | None:
    """:func:`record_columns` from the chunks' message indexes (``chunks``: buffer, index and
    where the chunk's records start in ``records``), in stored order; None when they do not
    parse, do not fit the records or leave a message record out."""
    import numpy as np

    # each index's (time, offset) pairs, its channel, count and the chunk's base, gathered
    # as bytes and lists (tens of indexes per chunk), then turned into columns at once
    pairs: list[bytes] = []
    ids: list[int] = []
    counts: list[int] = []
    bases: list[int] = []
    for buf, ci, base in chunks:
        if not ci.message_index_offsets:
            if ci.uncompressed_size:
                return None
            continue
        for cid, off in ci.message_index_offsets.items():
            entries = _index_entries(buf, off, cid)
            if entries is None:
                return None
            pairs.append(entries)
            ids.append(cid)
            counts.append(len(entries) // 16)
            bases.append(base)
    if not sum(counts):
        return None
    flat = np.frombuffer(b"".join(pairs), dtype="<u8")
    offsets = flat[1::2].astype(np.int64) + np.repeat(np.array(bases, dtype=np.int64), counts)
    n = len(records)
    order = np.argsort(offsets, kind="stable")
    offsets = offsets[order]
    cids = np.repeat(np.array(ids, dtype=np.uint16), counts)[order]
    times = flat[0::2][order].astype(np.int64)
    if offsets[0] < 0 or offsets[-1] + 31 > n or bool((np.diff(offsets) <= 0).any()):
        return None
    rec = np.frombuffer(records, dtype=np.uint8)
    if bool((rec[offsets] != OP_MESSAGE).any()):
        return None
    head = rec[offsets[:, None] + np.arange(1, 31)]  # length, channel, sequence, log time
    lengths = head[:, 0:8].copy().view("<u8").reshape(-1).astype(np.int64)
    sizes = lengths + 9
    if (bool((lengths < 22).any()) or offsets[-1] + sizes[-1] > n
            or bool((offsets[:-1] + sizes[:-1] > offsets[1:]).any())
            or bool((head[:, 8:10].copy().view("<u2").reshape(-1) != cids).any())
            or bool((head[:, 14:22].copy().view("<u8").reshape(-1).astype(np.int64)
                     != times).any())):
        return None
    # every other record lies in the gaps between the messages: a message the indexes leave
    # out would be lost, so the gaps are walked and must hold no message record
    gaps = np.flatnonzero(np.concatenate(([offsets[0] > 0], offsets[1:] > offsets[:-1] + sizes[:-1],
                                          [offsets[-1] + sizes[-1] < n])))
    ends = np.concatenate(([0], offsets + sizes))
    starts = np.concatenate((offsets, [n]))
    for g in gaps.tolist():
        try:
            if any(op == OP_MESSAGE for _at, op, _n in
                   _records_of(records[int(ends[g]):int(starts[g])])):
                return None
        except CorruptChunkError:
            return None
    return cids, times, offsets, sizes


def indexed_times(f: IO[bytes], chunk_indexes: Sequence[ChunkIndex]
                  ) -> dict[int, NDArray[np.int64]] | None:
    """The log times (ns) of every message per channel, read from the chunks' message
    indexes alone (nothing is decompressed), sorted; None when a chunk has no message index
    or one does not parse (the chunks must then be read)."""
    import numpy as np

    parts: dict[int, list[bytes]] = {}
    for ci in chunk_indexes:
        if not ci.message_index_offsets and ci.uncompressed_size:
            return None
        if not ci.message_index_offsets:
            continue
        lo = min(ci.message_index_offsets.values())
        f.seek(lo)
        buf = f.read(ci.message_index_length)
        for cid, off in ci.message_index_offsets.items():
            entries = _index_entries(buf, off - lo, cid)
            if entries is None:
                return None
            parts.setdefault(cid, []).append(entries)
    out: dict[int, NDArray[np.int64]] = {}
    for cid, chunks in parts.items():
        t = np.frombuffer(b"".join(chunks), dtype="<u8")[0::2].astype(np.int64)
        t.sort(kind="stable")
        out[cid] = t
    return out


def iter_channel_chunks(f: IO[bytes], chunk_indexes: Sequence[ChunkIndex],
                        wanted: Iterable[int], on_corrupt: OnCorrupt | None = None,
                        verified: set[int] | None = None
                        ) -> Iterator[dict[int, tuple[NDArray[np.uint64], list[bytes]]]]:
    """The messages of the ``wanted`` channels of an indexed file, one chunk at a time (in the
    order of the chunks' start times): per channel in the chunk, the log times (ns) and the
    message data in stored order. Only one chunk is held at a time (:func:`chunk_window`).

    Only the chunks holding a wanted channel are decompressed (and checked, see
    :func:`verified_records`), and their messages are found through the chunks' message
    indexes (chunks without one, or whose index does not fit, are walked record by record).
    A corrupt chunk is passed to ``on_corrupt`` and skipped; without ``on_corrupt`` it raises
    :class:`CorruptChunkError`. The offsets of the chunks found sound are added to
    ``verified``.
    """
    import numpy as np

    want = set(wanted)
    order = sorted((ci for ci in chunk_indexes
                    if not ci.message_index_offsets or want & ci.message_index_offsets.keys()),
                   key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
    zstd = zstandard.ZstdDecompressor()
    for ci in order:
        try:
            buf, local = chunk_window(f, ci)
            records = verified_records(buf, local, zstd)
            found: dict[int, tuple[NDArray[np.uint64], list[bytes]]] | None = {}
            for cid, off in local.message_index_offsets.items():
                if cid in want and found is not None:
                    got = _indexed_payloads(buf, records, off, cid)
                    if got is None:
                        found = None
                    else:
                        found[cid] = got
            if found is None or not local.message_index_offsets:
                walked: dict[int, tuple[list[int], list[bytes]]] = {}
                for log_time, cid, _pub, data in chunk_messages(records, want):
                    ts, ds = walked.setdefault(cid, ([], []))
                    ts.append(log_time)
                    ds.append(data)
                found = {cid: (np.array(ts, dtype=np.uint64), ds)
                         for cid, (ts, ds) in walked.items()}
            del records, buf
        except CorruptChunkError as exc:
            if on_corrupt is None:
                raise CorruptChunkError(ci.chunk_start_offset, exc.reason) from None
            on_corrupt(ci, exc.reason)
            continue
        if verified is not None:
            verified.add(ci.chunk_start_offset)
        yield found


def chunk_window(f: IO[bytes], ci: ChunkIndex) -> tuple[bytes, ChunkIndex]:
    """The bytes of the chunk ``ci`` (and of its message indexes when they follow it within
    64 KiB, as writers lay them out), read from ``f``, and ``ci`` with its offsets made
    relative to those bytes (without message indexes when they lie elsewhere: the chunk is
    then walked). Reading chunk by chunk this way holds one chunk in memory, where a map of
    the whole file keeps every page read resident."""
    lo = max(0, ci.chunk_start_offset)
    hi = lo + max(0, ci.chunk_length)
    offsets: dict[int, int] = {}
    if ci.message_index_offsets:
        mlo = min(ci.message_index_offsets.values())
        mhi = mlo + ci.message_index_length
        if hi <= mlo <= hi + (1 << 16) and mhi - lo <= (1 << 31):
            hi = mhi
            offsets = {k: v - lo for k, v in ci.message_index_offsets.items()}
    f.seek(lo)
    data = f.read(max(0, hi - lo))
    return data, ChunkIndex(ci.message_start_time, ci.message_end_time,
                            ci.chunk_start_offset - lo, ci.chunk_length, offsets,
                            ci.message_index_length, ci.compression, ci.compressed_size,
                            ci.uncompressed_size)


def read_channels(f: IO[bytes], chunk_indexes: Sequence[ChunkIndex], wanted: Iterable[int],
                  on_corrupt: OnCorrupt | None = None, verified: set[int] | None = None
                  ) -> dict[int, tuple[NDArray[np.int64], list[bytes]]]:
    """Every message of the ``wanted`` channels of an indexed file: per channel, the log times
    (ns) and the message data, in log-time order (ties in stored order). Chunks are read and
    checked as by :func:`iter_channel_chunks`."""
    import numpy as np

    want = set(wanted)
    times: dict[int, list[NDArray[np.uint64]]] = {c: [] for c in want}
    datas: dict[int, list[bytes]] = {c: [] for c in want}
    for found in iter_channel_chunks(f, chunk_indexes, want, on_corrupt, verified):
        for cid, (tc, d) in found.items():
            times[cid].append(tc)
            datas[cid].extend(d)
    out: dict[int, tuple[NDArray[np.int64], list[bytes]]] = {}
    for cid in want:
        t = (np.concatenate(times[cid]) if times[cid] else np.zeros(0, np.uint64)).astype(np.int64)
        payloads = datas[cid]
        if len(t) > 1 and not bool(np.all(t[1:] >= t[:-1])):
            o = np.argsort(t, kind="stable")
            t = t[o]
            payloads = [payloads[i] for i in o.tolist()]
        out[cid] = (t, payloads)
    return out


MERGED_BLOCK = 4096
"""Messages per block that :func:`iter_indexed_blocks` yields from overlapping chunks."""


def iter_indexed(stream: IO[bytes], chunk_indexes: list[ChunkIndex],
                 wanted: set[int] | None, on_corrupt: OnCorrupt | None = None,
                 verified: set[int] | None = None) -> Iterator[tuple[int, int, int, bytes]]:
    """Messages of the ``wanted`` channels in log-time order across (possibly overlapping)
    chunks: (log_time, channel_id, publish_time, data); see :func:`iter_indexed_blocks`."""
    for block in iter_indexed_blocks(stream, chunk_indexes, wanted, on_corrupt, verified):
        yield from block


def iter_indexed_blocks(stream: IO[bytes], chunk_indexes: list[ChunkIndex],
                 wanted: set[int] | None, on_corrupt: OnCorrupt | None = None,
                 verified: set[int] | None = None
                 ) -> Iterator[list[tuple[int, int, int, bytes]]]:
    """Messages of the ``wanted`` channels in log-time order across (possibly overlapping)
    chunks, in lists (a chunk's messages, or up to :data:`MERGED_BLOCK` merged from
    overlapping chunks): (log_time, channel_id, publish_time, data). Chunks are read lazily and checked
    (:func:`verified_records`); a corrupt one is passed to ``on_corrupt`` and skipped (without
    ``on_corrupt`` it raises :class:`CorruptChunkError`); sound ones are added to
    ``verified`` (file offsets)."""
    order = sorted((ci for ci in chunk_indexes
                    if wanted is None or not ci.message_index_offsets
                    or wanted & ci.message_index_offsets.keys()),
                   key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
    zstd = zstandard.ZstdDecompressor()

    def load(ci: ChunkIndex) -> list[tuple[int, int, int, bytes]]:
        try:
            buf, local = chunk_window(stream, ci)
            msgs = chunk_messages(verified_records(buf, local, zstd), wanted)
        except CorruptChunkError as exc:
            if on_corrupt is None:
                raise CorruptChunkError(ci.chunk_start_offset, exc.reason) from None
            on_corrupt(ci, exc.reason)
            return []
        if verified is not None:
            verified.add(ci.chunk_start_offset)
        msgs.sort(key=lambda m: m[0])
        return msgs

    heap: list[tuple[int, int, int, int, int, bytes]] = []
    merged: list[tuple[int, int, int, bytes]] = []
    seq = 0
    i = 0
    while i < len(order) or heap:
        if not heap and i < len(order):
            if merged:
                yield merged
                merged = []
            ci = order[i]
            i += 1
            msgs = load(ci)
            # fast path: this chunk ends before the next one starts -> no merging needed
            if i >= len(order) or ci.message_end_time < order[i].message_start_time:
                if msgs:
                    yield msgs
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
        merged.append((lt, cid, pub, data))
        if len(merged) >= MERGED_BLOCK or not heap:
            yield merged
            merged = []
    if merged:
        yield merged
