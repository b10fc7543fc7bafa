"""The records of an MCAP file without a usable summary, found by walking it once.

A log cut off by a crash, a power loss or a full disk has no summary section (and a file whose
summary fails its CRC-32 cannot trust it). :func:`scan_records` walks such a file's top-level
records from the start to the first one that does not fit: it gathers the schemas, channels
and metadata records, checks every chunk (decompressed, against its size and CRC-32, its
records framed), takes the schemas and channels defined inside it, counts its messages, and
makes it a :class:`~lgvtool.log.mcap_records.ChunkIndex`, with the message indexes that follow
it when they account for every one of its messages. Message records outside chunks (MCAP allows
a writer not to chunk) are gathered into runs of consecutive ones, each described by a
``ChunkIndex`` too (uncompressed, no message index; :attr:`Scan.loose` tells them apart), up
to :data:`LOOSE_RUN_BYTES` each. The chunks and runs are then read one at a time
(:class:`lgvtool.log.sources.SalvagedSource`), as the chunks of a complete file are: memory
holds one chunk or run, never the log's messages. Offsets and sizes in bytes, times in ns.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import IO

import zstandard

from lgvtool.log.mcap_chunks import CorruptChunkError, checked_records, records_of
from lgvtool.log.mcap_records import (
    CHUNK_HEAD,
    MAGIC,
    MSG_FIELDS,
    OP_CHANNEL,
    OP_CHUNK,
    OP_DATA_END,
    OP_FOOTER,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    OP_METADATA,
    OP_SCHEMA,
    REC_HEAD,
    U16,
    U32,
    Channel,
    ChunkIndex,
    Cursor,
    Metadata,
    Schema,
    parse_channel,
    parse_metadata,
    parse_schema,
)

#: what parsing a record that is damaged raises (a field runs past the bytes: struct.error
#: or IndexError; a string that is not UTF-8: UnicodeDecodeError; a record longer than its
#: body: ValueError, see :func:`_definition`)
_UNPARSED = (ValueError, IndexError, UnicodeDecodeError, struct.error)

LOOSE_RUN_BYTES = 1 << 20
"""Bytes of message records outside chunks described by one entry of :attr:`Scan.chunk_indexes`
at most (a run ends there, or at the first other record): what one read of them holds."""

__all__ = ["LOOSE_RUN_BYTES", "Scan", "scan_records"]


@dataclass
class Scan:
    """What :func:`scan_records` found."""

    #: schemas and channels by id, the first definition of each id (the data section's)
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata: list[Metadata] = field(default_factory=list)
    #: the sound chunks and the runs of message records outside chunks, in file order
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    #: file offset -> length in bytes of each run of message records outside chunks (its
    #: entry of :attr:`chunk_indexes` starts there)
    loose: dict[int, int] = field(default_factory=dict)
    #: messages per channel id in the sound chunks and the runs
    counts: dict[int, int] = field(default_factory=dict)
    #: the latest log time of those messages, ns (None: no message)
    last_time: int | None = None
    #: bytes from the file's start to the end of the last whole record
    good_end: int = len(MAGIC)

    def unknown_channels(self) -> bool:
        """Whether a message of the sound chunks names a channel no record defines (its
        definition was in a corrupt chunk)."""
        return any(cid not in self.channels for cid in self.counts)


@dataclass
class _Run:
    """A run of message records outside chunks being gathered: where it starts and ends in
    the file (bytes) and its first and last log times (ns)."""

    start: int
    end: int
    first: int
    last: int


def scan_records(f: IO[bytes], size: int, on_corrupt: Callable[[int, str], None]) -> Scan:
    """Walk the top-level records of the MCAP file ``f`` (``size`` bytes; its magic already
    checked) up to the end of its data section, or to the first record that runs past the end
    of the file, has opcode 0 (a zero-filled tail) or does not parse. A corrupt chunk goes to
    ``on_corrupt(its file offset, reason)`` and is left out."""
    out = Scan()
    zstd = zstandard.ZstdDecompressor()
    pos = len(MAGIC)
    # the chunk just read: its index and message counts per channel, and the message
    # indexes seen after it so far (channel -> offset, entries) with their bytes
    chunk: tuple[ChunkIndex, dict[int, int]] | None = None
    indexes: dict[int, tuple[int, int]] = {}
    index_bytes = 0
    run: _Run | None = None  # the run of message records outside chunks being gathered

    def close_chunk() -> None:
        nonlocal chunk, index_bytes
        if chunk is not None:
            ci, counts = chunk
            if counts and {c: n for c, (_o, n) in indexes.items() if n} == counts:
                ci.message_index_offsets = {c: o for c, (o, _n) in indexes.items()}
                ci.message_index_length = index_bytes
        chunk = None
        indexes.clear()
        index_bytes = 0

    def close_run() -> None:
        nonlocal run
        if run is not None:
            n = run.end - run.start
            out.chunk_indexes.append(ChunkIndex(run.first, run.last, run.start, n, {}, 0, "",
                                                n, n))
            out.loose[run.start] = n
        run = None

    while True:
        f.seek(pos)
        head = f.read(REC_HEAD.size)
        if len(head) < REC_HEAD.size:
            break
        opcode, length = REC_HEAD.unpack(head)
        end = pos + REC_HEAD.size + length
        if opcode == 0 or end > size:
            break
        if opcode == OP_MESSAGE and length >= MSG_FIELDS.size:
            close_chunk()
            if run is not None and end - run.start > LOOSE_RUN_BYTES:
                close_run()
            cid, _seq, log_time, _pub = MSG_FIELDS.unpack(f.read(MSG_FIELDS.size))
            _count(out, {cid: 1}, log_time)
            if run is None:
                run = _Run(pos, end, log_time, log_time)
            else:
                run.end = end
                run.first = min(run.first, log_time)
                run.last = max(run.last, log_time)
            out.good_end = pos = end
            continue
        if run is not None:
            close_run()
        if opcode == OP_MESSAGE:  # too short for its fields: the file is not read past it
            break
        if opcode == OP_MESSAGE_INDEX and chunk is not None and length >= 6:
            body = f.read(6)  # channel id, then the byte length of its (time, offset) pairs
            (cid,), (nbytes,) = U16.unpack_from(body, 0), U32.unpack_from(body, 2)
            fits = nbytes % 16 == 0 and 6 + nbytes <= length
            indexes[cid] = (pos, nbytes // 16 if fits else -1)
            index_bytes += REC_HEAD.size + length
            out.good_end = pos = end
            continue
        close_chunk()
        if opcode in (OP_DATA_END, OP_FOOTER):  # the data section ends: no message after it
            out.good_end = end
            break
        try:
            if opcode == OP_CHUNK:
                chunk = _chunk(f.read(length), pos, out, zstd, on_corrupt)
            elif opcode in (OP_SCHEMA, OP_CHANNEL, OP_METADATA):
                _take(_definition(opcode, f.read(length)), out)
        except _UNPARSED:  # a record that does not parse: the file is not read past it
            break
        out.good_end = pos = end
    close_chunk()
    close_run()
    return out


def _count(out: Scan, counts: dict[int, int], last: int | None) -> None:
    """Add messages (``counts`` per channel id), the latest at log time ``last`` (ns)."""
    for cid, n in counts.items():
        out.counts[cid] = out.counts.get(cid, 0) + n
    if last is not None and (out.last_time is None or last > out.last_time):
        out.last_time = last


def _definition(opcode: int, body: bytes) -> Schema | Channel | Metadata:
    """The schema, channel or metadata record of ``body``.

    :raises ValueError: the record runs past its body (or another error of
        :data:`_UNPARSED`: it does not parse)."""
    c = Cursor(body)
    rec = (parse_schema(c) if opcode == OP_SCHEMA else parse_channel(c) if opcode == OP_CHANNEL
           else parse_metadata(c))
    if c.pos > len(body):
        raise ValueError("a record runs past its length")
    return rec


def _take(rec: Schema | Channel | Metadata, out: Scan) -> None:
    """Add a definition to ``out``: the first definition of a schema or channel id counts."""
    if isinstance(rec, Schema):
        out.schemas.setdefault(rec.id, rec)
    elif isinstance(rec, Channel):
        out.channels.setdefault(rec.id, rec)
    else:
        out.metadata.append(rec)


def _chunk(body: bytes, offset: int, out: Scan, zstd: zstandard.ZstdDecompressor,
           on_corrupt: Callable[[int, str], None]) -> tuple[ChunkIndex, dict[int, int]] | None:
    """The chunk record at file ``offset`` (its ``body``) checked and opened: its index and
    messages per channel, its definitions and counts added to ``out``; None (and
    ``on_corrupt``) when it is corrupt."""
    try:
        start, end_time, usize, crc = CHUNK_HEAD.unpack_from(body, 0)
        c = Cursor(body, CHUNK_HEAD.size)
        kind = c.string()
        csize = c.u64()
        if c.pos + csize > len(body):
            raise CorruptChunkError(offset, "chunk data runs past its record")
        records = checked_records(kind, memoryview(body)[c.pos:c.pos + csize], usize, crc,
                                  zstd, offset=offset)
        counts, last, found = _opened(records)
        defined = [_definition(opcode, rec) for opcode, rec in found]
    except CorruptChunkError as exc:
        on_corrupt(offset, exc.reason)
        return None
    except _UNPARSED as exc:
        on_corrupt(offset, f"a record inside does not parse ({type(exc).__name__})")
        return None
    for rec in defined:
        _take(rec, out)
    _count(out, counts, last)
    ci = ChunkIndex(start, end_time, offset, REC_HEAD.size + len(body), {}, 0, kind, csize,
                    usize)
    out.chunk_indexes.append(ci)
    return ci, counts


def _opened(records: bytes) -> tuple[dict[int, int], int | None, list[tuple[int, bytes]]]:
    """A chunk's uncompressed ``records``: its messages per channel, their latest log time
    (ns; None: none) and its schema and channel records (opcode, body).

    :raises CorruptChunkError: a record runs past the end of the records.
    """
    counts: dict[int, int] = {}
    last: int | None = None
    found: list[tuple[int, bytes]] = []
    fields = MSG_FIELDS.unpack_from
    for pos, opcode, length in records_of(records):
        if opcode == OP_MESSAGE:
            cid, _seq, log_time, _pub = fields(records, pos + REC_HEAD.size)
            counts[cid] = counts.get(cid, 0) + 1
            if last is None or log_time > last:
                last = log_time
        elif opcode in (OP_SCHEMA, OP_CHANNEL):
            found.append((opcode, records[pos + REC_HEAD.size:pos + REC_HEAD.size + length]))
    return counts, last, found

