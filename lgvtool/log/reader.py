"""Read lgvtool logs: typed messages in log-time order, metadata, per-topic DataFrames.

A log that was cut off mid-write (crash, power loss, full disk) has no summary or footer. The
reader then walks the file's records once up to the cut (:mod:`lgvtool.log.mcap_scan`), finds
every complete chunk, reads their messages a chunk at a time as it reads a complete log's, and
says so in :attr:`LogReader.warnings`; :attr:`LogReader.complete` is False.
"""

from __future__ import annotations

import json
import warnings as _warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

import orjson

from lgvtool.config import Config, Reflector, config_from_dict, default_config
from lgvtool.errors import ConfigError, LogFormatError
from lgvtool.log import topics as T
from lgvtool.log.mcap_chunks import (
    CorruptChunkError,
    RecordColumns,
    checked_records,
    chunk_messages,
    chunk_window,
    iter_channel_chunks,
    iter_indexed,
    iter_indexed_blocks,
    read_channels,
    record_columns,
    verified_records,
)
from lgvtool.log.mcap_records import (
    MAGIC,
    Channel,
    ChunkIndex,
    Metadata,
    Schema,
    data_section_crc,
    read_metadata,
    read_summary,
    starts_with_magic,
)
from lgvtool.log.validate import check_channel
from lgvtool.log.writer import FORMAT_VERSION

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd
    from mcap.records import Message
    from numpy.typing import NDArray


class LogMessage(NamedTuple):
    """One decoded message: topic, host receive time (ns since the Unix epoch), and its dict."""

    topic: str
    log_time_ns: int
    data: dict[str, Any]


class RawMessage(NamedTuple):
    """One message as stored: topic, schema name, times in ns, JSON bytes."""

    topic: str
    schema: str
    log_time_ns: int
    publish_time_ns: int
    data: bytes


#: one chunk's messages of some topics, undecoded: per topic, the log times (ns since the
#: epoch) and the JSON bytes in stored order (:meth:`LogReader.raw_column_chunks`)
RawBlock = Mapping[str, tuple["NDArray[np.int64]", list[bytes]]]


class Tap(Protocol):
    """Another reader of the chunks a reading pass goes through, so that a caller takes more
    from the log in the same pass: it names its ``topics`` and is handed each chunk's messages
    of them (with those of the pass's own topics) before the pass decodes them
    (:meth:`LogReader.dataframes`, :func:`lgvtool.localize.logdata.load_log`; a
    :class:`lgvtool.log.frames.TopicTables` is one)."""

    @property
    def topics(self) -> Sequence[str]:
        """The topics to be read for this tap (those the log has)."""
        ...

    def add(self, block: RawBlock) -> None:
        """Take one chunk's messages."""
        ...


@dataclass(frozen=True)
class TopicInfo:
    """What a log holds on one topic. Times in ns since the Unix epoch."""

    schema: str
    count: int
    start_ns: int
    end_ns: int
    max_gap_ns: int

    @property
    def duration_s(self) -> float:
        """Span between the first and last message, s."""
        return (self.end_ns - self.start_ns) / 1e9

    @property
    def rate_hz(self) -> float:
        """Mean message rate, Hz (0 with fewer than two messages)."""
        return (self.count - 1) / self.duration_s if self.count > 1 and self.duration_s > 0 else 0.0


RECORD_GROUP_BYTES = 4 * 1024 * 1024
"""Uncompressed bytes of records :meth:`LogReader.record_chunks` hands over at once (a log
recorded with a chunk a second has chunks of 40 kB: numpy's cost per call is then paid per
4 MiB, not per chunk)."""


CORRUPT_CHUNKS_SAID = 5
"""Corrupt chunks of one log named in a warning each; the rest are counted, in one more."""


class LogWarning(UserWarning):
    """Issued when a log is opened that is incomplete or not written by lgvtool."""


def _major(version: str) -> int:
    try:
        return int(str(version).split(".")[0])
    except ValueError:
        return -1


