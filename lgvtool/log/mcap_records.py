"""MCAP records: their layouts, packing and parsing, the summary section and chunk compression.

The pieces shared by lgvtool's lean writer (:mod:`lgvtool.log.mcap_writer`), chunk reader
(:mod:`lgvtool.log.mcap_chunks`) and walk of a file without a summary
(:mod:`lgvtool.log.mcap_scan`): the record opcodes and binary layouts of the MCAP
specification, the header, schema, channel, metadata and chunk index records as small classes,
their packing and parsing, the parsing of an indexed file's summary section (with its CRC-32)
and the compression of chunks. Offsets and sizes in bytes, times in ns.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Mapping
from typing import IO, TYPE_CHECKING, TypeAlias

import lz4.frame
import zstandard

if TYPE_CHECKING:
    import mmap

#: the bytes of a file (or a part of one) held in memory: read, or mapped
FileBytes: TypeAlias = "bytes | bytearray | memoryview | mmap.mmap"

MAGIC = b"\x89MCAP0\r\n"
MSG_HEAD = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish
REC_HEAD = struct.Struct("<BQ")
MSG_FIELDS = struct.Struct("<HIQQ")
CHUNK_HEAD = struct.Struct("<QQQI")  # start, end, uncompressed size, crc
U16 = struct.Struct("<H")
U32 = struct.Struct("<I")
U64 = struct.Struct("<Q")
MI_HEAD = struct.Struct("<BQHI")  # message index: opcode, record length, channel, array bytes
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


def starts_with_magic(path: str | os.PathLike[str]) -> bool:
    """Whether the file at ``path`` starts with the MCAP magic (False when it cannot be
    read)."""
    try:
        with open(path, "rb") as f:
            return f.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


class _Record:
    """A plain record: the fields ``_fields`` (in order), set by position or keyword."""

    __slots__: tuple[str, ...] = ()
    _fields: tuple[str, ...] = ()

    def __init__(self, *args: object, **kwargs: object) -> None:
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


def pack_str(text: str) -> bytes:
    """An MCAP string: its UTF-8 length (u32) and bytes."""
    raw = text.encode()
    return U32.pack(len(raw)) + raw


def pack_string_map(entries: Mapping[str, str]) -> bytes:
    """An MCAP map of strings to strings: its length in bytes (u32) and the pairs."""
    body = b"".join(pack_str(k) + pack_str(v) for k, v in entries.items())
    return U32.pack(len(body)) + body


def pack_id_map(entries: Mapping[int, int]) -> bytes:
    """An MCAP map of channel ids (u16) to u64 values: its length in bytes (u32) and the
    pairs."""
    return U32.pack(10 * len(entries)) + b"".join(_MAP_ENTRY.pack(k, v)
                                                   for k, v in entries.items())


def record(opcode: int, body: bytes) -> bytes:
    """One MCAP record: opcode, length and ``body``."""
    return REC_HEAD.pack(opcode, len(body)) + body


def schema_record(s: Schema) -> bytes:
    """The record of a schema."""
    return record(OP_SCHEMA, U16.pack(s.id) + pack_str(s.name) + pack_str(s.encoding)
                  + U32.pack(len(s.data)) + s.data)


def channel_record(c: Channel) -> bytes:
    """The record of a channel."""
    return record(OP_CHANNEL, U16.pack(c.id) + U16.pack(c.schema_id) + pack_str(c.topic)
                  + pack_str(c.message_encoding) + pack_string_map(c.metadata))


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


class Cursor:
    """Reads MCAP primitives from a buffer."""

    __slots__ = ("buf", "pos")

    def __init__(self, buf: FileBytes, pos: int = 0) -> None:
        self.buf = buf
        self.pos = pos

    def u8(self) -> int:
        v: int = self.buf[self.pos]
        self.pos += 1
        return v

    def u16(self) -> int:
        (v,) = U16.unpack_from(self.buf, self.pos)
        self.pos += 2
        return int(v)

    def u32(self) -> int:
        (v,) = U32.unpack_from(self.buf, self.pos)
        self.pos += 4
        return int(v)

    def u64(self) -> int:
        (v,) = U64.unpack_from(self.buf, self.pos)
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
    c = Cursor(buf)
    while c.pos + 9 <= len(buf):
        opcode, length = REC_HEAD.unpack_from(buf, c.pos)
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
            schema = parse_schema(c)
            out.schemas[schema.id] = schema
        elif opcode == OP_CHANNEL:
            channel = parse_channel(c)
            out.channels[channel.id] = channel
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
    (crc,) = U32.unpack_from(footer, 9 + 16)
    if crc and zlib.crc32(footer[:9 + 16], zlib.crc32(summary)) != crc:
        raise CorruptSummaryError("the summary section does not match its CRC-32")


def data_section_crc(buf: FileBytes, summary_start: int) -> tuple[int, int] | None:
    """The data section's stored CRC-32 (from the data end record before ``summary_start``)
    and the CRC-32 computed over the file up to that record; None when the file has no data
    end record there or its CRC is 0 ("not computed")."""
    end = summary_start - 13
    if end < len(MAGIC) or buf[end] != OP_DATA_END:
        return None
    (stored,) = U32.unpack_from(buf, end + 9)
    if stored == 0:
        return None
    with memoryview(buf)[:end] as data:
        return stored, zlib.crc32(data)


def read_metadata(f: IO[bytes], index: MetadataIndex) -> Metadata:
    """The metadata record that ``index`` points at."""
    f.seek(index.offset)
    buf = f.read(index.length)
    return parse_metadata(Cursor(buf, 9))


def parse_schema(c: Cursor) -> Schema:
    """The schema record whose body starts at ``c`` (read past it)."""
    sid = c.u16()
    name, enc = c.string(), c.string()
    return Schema(sid, name, enc, c.raw(c.u32()))


def parse_channel(c: Cursor) -> Channel:
    """The channel record whose body starts at ``c`` (read past it)."""
    cid, sid = c.u16(), c.u16()
    topic, enc = c.string(), c.string()
    return Channel(cid, topic, enc, sid, c.string_map())


def parse_metadata(c: Cursor) -> Metadata:
    """The metadata record whose body starts at ``c`` (read past it)."""
    name = c.string()
    return Metadata(name, c.string_map())


ZSTD_LEVEL = 1
"""zstd level of the chunks written: on lgvtool's logs (JSON messages) level 1 compresses
about twice as fast as level 3 and as small or smaller (docs/performance.md)."""


def compress(kind: str, data: bytes | bytearray) -> bytes:
    """A chunk's records compressed with ``kind`` ('', 'zstd', 'lz4')."""
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
