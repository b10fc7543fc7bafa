"""Reading the chunks of an indexed MCAP file: checked, through their message indexes.

The ``mcap`` package's Reader is correct but spends tens of microseconds per message. Here a
chunk is read with one ``read`` (with its message indexes, :func:`chunk_window`), decompressed
once and checked against its size and CRC-32 (:func:`verified_records`), and its messages are
found through the message indexes as columns (:func:`record_columns`, :func:`read_channels`),
or by walking the records when an index is missing or does not fit. Chunks that overlap in
time are merged in log-time order (:func:`iter_indexed`). The functions that go through many
chunks are handed how to read one (a :data:`LoadChunk`, :func:`load_chunk` for a chunk record
of the file): the sources of :mod:`lgvtool.log.sources` give it. Reading does not import the
``mcap`` package. Times in ns, offsets and sizes in bytes.
"""

from __future__ import annotations

import heapq
import zlib
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import IO, TYPE_CHECKING, NamedTuple

import zstandard

from lgvtool.log.mcap_records import (
    CHUNK_HEAD,
    MSG_FIELDS,
    OP_CHUNK,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    REC_HEAD,
    U16,
    U32,
    U64,
    ChunkIndex,
    FileBytes,
    decompress,
)

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray


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


class ChunkWindow(NamedTuple):
    """One chunk read and checked: the bytes read (the chunk record and, when they follow it,
    its message indexes), its index with offsets relative to them (``local``; no message
    indexes when they were not read), and its uncompressed records."""

    buf: bytes
    local: ChunkIndex
    records: bytes


#: reads the chunk a :class:`ChunkIndex` points at and checks it
#: (raises :class:`CorruptChunkError`)
LoadChunk = Callable[[ChunkIndex], ChunkWindow]


def load_chunk(f: IO[bytes], ci: ChunkIndex, zstd: zstandard.ZstdDecompressor | None = None
               ) -> ChunkWindow:
    """The chunk record ``ci`` points at in ``f`` (:func:`chunk_window`), its records checked
    (:func:`verified_records`).

    :raises CorruptChunkError: a check fails.
    """
    buf, local = chunk_window(f, ci)
    return ChunkWindow(buf, local, verified_records(buf, local, zstd))


def records_of(records: bytes) -> Iterator[tuple[int, int, int]]:
    """``(offset, opcode, length)`` of every record in a chunk's uncompressed ``records``.

    :raises CorruptChunkError: a record runs past the end of ``records`` (or a message record
        is too short for its fields).
    """
    pos, n = 0, len(records)
    rec_head = REC_HEAD.unpack_from
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
    fields = MSG_FIELDS.unpack_from
    for pos, opcode, length in records_of(records):
        if opcode == OP_MESSAGE:
            cid, _seq, log_time, pub = fields(records, pos + 9)
            if wanted is None or cid in wanted:
                out.append((log_time, cid, pub, records[pos + 31 : pos + 9 + length]))
    return out


def _chunk_frame(buf: FileBytes, ci: ChunkIndex) -> tuple[str, int, int, int]:
    """Compression, offset and length (bytes) of the compressed records of the chunk ``ci``
    of a file held in ``buf``, and the CRC-32 of its uncompressed records (0: none).

    :raises CorruptChunkError: the chunk record lies outside the file or its header does not
        parse.
    """
    at = ci.chunk_start_offset
    if at < 0 or at + 9 + CHUNK_HEAD.size + 4 > len(buf) or buf[at] != OP_CHUNK:
        raise CorruptChunkError(at, "no chunk record where the index points")
    pos = at + 9 + CHUNK_HEAD.size
    crc = CHUNK_HEAD.unpack_from(buf, at + 9)[3]
    (clen,) = U32.unpack_from(buf, pos)
    if pos + 4 + clen + 8 > len(buf):
        raise CorruptChunkError(at, "chunk header runs past the end of the file")
    try:
        kind = bytes(buf[pos + 4:pos + 4 + clen]).decode()
    except UnicodeDecodeError:
        raise CorruptChunkError(at, "unreadable compression name") from None
    pos += 4 + clen
    (dlen,) = U64.unpack_from(buf, pos)
    if pos + 8 + dlen > len(buf):
        raise CorruptChunkError(at, "chunk data runs past the end of the file")
    return kind, pos + 8, dlen, crc


