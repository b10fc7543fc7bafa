"""Write lgvtool logs: MCAP, JSON messages, schemas embedded, chunks closed every second.

Crash safety: a chunk is compressed and written as soon as the messages in it span
``chunk_seconds`` of log time (or :meth:`LogWriter.maybe_flush` finds it that old by the
wall clock), so a process killed mid-run loses at most about that much. ``fsync=True`` also
asks the OS to put each chunk on disk, for power loss.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import sys
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from itertools import pairwise
from pathlib import Path
from types import TracebackType
from typing import IO, TYPE_CHECKING, TypedDict

import orjson

from lgvtool import __version__
from lgvtool.config import Config, Reflector
from lgvtool.errors import InputError
from lgvtool.json_types import JSONRecord
from lgvtool.log import messages, topics
from lgvtool.log.mcap_writer import McapWriter
from lgvtool.log.schemas import schema_bytes
from lgvtool.timestamps import stamp

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.log.mcap_chunks import RecordColumns
    from lgvtool.log.reader import LogReader

FORMAT_VERSION = "1.0"
"""Version of the log contract written. A reader refuses a newer major version."""

PROFILE = ""
"""MCAP header profile of lgvtool logs: none (the reference checker warns of any profile but
the well-known 'ros1' and 'ros2'); the header's library and the 'lgvtool' metadata record say
what wrote the file."""

_COMPRESSION = ("zstd", "lz4", "none")

_Batch = tuple[Sequence[str], Sequence[bytes], Sequence[int]]
"""Messages to write: (topics, JSON texts, log times in ns), in time order."""

REORDER_NS = 50_000_000
"""How much older than the newest message (ns) a message may reach a time-chunked writer
(a recorder's threads) and still be written in log-time order: the newest 50 ms of a closing
chunk go into the next one."""


def _dumps(data: object) -> bytes:
    return orjson.dumps(data)


COPY_BATCH = 65536
"""Messages :meth:`LogWriter.copy_from` writes at a time."""

SPLICE_BYTES = 1 << 20
"""Bytes of a copied log's records spliced with the further messages at a time (with them,
about 4 MiB for a replay of the five estimators and the view)."""


class WriterOptions(TypedDict, total=False):
    """The keyword options of :class:`LogWriter` (chunk length in s, chunk size in bytes,
    compression, fsync, the source and command recorded in the metadata)."""

    chunk_seconds: float | None
    chunk_bytes: int
    compression: str
    fsync: bool
    source: str
    command: str | None


class LogWriter:
    """Write one lgvtool log. Use as a context manager; the file is finished on exit.

    Each schema and channel is registered on first use; topics outside the log contract are
    refused (see :mod:`lgvtool.log.topics`).

    :param path: file to create (or a binary stream).
    :param chunk_seconds: close a chunk once it spans this much log time, s; None: by size only.
    :param chunk_bytes: close a chunk once it holds this many uncompressed bytes.
    :param compression: 'zstd', 'lz4' or 'none'.
    :param fsync: fsync the file after each chunk (recorders: survive power loss).
    :param source: what wrote the log ('simulate', 'record', 'replay', ...), kept in metadata.
    :param command: the command line, kept in metadata (default: this process's argv).
    """

    def __init__(
        self,
        path: str | Path | IO[bytes],
        *,
        chunk_seconds: float | None = 1.0,
        chunk_bytes: int = 4 * 1024 * 1024,
        compression: str = "zstd",
        fsync: bool = False,
        source: str = "",
        command: str | None = None,
    ) -> None:
        if compression not in _COMPRESSION:
            raise InputError(f"unknown compression {compression!r} (zstd, lz4, none)")
        if isinstance(path, str | Path):
            self.path: Path | None = Path(path)
            self._stream: IO[bytes] = open(self.path, "wb")  # noqa: SIM115 - closed in close()
            self._owns_stream = True
        else:
            self.path = None
            self._stream = path
            self._owns_stream = False
        # a log written by size alone (a batch job, not a recorder) compresses each chunk on a
        # second thread while the next fills
        self._writer = McapWriter(self._stream, compression=compression, chunk_bytes=chunk_bytes,
                                  profile=PROFILE, library=f"lgvtool/{__version__}",
                                  background=chunk_seconds is None and not fsync)
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._chunk_ns = None if chunk_seconds is None else int(chunk_seconds * 1e9)
        self._chunk_first_ns: int | None = None
        self._chunk_wall = time.monotonic()
        self._fsync = fsync
        self._closed = False
        self.message_count = 0
        self.add_metadata("lgvtool", {
            "format_version": FORMAT_VERSION,
            "tool_version": __version__,
            "source": source,
            "command": command if command is not None else " ".join(
                [Path(sys.argv[0]).name, *sys.argv[1:]]),
            "created_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        })

    # ------------------------------------------------------------------ registration
    def _schema_id(self, name: str, own: tuple[str, bytes] | None = None) -> int:
        sid = self._schemas.get(name)
        if sid is None:
            try:
                encoding, data = "jsonschema", schema_bytes(name)
            except KeyError:
                if own is None:
                    raise
                encoding, data = own
            sid = self._writer.add_schema(name, encoding, data)
            self._schemas[name] = sid
        return sid

    def channel_id(self, topic: str, schema: str | None = None,
                   own: tuple[str, bytes] | None = None) -> int:
        """The channel id of ``topic``, registering its schema and channel on first use;
        ``own``: (encoding, data) of the schema when lgvtool has none of that name (a copied
        log's foreign channel)."""
        cid = self._channels.get(topic)
        if cid is None:
            name = schema or topics.schema_for_topic(topic)
            if name is None:
                raise ValueError(f"topic {topic!r} is not part of the lgvtool log contract")
            cid = self._writer.add_channel(topic, "json", self._schema_id(name, own))
            self._channels[topic] = cid
        return cid

    # ------------------------------------------------------------------ messages
    def write(self, topic: str, message: Mapping[str, object], log_time_ns: int,
              publish_time_ns: int | None = None) -> None:
        """Write one message dict (laid out as the topic's schema) at ``log_time_ns``."""
        self.write_encoded(topic, _dumps(message), log_time_ns, publish_time_ns)

    def write_encoded(self, topic: str, data: bytes, log_time_ns: int,
                      publish_time_ns: int | None = None) -> None:
        """Write one message that is already JSON-encoded (e.g. copied from another log)."""
        cid = self.channel_id(topic)
        t = int(log_time_ns)
        self._writer.add_message(cid, t, data, t if publish_time_ns is None else int(publish_time_ns))
        self.message_count += 1
        if self._chunk_ns is not None:
            if self._chunk_first_ns is None:
                self._chunk_first_ns = t
            elif t - self._chunk_first_ns >= self._chunk_ns:
                self.flush()

    def write_encoded_many(self, topics: Sequence[str], datas: Sequence[bytes],
                           log_times_ns: Sequence[int]) -> None:
        """Write many JSON-encoded messages in the order given (publish time = log time):
        the same file as :meth:`write_encoded` one by one, faster."""
        if self._chunk_ns is not None:
            for topic, data, t in zip(topics, datas, log_times_ns, strict=True):
                self.write_encoded(topic, data, t)
            return
        ids: dict[str, int] = {}
        cids = []
        for topic in topics:
            cid = ids.get(topic)
            if cid is None:
                cid = ids[topic] = self.channel_id(topic)
            cids.append(cid)
        self._writer.add_messages(cids, [int(t) for t in log_times_ns], datas)
        self.message_count += len(cids)

    def write_raw(self, device: str, direction: str, data: bytes, log_time_ns: int) -> None:
        """Log bytes exactly as received from (rx) or sent to (tx) ``device``."""
        self.write(topics.raw_topic(device, direction), {
            "timestamp": stamp(log_time_ns), "device": device, "direction": direction,
            "data": base64.b64encode(bytes(data)).decode("ascii"),
        }, log_time_ns)

    def write_diagnostic(self, source: str, kind: str, message: str, log_time_ns: int, *,
                         level: int = 3, count: int = 1,
                         details: JSONRecord | None = None) -> None:
        """Log a structured event on /diagnostics and its foxglove.Log mirror."""
        diag = messages.diagnostic_message(log_time_ns, source, kind, message, level=level,
                                           count=count, details=details)
        self.write(topics.DIAGNOSTICS, diag, log_time_ns)
        self.write(topics.DIAGNOSTICS_LOG, messages.log_message_of(diag), log_time_ns)

    def write_map(self, reflectors: Iterable[Reflector], log_time_ns: int) -> None:
        """Log the reflector map on /map/reflectors and as a scene on /map/scene."""
        refl = tuple(reflectors)
        self.write(topics.MAP, messages.reflector_map_message(log_time_ns, refl), log_time_ns)
        self.write(topics.MAP_SCENE, messages.map_scene_message(log_time_ns, refl), log_time_ns)

    # ------------------------------------------------------------------ metadata
    def add_metadata(self, name: str, data: Mapping[str, object]) -> None:
        """Write a metadata record; each value is stored JSON-encoded (a string in quotes)."""
        self._writer.add_metadata(name, {
            str(k): json.dumps(v, separators=(",", ":")) for k, v in data.items()
        })
        self._chunk_first_ns = None

    def copy_from(self, reader: LogReader, *, skip_topics: frozenset[str] = frozenset(),
                  metadata: bool = True,
                  extra: _Batch | Iterable[_Batch] | None = None,
                  verbatim: bool = True) -> int:
        """Copy every message of ``reader`` (except ``skip_topics``) into this log, and its
        metadata records other than 'lgvtool'. Returns the number of messages copied.

        ``extra``: (topics, JSON datas, log times in ns) of further messages, sorted by time,
        merged with the copied ones so that the file is in log-time order (a copied message
        first at equal times); or an iterable (not a tuple) of such batches, each sorted and the
        batches in increasing time, taken one at a time as the merge reaches them (so that
        only one batch need exist at once, e.g. :class:`lgvtool.log.windows.WindowedMerge`).
        Without it, a complete input copied into a fresh writer has its
        chunks copied verbatim (no decoding) unless ``verbatim`` is False (the records are then
        put into new chunks compressed as this writer compresses); otherwise the input's
        records are spliced with the further messages (message by message where its chunks
        overlap in time).
        """
        if metadata:
            for name, record in reader.metadata.items():
                if name != "lgvtool":
                    self.add_metadata(name, record)
        plan = reader.verbatim_plan(skip_topics) if extra is None and verbatim else None
        if plan is not None and not self._channels and not self._schemas:
            schemas, channels, chunk_indexes, counts = plan
            for sid, (name, encoding, data) in schemas.items():
                self._writer.add_schema(name, encoding, data, schema_id=sid, in_data=False)
                self._schemas[name] = sid
            for cid, (topic, encoding, sid) in channels.items():
                self._writer.add_channel(topic, encoding, sid, channel_id=cid, in_data=False)
                self._channels[topic] = cid
            with open(reader.path, "rb") as source:
                self._writer.copy_chunks(source, chunk_indexes, counts)
            n = sum(counts.values())
            self.message_count += n
            return n
        batches = iter([extra] if isinstance(extra, tuple) else extra if extra else [])
        chunks = reader.record_chunks() if not self._channels and self._chunk_ns is None \
            else None
        if chunks is not None:
            return self._splice(reader, chunks, skip_topics, batches)
        merge = _Merge(self, batches, {s.name: (s.encoding, s.data)
                                       for s in getattr(reader, "_schemas", {}).values()})
        seen: set[int] = set()
        dropped: set[int] = set()
        n = 0
        for block in reader.raw_blocks():
            cids = {m[1] for m in block}
            for cid in cids - seen:
                seen.add(cid)
                if reader.channel_topic(cid)[0] in skip_topics:
                    dropped.add(cid)
            kept = [m for m in block if m[1] not in dropped] if cids & dropped else block
            if kept:
                merge.add(kept, reader)
                n += len(kept)
        merge.finish()
        return n

    def _splice(self, reader: LogReader, chunks: Iterator[tuple[bytes, RecordColumns]],
                skip_topics: frozenset[str], batches: Iterator[_Batch]) -> int:
        """:meth:`copy_from` of a fresh writer from the input's chunks as records: the input's
        schemas and channels registered under their own ids, its records copied as they are
        (:func:`lgvtool.log.splice.spliced`), the further messages framed and merged in."""
        import numpy as np

        from lgvtool.log.mcap_writer import framed_records
        from lgvtool.log.splice import spliced

        w = self._writer
        schemas, channels = reader.registrations()
        for sid, s in schemas.items():
            w.add_schema(s.name, s.encoding, s.data, schema_id=sid)
            # the further messages share a schema the input holds as lgvtool writes it
            try:
                if s.encoding == "jsonschema" and s.data == schema_bytes(s.name):
                    self._schemas.setdefault(s.name, sid)
            except KeyError:
                pass
        dropped = []
        for cid, c in channels.items():
            if c.topic in skip_topics:
                dropped.append(cid)
                continue
            w.add_channel(c.topic, c.message_encoding, c.schema_id, channel_id=cid,
                          metadata=c.metadata)
            self._channels[c.topic] = cid
        skip = np.array(dropped, dtype=np.uint16)
        pending = _Pending(batches)
        copied = 0
        full = (c for c in chunks if len(c[1][1]))  # the chunks with a message record
        current = next(full, None)
        while current is not None:
            records, (cids, times, offsets, sizes) = current
            current = next(full, None)
            keep = ~np.isin(cids, skip) if len(skip) else None
            copied += len(cids) if keep is None else int(np.count_nonzero(keep))
            # about SPLICE_BYTES of the input at a time, with the further messages before the
            # next part's first message (they outweigh the input: the estimates, the view)
            cuts = np.searchsorted(np.cumsum(sizes), np.arange(SPLICE_BYTES, int(sizes.sum()),
                                                                SPLICE_BYTES))
            bounds = [0, *np.unique(cuts[(cuts > 0) & (cuts < len(cids))]).tolist(), len(cids)]
            for a, b in pairwise(bounds):
                if b < len(cids):
                    until: int | None = int(times[b])
                else:
                    until = int(current[1][1][0]) if current is not None else None
                e_topics, e_datas, e_times = pending.before(until)
                ids = {t: self.channel_id(t) for t in dict.fromkeys(e_topics)}
                added = framed_records([ids[t] for t in e_topics], e_times, e_datas)
                block = spliced(records, (cids[a:b], times[a:b], offsets[a:b], sizes[a:b]),
                                None if keep is None else keep[a:b], added)
                if len(block[1]):
                    w.add_records(*block)
                self.message_count += len(block[1])
        for batch in pending.left():
            self.write_encoded_many(*batch)
        return copied

    def write_config(self, config: Config) -> None:
        """Store the effective configuration as the metadata record 'config'."""
        d = config.to_dict()
        self.add_metadata("config", d)

    # ------------------------------------------------------------------ chunking
    def maybe_flush(self) -> None:
        """Close the chunk in progress if it is older than ``chunk_seconds`` by the wall clock
        (call this periodically while a device is silent)."""
        if self._chunk_ns is None or self._chunk_first_ns is None:
            return
        if (time.monotonic() - self._chunk_wall) * 1e9 >= self._chunk_ns:
            self.flush()

    def flush(self) -> None:
        """Write the chunk in progress to the file now (a time-chunked writer keeps its last
        :data:`REORDER_NS` of messages for the next chunk, so that messages handed over a
        little out of order still land in log-time order)."""
        self._writer.close_chunk(REORDER_NS if self._chunk_ns is not None else 0)
        self._writer.drain()
        self._stream.flush()
        if self._fsync and self._owns_stream:
            os.fsync(self._stream.fileno())
        self._chunk_first_ns = self._writer.open_chunk_start
        self._chunk_wall = time.monotonic()

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Finish the file: last chunk, summary, indexes, footer. When that fails (a full
        disk), the file is closed all the same and the error raised."""
        if self._closed:
            return
        self._closed = True
        try:
            self._writer.finish()
            if self._owns_stream:
                self._stream.flush()
                if self._fsync:
                    os.fsync(self._stream.fileno())
        except BaseException:
            self._release()
            raise
        if self._owns_stream:
            self._stream.close()

    def abort(self) -> None:
        """Close the file without finishing it (after a write error such as a full disk): what
        was written stays readable as a salvaged log; nothing more is attempted."""
        self._closed = True
        self._release()

    def _release(self) -> None:
        """Close the file this writer opened, if it is still open, whatever its buffer's last
        write does (a file left open would report its failed flush when collected)."""
        if self._owns_stream and not self._stream.closed:
            with contextlib.suppress(OSError, ValueError):
                self._stream.close()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


class _Pending:
    """Further messages (batches sorted by time, the batches in increasing time) handed out
    up to a time as a merge reaches it, the batches taken as they are needed."""

    def __init__(self, batches: Iterator[_Batch]) -> None:
        self._batches = batches
        self._more = True
        self._topics: list[str] = []
        self._datas: list[bytes] = []
        self._times: list[int] = []

    def before(self, t: int | None) -> tuple[list[str], list[bytes], list[int]]:
        """The messages before log time ``t`` (ns; None: all that are left), removed."""
        import bisect

        while self._more and (t is None or not self._times or self._times[-1] < t):
            nxt = next(self._batches, None)
            if nxt is None:
                self._more = False
                break
            self._topics.extend(nxt[0])
            self._datas.extend(nxt[1])
            times = nxt[2]
            # (a list of ints as the merges give it is taken as it is)
            self._times.extend(times if isinstance(times, list) else map(int, times))
        k = len(self._times) if t is None else bisect.bisect_left(self._times, t)
        out = (self._topics[:k], self._datas[:k], self._times[:k])
        del self._topics[:k], self._datas[:k], self._times[:k]
        return out

    def left(self) -> Iterator[_Batch]:
        """Every message left: those pulled already, then the remaining batches one at a
        time."""
        if self._times:
            held = (self._topics, self._datas, self._times)
            self._topics, self._datas, self._times = [], [], []
            yield held
        if self._more:
            self._more = False
            yield from self._batches


class _Merge:
    """Merges a log's messages, a block at a time, with batches of further messages (sorted
    by time, the batches in increasing time) into a writer: a further message goes after
    every log message at or before its time. Writes in batches of :data:`COPY_BATCH`
    messages, with each log topic registered when first met and the further topics when
    their batch is written (the file of a message-by-message merge)."""

    def __init__(self, writer: LogWriter, batches: Iterator[_Batch],
                 own: dict[str, tuple[str, bytes]]) -> None:
        self._w = writer
        self._own = own
        # further messages not yet placed
        self._pending = _Pending(batches)
        # the batch being gathered, and the log topics registered
        self._batch: tuple[list[str], list[bytes], list[int]] = ([], [], [])
        self._inputs: list[tuple[str, str]] = []
        self._registered: set[str] = set()
        self._names: dict[int, tuple[str, str]] = {}

    def add(self, block: list[tuple[int, int, int, bytes]], reader: LogReader) -> None:
        """Merge one block of log messages ``(log time, channel id, publish time, data)`` (in
        log-time order) with the further messages before its last time."""
        import numpy as np

        e_topics, e_datas, e_times = self._pending.before(block[-1][0])
        k = len(e_times)
        cache = self._names
        for cid in {m[1] for m in block} - cache.keys():
            cache[cid] = reader.channel_topic(cid)
        names = [cache[m[1]] for m in block]
        times = [m[0] for m in block]
        if k:
            kinds = np.concatenate([np.zeros(len(block), np.int8), np.ones(k, np.int8)])
            order = np.lexsort((kinds, np.array(times + e_times, dtype=np.int64))).tolist()
            all_topics = [n[0] for n in names] + e_topics
            all_datas = [m[3] for m in block] + e_datas
            all_times = times + e_times
            topics = [all_topics[i] for i in order]
            datas = [all_datas[i] for i in order]
            tt = [all_times[i] for i in order]
            is_input = (kinds[order] == 0)
            inputs = [names[i] for i in order if i < len(block)]
        else:
            topics = [n[0] for n in names]
            datas = [m[3] for m in block]
            tt = times
            is_input = np.ones(len(block), dtype=bool)
            inputs = names
        self._extend(topics, datas, tt, is_input, inputs)

    def _extend(self, topics: list[str], datas: list[bytes], times: list[int],
                is_input: NDArray[np.bool_], inputs: list[tuple[str, str]]) -> None:
        """Append merged messages to the batch, writing it at the first log message at which
        it holds :data:`COPY_BATCH` messages."""
        import numpy as np

        at = 0
        n = len(topics)
        while at < n:
            room = COPY_BATCH - len(self._batch[2])
            # the batch reaches its size at position at + room - 1; it is written after the
            # first log message from there on
            cut = n
            if room <= n - at:
                later = np.flatnonzero(is_input[at + max(room, 1) - 1:])
                if len(later):
                    cut = at + max(room, 1) - 1 + int(later[0]) + 1
            n_in = int(np.count_nonzero(is_input[at:cut]))
            self._batch[0].extend(topics[at:cut])
            self._batch[1].extend(datas[at:cut])
            self._batch[2].extend(times[at:cut])
            self._inputs.extend(inputs[:n_in])
            del inputs[:n_in]
            at = cut
            if cut < n or (len(self._batch[2]) >= COPY_BATCH and n_in and is_input[cut - 1]):
                self._flush()

    def _flush(self) -> None:
        """Register the batch's new log topics, then write it."""
        for topic, schema in self._inputs:
            if topic not in self._registered:
                self._registered.add(topic)
                if schema:
                    self._w.channel_id(topic, schema, self._own.get(schema))
        self._inputs = []
        self._w.write_encoded_many(*self._batch)
        self._batch = ([], [], [])

    def finish(self) -> None:
        """Write the batch with every further message left, then the remaining batches."""
        rest = self._pending.left()
        for dst, src in zip(self._batch, next(rest, ([], [], [])), strict=True):
            dst.extend(src)  # type: ignore[attr-defined]
        self._flush()
        for batch in rest:
            self._w.write_encoded_many(*batch)