class LogReader:
    """Open an lgvtool log (MCAP) for reading.

    :param path: the log file.
    :raises LogFormatError: not a file, empty, not MCAP, a foreign MCAP without lgvtool
        topics, or written with a newer major ``format_version``.
    """

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise LogFormatError(f"{self.path}: no such file")
        if not self.path.is_file():
            raise LogFormatError(f"{self.path}: not a file")
        size = self.path.stat().st_size
        if size == 0:
            raise LogFormatError(f"{self.path}: empty file")
        if not starts_with_magic(self.path):
            raise LogFormatError(f"{self.path}: not an MCAP file")
        self.size = size
        self.warnings: list[str] = []
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._metadata: list[Metadata] = []
        self._salvaged: list[Message] | None = None
        self._chunk_indexes: list[ChunkIndex] = []
        self._counts: dict[int, int] = {}
        #: file offset -> reason of every chunk found corrupt and skipped so far
        self.corrupt_chunks: dict[int, str] = {}
        self._checked_topics: set[str] = set()
        self._verified: set[int] = set()  # offsets of chunks read and found sound
        self.salvaged_bytes = size
        self.complete = self._open_indexed()
        if not self.complete:
            self._salvage()
        self.metadata: dict[str, dict[str, Any]] = {}
        for rec in self._metadata:
            self.metadata[rec.name] = {k: _decode_value(v) for k, v in rec.metadata.items()}
        self._check_contract()
        self._topic_info: dict[str, TopicInfo] | None = None
        for w in self.warnings:
            _warnings.warn(w, LogWarning, stacklevel=2)

    # ------------------------------------------------------------------ opening
    def _open_indexed(self) -> bool:
        from lgvtool.log.mcap_records import CorruptSummaryError

        try:
            with open(self.path, "rb") as f:
                try:
                    summary = read_summary(f)
                except CorruptSummaryError as exc:
                    self.warnings.append(f"{self.path}: {exc}; reading the file record by "
                                         "record instead of through its index")
                    return False
                if summary is None:
                    return False
                self._check_data_crc(f)
                self._schemas = summary.schemas
                self._channels = summary.channels
                self._metadata = [read_metadata(f, i) for i in summary.metadata_indexes]
                self._chunk_indexes = summary.chunk_indexes
                if summary.channel_message_counts is not None:
                    self._counts = summary.channel_message_counts
            return True
        except Exception:
            self._schemas, self._channels, self._metadata = {}, {}, []
            self._chunk_indexes, self._counts = [], {}
            return False

    def _check_data_crc(self, f: Any) -> None:
        """Compare the data section with its CRC-32 when the file has one (a warning only:
        the chunks' own CRCs tell which messages are affected)."""
        import mmap
        import struct

        f.seek(-(9 + 20 + len(MAGIC)), 2)
        (summary_start,) = struct.unpack_from("<Q", f.read(17), 9)
        try:
            buf: Any = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
        except (OSError, ValueError):
            return
        try:
            crcs = data_section_crc(buf, summary_start)
        finally:
            buf.close()
        if crcs is not None and crcs[0] != crcs[1]:
            self.warnings.append(f"{self.path}: the data section does not match its CRC-32")

    def _note_corrupt(self, ci: ChunkIndex | int, reason: str) -> None:
        """Count a corrupt chunk (skipped by the caller) and say so once, as a warning; beyond
        :data:`CORRUPT_CHUNKS_SAID` of them, one more warning says that others follow (a badly
        damaged file would otherwise print a line per chunk); all are counted."""
        offset = ci if isinstance(ci, int) else ci.chunk_start_offset
        if offset in self.corrupt_chunks:
            return
        self.corrupt_chunks[offset] = reason
        said = len(self.corrupt_chunks)
        if said <= CORRUPT_CHUNKS_SAID:
            text = (f"{self.path}: chunk at byte {offset} is corrupt ({reason}); its messages "
                    "skipped")
        elif said == CORRUPT_CHUNKS_SAID + 1:
            text = (f"{self.path}: more chunks are corrupt, from byte {offset} on; their "
                    f"messages skipped too (lgvtool info counts them)")
        else:
            return
        self.warnings.append(text)
        _warnings.warn(text, LogWarning, stacklevel=3)

    def _salvage(self) -> None:
        """Find the records of a file without a usable summary (:mod:`lgvtool.log.mcap_scan`):
        its chunks are then read one at a time, as a complete file's are. A file with message
        records outside chunks, or with messages on a channel whose definition was lost, is
        read record by record into memory instead (:meth:`_salvage_in_memory`)."""
        from lgvtool.log.mcap_scan import scan_records

        corrupt: list[tuple[int, str]] = []
        with open(self.path, "rb") as f:
            scan = scan_records(f, self.size, lambda at, why: corrupt.append((at, why)))
        if scan.loose_messages or scan.unknown_channels():
            self._salvage_in_memory()
            return
        for at, why in corrupt:
            self._note_corrupt(at, why)
        self._schemas, self._channels = scan.schemas, scan.channels
        self._metadata = scan.metadata
        self._chunk_indexes = scan.chunk_indexes
        self._verified.update(ci.chunk_start_offset for ci in scan.chunk_indexes)
        self.salvaged_bytes = scan.good_end
        self._say_salvaged(scan.good_end, sum(scan.counts.values()), scan.last_time)

    def _say_salvaged(self, good_end: int, messages: int, last_ns: int | None) -> None:
        where = f", last message at {last_ns / 1e9:.3f} s" if last_ns is not None else ""
        self.warnings.append(
            f"{self.path}: incomplete log (no summary; cut off after {good_end} of {self.size} "
            f"bytes): salvaged {messages} complete messages{where}"
        )

    def _salvage_in_memory(self) -> None:
        """Walk the file record by record through the ``mcap`` package's stream reader and
        keep every complete message (in log-time order) in memory."""
        from mcap.records import Channel as McapChannel
        from mcap.records import Chunk, Message
        from mcap.records import Metadata as McapMetadata
        from mcap.records import Schema as McapSchema
        from mcap.stream_reader import StreamReader

        msgs: list[Message] = []
        good_end = len(MAGIC)
        with open(self.path, "rb") as f:
            stream = StreamReader(f, skip_magic=False, emit_chunks=True,
                                  record_size_limit=self.size)
            try:
                for rec in _chunk_records(stream.records, self._note_corrupt, f):
                    if isinstance(rec, Chunk):
                        continue
                    if isinstance(rec, Message):
                        msgs.append(rec)
                    # the first definition counts: the data section's, not the summary's
                    # copy (which may be what failed its CRC)
                    elif isinstance(rec, McapSchema) and rec.id not in self._schemas:
                        self._schemas[rec.id] = Schema(rec.id, rec.name, rec.encoding, rec.data)
                    elif isinstance(rec, McapChannel) and rec.id not in self._channels:
                        self._channels[rec.id] = Channel(rec.id, rec.topic, rec.message_encoding,
                                                         rec.schema_id, dict(rec.metadata))
                    elif isinstance(rec, McapMetadata):
                        self._metadata.append(Metadata(rec.name, dict(rec.metadata)))
                    good_end = f.tell()
            except Exception:
                pass
        msgs.sort(key=lambda m: m.log_time)
        self._salvaged = [m for m in msgs if m.channel_id in self._channels]
        self.salvaged_bytes = good_end
        self._say_salvaged(good_end, len(self._salvaged),
                           self._salvaged[-1].log_time if self._salvaged else None)

    def _check_contract(self) -> None:
        info = self.metadata.get("lgvtool")
        known = any(T.schema_for_topic(c.topic) for c in self._channels.values())
        if info is None:
            if not known:
                raise LogFormatError(f"{self.path}: an MCAP file, but not an lgvtool log "
                                     "(no lgvtool metadata and no lgvtool topics)")
            self.warnings.append(f"{self.path}: no lgvtool metadata; reading its lgvtool topics")
            return
        version = str(info.get("format_version", "0"))
        if _major(version) > _major(FORMAT_VERSION):
            raise LogFormatError(
                f"{self.path}: log format {version} is newer than this lgvtool reads "
                f"({FORMAT_VERSION}); upgrade lgvtool")
        if _major(version) < 0:
            raise LogFormatError(f"{self.path}: unreadable format_version {version!r}")

    # ------------------------------------------------------------------ messages
    def raw_messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Every stored message (or those of ``topics``) in log-time order, undecoded."""
        wanted = None if topics is None else set(topics)
        self.check_topics(wanted)
        yield from self._raw_messages(wanted)

    def _raw_messages(self, wanted: set[str] | None) -> Iterator[RawMessage]:
        schemas = {sid: s.name for sid, s in self._schemas.items()}
        if self._salvaged is not None:
            for m in self._salvaged:
                ch = self._channels[m.channel_id]
                if wanted is None or ch.topic in wanted:
                    yield RawMessage(ch.topic, schemas.get(ch.schema_id, ""), m.log_time,
                                     m.publish_time, m.data)
            return
        ids = None if wanted is None else {cid for cid, c in self._channels.items()
                                           if c.topic in wanted}
        if ids is not None and not ids:
            return
        topic_of = {cid: (c.topic, schemas.get(c.schema_id, "")) for cid, c in self._channels.items()}
        with open(self.path, "rb") as f:
            for log_time, cid, pub, data in iter_indexed(f, self._chunk_indexes, ids,
                                                         self._note_corrupt, self._verified):
                topic, schema = topic_of[cid]
                yield RawMessage(topic, schema, log_time, pub, data)

    def raw_blocks(self) -> Iterator[list[tuple[int, int, int, bytes]]]:
        """Every stored message in log-time order, undecoded, in blocks (about a chunk's):
        ``(log time ns, channel id, publish time ns, data)``; :meth:`channel_topic` names a
        channel id. The same messages in the same order as :meth:`raw_messages`."""
        self.check_topics(None)
        if self._salvaged is not None:
            block = [(m.log_time, m.channel_id, m.publish_time, m.data) for m in self._salvaged]
            if block:
                yield block
            return
        with open(self.path, "rb") as f:
            yield from iter_indexed_blocks(f, self._chunk_indexes, None, self._note_corrupt,
                                           self._verified)

    def registrations(self) -> tuple[dict[int, Schema], dict[int, Channel]]:
        """The log's schemas and channels by id (copies)."""
        return dict(self._schemas), dict(self._channels)

    def record_chunks(self) -> Iterator[tuple[bytes, RecordColumns]] | None:
        """The log's message records in log-time order, as the uncompressed records of runs of
        consecutive chunks (at least :data:`RECORD_GROUP_BYTES` each, but the last) with the
        columns of their message records (:func:`lgvtool.log.mcap_chunks.record_columns`);
        corrupt chunks skipped with a warning as :meth:`raw_blocks` skips them: the same
        messages in the same order as :meth:`raw_blocks`. None when that order is not the
        chunks' (a salvaged file, chunks whose times overlap)."""
        self.check_topics(None)
        if self._salvaged is not None:
            return None
        order = sorted(self._chunk_indexes,
                       key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
        if any(b.message_start_time < a.message_end_time for a, b in pairwise(order)):
            return None
        return self._record_chunks(order)

    def _record_chunks(self, order: list[ChunkIndex]) -> Iterator[tuple[bytes, RecordColumns]]:
        import zstandard

        zstd = zstandard.ZstdDecompressor()
        group: list[tuple[bytes, ChunkIndex, bytes]] = []
        sources: list[ChunkIndex] = []
        size = 0

        def columns() -> tuple[bytes, RecordColumns]:
            bad: set[int] = set()

            def corrupt(k: int, reason: str) -> None:
                bad.add(k)
                self._note_corrupt(sources[k], reason)

            out = record_columns(group, corrupt)
            self._verified.update(ci.chunk_start_offset for k, ci in enumerate(sources)
                                  if k not in bad)
            return out

        with open(self.path, "rb") as f:
            for ci in order:
                try:
                    buf, local = chunk_window(f, ci)
                    records = verified_records(buf, local, zstd)
                except CorruptChunkError as exc:
                    self._note_corrupt(ci, exc.reason)
                    continue
                group.append((buf, local, records))
                sources.append(ci)
                size += len(records)
                if size >= RECORD_GROUP_BYTES:
                    yield columns()
                    group, sources, size = [], [], 0
        if group:
            yield columns()

    def channel_topic(self, channel_id: int) -> tuple[str, str]:
        """Topic and schema name of a channel id."""
        c = self._channels[channel_id]
        s = self._schemas.get(c.schema_id)
        return c.topic, s.name if s is not None else ""

    def raw_columns(self, topics: Iterable[str]) -> dict[str, tuple[NDArray[np.int64],
                                                                   list[bytes]]]:
        """Every message of ``topics``, undecoded, per topic: the log times (ns since the
        epoch) and the JSON bytes, in log-time order. Faster than :meth:`raw_messages` for
        whole topics: only their chunks are decompressed and their messages are found through
        the chunks' indexes. Topics without messages are left out."""
        import numpy as np

        wanted = set(topics)
        self.check_topics(wanted)
        by_topic: dict[str, list[int]] = {}
        for cid, c in self._channels.items():
            if c.topic in wanted:
                by_topic.setdefault(c.topic, []).append(cid)
        if not by_topic:
            return {}
        out: dict[str, tuple[NDArray[np.int64], list[bytes]]] = {}
        if self._salvaged is not None:
            acc: dict[str, tuple[list[int], list[bytes]]] = {t: ([], []) for t in by_topic}
            for m in self.raw_messages(by_topic):
                acc[m.topic][0].append(m.log_time_ns)
                acc[m.topic][1].append(m.data)
            return {t: (np.array(ts, dtype=np.int64), ds) for t, (ts, ds) in acc.items() if ts}
        with open(self.path, "rb") as f:
            per_channel = read_channels(f, self._chunk_indexes,
                                        [c for ids in by_topic.values() for c in ids],
                                        self._note_corrupt, self._verified)
        for topic, ids in by_topic.items():
            parts = [per_channel[c] for c in ids if len(per_channel[c][0])]
            if not parts:
                continue
            if len(parts) == 1:
                out[topic] = parts[0]
                continue
            t = np.concatenate([p[0] for p in parts])
            data = [d for p in parts for d in p[1]]
            order = np.argsort(t, kind="stable")
            out[topic] = (t[order], [data[i] for i in order.tolist()])
        return out

    def raw_column_chunks(self, topics: Iterable[str]) -> Iterator[
            dict[str, tuple[NDArray[np.int64], list[bytes]]]]:
        """The messages of ``topics``, undecoded, one chunk at a time (chunks in the order of
        their start times): per topic in the chunk, the log times (ns since the epoch) and the
        JSON bytes in stored order. Only one chunk is held at a time; for a salvaged file the
        whole of :meth:`raw_columns` comes as one block."""
        import numpy as np

        wanted = set(topics)
        self.check_topics(wanted)
        topic_of = {cid: c.topic for cid, c in self._channels.items() if c.topic in wanted}
        if not topic_of:
            return
        if self._salvaged is not None:
            yield self.raw_columns(wanted)
            return
        with open(self.path, "rb") as f:
            for found in iter_channel_chunks(f, self._chunk_indexes, topic_of,
                                             self._note_corrupt, self._verified):
                block: dict[str, tuple[NDArray[np.int64], list[bytes]]] = {}
                for cid, (t, d) in found.items():
                    topic = topic_of[cid]
                    if topic in block:
                        t0, d0 = block[topic]
                        block[topic] = (np.concatenate([t0, t.astype(np.int64)]), d0 + d)
                    else:
                        block[topic] = (t.astype(np.int64), d)
                yield block

    def verbatim_plan(self, skip_topics: frozenset[str] = frozenset()) -> tuple[
            dict[int, tuple[str, str, bytes]], dict[int, tuple[str, str, int]],
            list[ChunkIndex], dict[int, int]] | None:
        """What a writer needs to copy this log's chunks byte for byte: schemas and channels by
        id, chunk indexes and per-channel counts; None when that is not possible (salvaged
        file, no statistics, or a topic to skip)."""
        if not self.complete or (not self._counts and self._chunk_indexes):
            return None
        if any(c.topic in skip_topics for c in self._channels.values()):
            return None
        self.check_topics(None)
        if not self.verify_chunks():
            return None
        schemas = {sid: (s.name, s.encoding, s.data) for sid, s in self._schemas.items()}
        channels = {cid: (c.topic, c.message_encoding, c.schema_id)
                    for cid, c in self._channels.items()}
        return schemas, channels, list(self._chunk_indexes), dict(self._counts)

    def check_topics(self, topics: Iterable[str] | None = None) -> None:
        """Refuse a foreign schema or encoding on an lgvtool topic among ``topics`` (all the
        log's topics if None): each must carry the schema name the log contract gives it,
        JSON messages and a JSON schema.

        :raises LogFormatError: naming the topic, its schema and its encodings.
        """
        wanted = None if topics is None else set(topics)
        for c in self._channels.values():
            if c.topic in self._checked_topics or (wanted is not None and c.topic not in wanted):
                continue
            s = self._schemas.get(c.schema_id)
            problem = check_channel(c.topic, c.message_encoding, s.name if s else "",
                                    s.encoding if s else "")
            if problem:
                raise LogFormatError(f"{self.path}: {problem}")
            self._checked_topics.add(c.topic)

    def verify_chunks(self) -> bool:
        """Decompress and check every chunk (CRC-32, size, record framing); corrupt ones are
        counted in :attr:`corrupt_chunks` with a warning. True when none is corrupt."""
        if self._salvaged is not None:
            return not self.corrupt_chunks
        import zstandard

        from lgvtool.log.mcap_chunks import chunk_window, verified_records

        zstd = zstandard.ZstdDecompressor()
        with open(self.path, "rb") as f:
            for ci in self._chunk_indexes:
                if ci.chunk_start_offset in self._verified:
                    continue
                try:
                    buf, local = chunk_window(f, ci)
                    chunk_messages(verified_records(buf, local, zstd), set())
                except CorruptChunkError as exc:
                    self._note_corrupt(ci, exc.reason)
                else:
                    self._verified.add(ci.chunk_start_offset)
        return not self.corrupt_chunks

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[LogMessage]:
        """Every message (or those of ``topics``) in log-time order, decoded to dicts."""
        loads = orjson.loads
        for m in self.raw_messages(topics):
            yield LogMessage(m.topic, m.log_time_ns, loads(m.data))

    def topic_names(self) -> list[str]:
        """Topics that have a channel in the log, sorted."""
        return sorted({c.topic for c in self._channels.values()})

    def topics(self) -> dict[str, TopicInfo]:
        """Per topic: schema, count, first and last time, largest gap. Every chunk is checked
        (:meth:`verify_chunks`); the times come from the sound chunks' message indexes, or,
        without indexes, from reading every message."""
        if self._topic_info is None:
            schema_of = {c.topic: self._schemas[c.schema_id].name if c.schema_id in self._schemas
                         else "" for c in self._channels.values()}
            acc = self._indexed_topic_times()
            if acc is None:
                acc = self._read_topic_times()
            self._topic_info = {
                t: TopicInfo(schema_of.get(t, ""), a[0], a[1], a[2], a[3])
                for t, a in sorted(acc.items())
            }
        return self._topic_info

    def _indexed_topic_times(self) -> dict[str, list[int]] | None:
        """(count, first, last, largest gap) per topic from the message indexes of the sound
        chunks (a chunk without them read for its messages' times); None for a file held in
        memory (:meth:`_salvage_in_memory`) or one whose message indexes do not parse."""
        import numpy as np

        from lgvtool.log.mcap_chunks import indexed_times

        if self._salvaged is not None:
            return None
        self.verify_chunks()
        sound = [ci for ci in self._chunk_indexes if ci.chunk_start_offset in self._verified]
        # a chunk without message indexes (a cut-off log's last one may have lost them) is
        # read for its messages' times
        indexed: list[ChunkIndex] = []
        walked: list[ChunkIndex] = []
        for ci in sound:
            (walked if ci.uncompressed_size and not ci.message_index_offsets
             else indexed).append(ci)
        with open(self.path, "rb") as f:
            per_channel = indexed_times(f, indexed)
            if per_channel is None:
                return None
            more: dict[int, list[int]] = {}
            for block in iter_indexed_blocks(f, walked, None, self._note_corrupt):
                for log_time, cid, _pub, _data in block:
                    more.setdefault(cid, []).append(log_time)
        for cid, ts in more.items():
            joined = np.concatenate([per_channel.get(cid, np.zeros(0, np.int64)),
                                     np.array(ts, dtype=np.int64)])
            joined.sort(kind="stable")
            per_channel[cid] = joined
        by_topic: dict[str, list[NDArray[np.int64]]] = {}
        for cid, t in per_channel.items():
            c = self._channels.get(cid)
            if c is not None and len(t):
                by_topic.setdefault(c.topic, []).append(t)
        acc: dict[str, list[int]] = {}
        for topic, parts in by_topic.items():
            t = np.sort(np.concatenate(parts), kind="stable") if len(parts) > 1 else parts[0]
            gap = int(np.diff(t).max()) if len(t) > 1 else 0
            acc[topic] = [len(t), int(t[0]), int(t[-1]), max(gap, 0)]
        return acc

    def _read_topic_times(self) -> dict[str, list[int]]:
        """(count, first, last, largest gap) per topic, reading every message."""
        acc: dict[str, list[int]] = {}
        for m in self._raw_messages(None):
            a = acc.get(m.topic)
            if a is None:
                acc[m.topic] = [1, m.log_time_ns, m.log_time_ns, 0]
            else:
                gap = m.log_time_ns - a[2]
                a[0] += 1
                a[2] = m.log_time_ns
                if gap > a[3]:
                    a[3] = gap
        return acc

    def has_topic(self, topic: str) -> bool:
        """Whether the log has a channel for ``topic`` (it may hold no messages)."""
        return any(c.topic == topic for c in self._channels.values())

    def schema_of(self, topic: str) -> str:
        """The schema name of ``topic``'s channel (else the log contract's for it, else "")."""
        return next((self._schemas[c.schema_id].name for c in self._channels.values()
                     if c.topic == topic and c.schema_id in self._schemas),
                    T.schema_for_topic(topic) or "")

    def dataframe(self, topic: str) -> pd.DataFrame:
        """One table of ``topic`` with SI-unit columns; ``t`` is the log time in s."""
        return self.dataframes([topic])[topic]

    def dataframes(self, topics: Iterable[str], tap: Tap | None = None
                   ) -> dict[str, pd.DataFrame]:
        """:meth:`dataframe` of each of ``topics``, read in one pass over the chunks, in which
        ``tap`` is handed each chunk's messages of its own topics too: a log that holds many
        topics in every chunk (one written by ``replay``) is decompressed once, not once per
        topic (:class:`lgvtool.log.frames.TopicTables`)."""
        from lgvtool.log.frames import TopicTables

        tables = TopicTables(self, topics)
        for block in self.raw_column_chunks([*tables.topics, *(tap.topics if tap else ())]):
            tables.add(block)
            if tap is not None:
                tap.add(block)
        return tables.tables()

    # ------------------------------------------------------------------ run facts
    def config(self) -> Config:
        """The configuration stored in the log (record 'config'), else the defaults with the
        log's reflector map."""
        stored = self.metadata.get("config")
        if stored:
            try:
                cfg = config_from_dict(stored)
            except ConfigError as exc:
                raise LogFormatError(f"{self.path}: stored configuration is invalid: {exc}") from None
        else:
            cfg = default_config()
        refl = self._map_from_topic()
        if refl:
            from dataclasses import replace

            cfg = replace(cfg, reflectors=refl)
        return cfg

    def _map_from_topic(self) -> tuple[Reflector, ...]:
        from lgvtool.log.messages import reflectors_from_message

        for m in self.messages([T.MAP]):
            try:
                return reflectors_from_message(m.data)
            except ValueError as exc:
                raise LogFormatError(f"{self.path}: {exc}") from None
        return ()

    def reflector_map(self) -> tuple[Reflector, ...]:
        """The reflector map: /map/reflectors if logged, else the stored configuration's."""
        return self._map_from_topic() or self.config().reflectors


def _chunk_records(records: Iterable[Any], on_corrupt: Any, f: Any) -> Iterator[Any]:
    """The records of a stream read with ``emit_chunks``, with each chunk checked
    (:func:`checked_records`) and opened into its records; a corrupt chunk goes to
    ``on_corrupt(offset, reason)`` and is left out."""
    from mcap.records import Chunk
    from mcap.stream_reader import breakup_chunk

    for rec in records:
        if not isinstance(rec, Chunk):
            yield rec
            continue
        try:
            chunk_messages(checked_records(rec.compression, rec.data, rec.uncompressed_size,
                                           rec.uncompressed_crc), set())
            inner = breakup_chunk(rec)
        except CorruptChunkError as exc:
            on_corrupt(f.tell(), exc.reason)
            continue
        except Exception as exc:  # a record inside that does not parse
            on_corrupt(f.tell(), f"a record inside does not parse ({type(exc).__name__})")
            continue
        yield from inner
        yield rec


def _decode_value(value: str) -> Any:
    try:
        return json.loads(value)
    except (json.JSONDecodeError, ValueError):
        return value