def verified_records(buf: FileBytes, ci: ChunkIndex,
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


DECOMPRESS_ERRORS = (zstandard.ZstdError, RuntimeError, ValueError, MemoryError)
"""What decompressing a chunk's data raises when the data is damaged: zstandard raises
``ZstdError``; lz4.frame raises ``RuntimeError`` (a bad frame header, checksum or length);
:func:`~lgvtool.log.mcap_records.decompress` raises ``ValueError`` for a compression it does
not know; and zstd allocates the size the chunk header gives when its frame does not state
one, so a damaged size asks for more memory than there is (``MemoryError``)."""


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
    except DECOMPRESS_ERRORS as exc:
        name = kind or "uncompressed"
        raise CorruptChunkError(offset, f"{name} data does not decompress ({exc})") from None
    if len(records) != size:
        raise CorruptChunkError(offset, f"{len(records)} bytes of records, the header says "
                                        f"{size}")
    if crc and zlib.crc32(records) != crc:
        raise CorruptChunkError(offset, "CRC-32 of its records does not match")
    return records


def _indexed_payloads(buf: FileBytes, records: bytes, off: int, cid: int
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
    unpack = U64.unpack_from
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


def record_columns(chunks: Sequence[tuple[FileBytes, ChunkIndex, bytes]],
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
    fields = MSG_FIELDS.unpack_from
    for pos, opcode, length in records_of(records):
        if opcode == OP_MESSAGE:
            cid, _seq, log_time, _pub = fields(records, pos + 9)
            cids.append(cid)
            times.append(log_time)
            offsets.append(pos)
            sizes.append(9 + length)
    return (np.array(cids, dtype=np.uint16), np.array(times, dtype=np.uint64).astype(np.int64),
            np.array(offsets, dtype=np.int64), np.array(sizes, dtype=np.int64))


def _index_entries(buf: FileBytes, at: int, cid: int) -> bytes | None:
    """The (log time, offset) pairs, as bytes (u64 each, 16 a pair), of the Message Index
    record of channel ``cid`` at ``at`` in ``buf``; None when no such record is there."""
    if at < 0 or at + 15 > len(buf) or buf[at] != OP_MESSAGE_INDEX:
        return None
    (got,) = U16.unpack_from(buf, at + 9)
    (nbytes,) = U32.unpack_from(buf, at + 11)
    if got != cid or nbytes % 16 or at + 15 + nbytes > len(buf):
        return None
    return bytes(buf[at + 15:at + 15 + nbytes])


def _indexed_columns(chunks: Sequence[tuple[FileBytes, ChunkIndex, int]], records: bytes
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
                   records_of(records[int(ends[g]):int(starts[g])])):
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


def iter_channel_chunks(load: LoadChunk, chunk_indexes: Sequence[ChunkIndex],
                        wanted: Iterable[int], on_corrupt: OnCorrupt | None = None,
                        verified: set[int] | None = None
                        ) -> Iterator[dict[int, tuple[NDArray[np.uint64], list[bytes]]]]:
    """The messages of the ``wanted`` channels of the chunks ``chunk_indexes``, one chunk at a
    time (in the order of the chunks' start times), each read by ``load``: per channel in the
    chunk, the log times (ns) and the message data in stored order. Only one chunk is held at
    a time.

    Only the chunks holding a wanted channel are read (and checked, see
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
    for ci in order:
        try:
            buf, local, records = load(ci)
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


def read_channels(load: LoadChunk, chunk_indexes: Sequence[ChunkIndex], wanted: Iterable[int],
                  on_corrupt: OnCorrupt | None = None, verified: set[int] | None = None
                  ) -> dict[int, tuple[NDArray[np.int64], list[bytes]]]:
    """Every message of the ``wanted`` channels of the chunks ``chunk_indexes``: per channel,
    the log times (ns) and the message data, in log-time order (ties in stored order). Chunks
    are read (by ``load``) and checked as by :func:`iter_channel_chunks`."""
    import numpy as np

    want = set(wanted)
    times: dict[int, list[NDArray[np.uint64]]] = {c: [] for c in want}
    datas: dict[int, list[bytes]] = {c: [] for c in want}
    for found in iter_channel_chunks(load, chunk_indexes, want, on_corrupt, verified):
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


def iter_indexed(load: LoadChunk, chunk_indexes: Sequence[ChunkIndex],
                 wanted: set[int] | None, on_corrupt: OnCorrupt | None = None,
                 verified: set[int] | None = None) -> Iterator[tuple[int, int, int, bytes]]:
    """Messages of the ``wanted`` channels in log-time order across (possibly overlapping)
    chunks: (log_time ns, channel_id, publish_time ns, data); see
    :func:`iter_indexed_blocks`."""
    for block in iter_indexed_blocks(load, chunk_indexes, wanted, on_corrupt, verified):
        yield from block


def iter_indexed_blocks(load: LoadChunk, chunk_indexes: Sequence[ChunkIndex],
                        wanted: set[int] | None, on_corrupt: OnCorrupt | None = None,
                        verified: set[int] | None = None
                        ) -> Iterator[list[tuple[int, int, int, bytes]]]:
    """Messages of the ``wanted`` channels (None: all) in log-time order across (possibly
    overlapping) chunks, in lists (a chunk's messages, or up to :data:`MERGED_BLOCK` merged
    from overlapping chunks): (log_time ns, channel_id, publish_time ns, data). Chunks are
    read lazily by ``load`` and checked (:func:`verified_records`); a corrupt one is passed to
    ``on_corrupt`` and skipped (without ``on_corrupt`` it raises :class:`CorruptChunkError`);
    sound ones are added to ``verified`` (file offsets)."""
    order = sorted((ci for ci in chunk_indexes
                    if wanted is None or not ci.message_index_offsets
                    or wanted & ci.message_index_offsets.keys()),
                   key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))

    def messages_of(ci: ChunkIndex) -> list[tuple[int, int, int, bytes]]:
        try:
            msgs = chunk_messages(load(ci).records, wanted)
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
            msgs = messages_of(ci)
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
            for m in messages_of(order[i]):
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
