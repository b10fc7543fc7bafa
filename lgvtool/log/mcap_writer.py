"""A lean MCAP writer for lgvtool's hot paths: chunked, indexed, with a summary.

The ``mcap`` package's own Writer is correct but spends tens of microseconds per message; a
one-hour log holds about 200 000 messages. :class:`McapWriter` packs message records directly
into the chunk buffer (many at once from columns, :func:`framed_records`), keeps each chunk's
message index as columns, can compress chunks on a worker thread while the next fill, and
copies whole chunks of another file verbatim (no decoding), which is what ``replay`` and
``decode`` do with the input's messages. Files written here are ordinary MCAP (checked by the
``mcap`` package's reader and the reference checker in the tests). Times in ns, sizes in bytes.
"""

from __future__ import annotations

import os
import struct
import zlib
from array import array
from collections import deque
from collections.abc import Iterable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from typing import IO, TYPE_CHECKING

from lgvtool.log.mcap_records import (
    CHUNK_HEAD,
    MAGIC,
    MI_HEAD,
    MSG_HEAD,
    OP_CHANNEL,
    OP_CHUNK,
    OP_CHUNK_INDEX,
    OP_DATA_END,
    OP_FOOTER,
    OP_HEADER,
    OP_MESSAGE,
    OP_MESSAGE_INDEX,
    OP_METADATA,
    OP_METADATA_INDEX,
    OP_SCHEMA,
    OP_STATISTICS,
    OP_SUMMARY_OFFSET,
    REC_HEAD,
    U32,
    U64,
    Channel,
    ChunkIndex,
    MetadataIndex,
    Schema,
    channel_record,
    chunk_index_record,
    compress,
    pack_id_map,
    pack_str,
    pack_string_map,
    record,
    schema_record,
)

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

#: a message record's head as a packed numpy record (31 bytes, :data:`MSG_HEAD`), to pack many
#: at once
_MSG_HEAD_DTYPE = [("opcode", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"),
                   ("log_time", "<u8"), ("publish_time", "<u8")]

BACKGROUND_DEPTH = 4
"""Chunks a background-compressing writer may have waiting for its worker thread (4 MiB each
by default): bursts of fast filling (a copied log's chunks) then do not wait for the worker;
the file is the same."""


def _compress_with_crc(kind: str, data: bytes | bytearray) -> tuple[bytes, int]:
    """``data`` compressed, and its CRC-32 (both release the GIL for large buffers)."""
    return compress(kind, data), zlib.crc32(data)


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

    def _set_index(self, cids: NDArray[np.uint16], times: NDArray[np.uint64],
                   offsets: NDArray[np.uint64]) -> None:
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
            opcode, length = REC_HEAD.unpack_from(buf, pos)
            if opcode != OP_MESSAGE:
                out += buf[pos:pos + 9 + length]
            pos += 9 + length
        new_offsets = np.empty(len(order), np.uint64)
        for k, at in enumerate(offsets[order].tolist()):
            (length,) = U64.unpack_from(buf, at + 1)
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
            rec = MI_HEAD.pack(OP_MESSAGE_INDEX, 6 + len(body), cid, len(body)) + body
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
    ``MSG_HEAD.pack`` each; times must lie in 0 .. 2**63 - 1 ns)."""
    import numpy as np

    n = len(datas)
    sizes = np.fromiter(map(len, datas), np.int64, n)
    cids = np.asarray(channel_ids, dtype=np.uint16).reshape(n)
    times = np.asarray(log_times, dtype=np.int64).reshape(n)
    if n and int(times.min()) < 0:
        raise ValueError("a message's log time is before 1970 (negative ns)")
    heads = np.zeros(n, _MSG_HEAD_DTYPE)
    heads["opcode"] = OP_MESSAGE
    heads["length"] = sizes + (MSG_HEAD.size - 9)
    heads["channel"] = cids
    heads["log_time"] = times
    heads["publish_time"] = times
    k = MSG_HEAD.size
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
        #: the chunk index records of the summary, packed as each chunk is written (about 170
        #: bytes in memory with five channels, where a ChunkIndex object with its dict took 690:
        #: a day-long recording of 1 s chunks holds 14 MB of them, not 60)
        self._chunk_indexes: list[bytes] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._counts: dict[int, int] = {}
        self._message_count = 0
        self._timed = False  # whether _start and _end hold a message's time yet
        self._start = 0
        self._end = 0
        self._chunk = _OpenChunk()
        self._pos = 0
        self._emit(MAGIC)
        self._emit(record(OP_HEADER, pack_str(profile) + pack_str(library)))

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
        c.buf += MSG_HEAD.pack(5, 22 + len(data), channel_id, sequence, log_time,
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
        head = (CHUNK_HEAD.pack(c.start, c.end, size, crc)
                + pack_str(self._compression) + U64.pack(len(compressed)))
        self._emit(REC_HEAD.pack(OP_CHUNK, len(head) + len(compressed)) + head)
        self._emit(compressed)
        mi_start = self._pos
        offsets, blob = c.message_indexes(mi_start)
        self._emit(blob)
        self._chunk_indexes.append(chunk_index_record(ChunkIndex(
            message_start_time=c.start, message_end_time=c.end, chunk_start_offset=start_offset,
            chunk_length=9 + len(head) + len(compressed), message_index_offsets=offsets,
            message_index_length=self._pos - mi_start, compression=self._compression,
            compressed_size=len(compressed), uncompressed_size=size)))
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
            self._chunk_indexes.append(chunk_index_record(ChunkIndex(
                ci.message_start_time, ci.message_end_time, new_start, ci.chunk_length,
                {k: v - mi_old + new_mi for k, v in ci.message_index_offsets.items()},
                ci.message_index_length, ci.compression, ci.compressed_size,
                ci.uncompressed_size)))
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
        rec = record(OP_METADATA, pack_str(name) + pack_string_map(data))
        self._metadata_indexes.append(MetadataIndex(self._pos, len(rec), name))
        self._emit(rec)

    def finish(self) -> None:
        """Close the open chunk and write the summary, footer and closing magic."""
        self.close_chunk()
        self.drain()
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None
        self._emit(record(OP_DATA_END, U32.pack(0)))
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
            + pack_id_map(self._counts))])
        group(OP_CHUNK_INDEX, self._chunk_indexes)
        group(OP_METADATA_INDEX, [record(OP_METADATA_INDEX, U64.pack(x.offset)
                                         + U64.pack(x.length) + pack_str(x.name))
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
