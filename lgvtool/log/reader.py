"""Read lgvtool logs: typed messages in log-time order, metadata, per-topic DataFrames.

The reader reads one source (:mod:`lgvtool.log.sources`): the file through its summary section
when it has a usable one, else what a walk of the file finds still whole. A log that was cut
off mid-write (crash, power loss, full disk) has no summary or footer: the walk
(:mod:`lgvtool.log.mcap_scan`) goes once up to the cut, finds every complete chunk (and any
messages written outside chunks), and the reader reads them a chunk at a time as it reads a
complete log's, and says so in :attr:`LogReader.warnings`; :attr:`LogReader.complete` is False.
Every reading method is written once, against the source's questions. Times in ns since the
Unix epoch unless a name says otherwise, sizes and offsets in bytes.
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
from lgvtool.json_types import JSON
from lgvtool.log import topics as T
from lgvtool.log.mcap_chunks import (
    ChunkWindow,
    CorruptChunkError,
    RecordColumns,
    chunk_messages,
    indexed_times,
    iter_channel_chunks,
    iter_indexed,
    iter_indexed_blocks,
    read_channels,
    record_columns,
)
from lgvtool.log.mcap_records import (
    Channel,
    ChunkIndex,
    Schema,
    starts_with_magic,
)
from lgvtool.log.sources import LogSource, open_source
from lgvtool.log.validate import check_channel
from lgvtool.log.writer import FORMAT_VERSION

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd
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
        self.size = size  #: the file's size, bytes
        self.warnings: list[str] = []
        #: file offset -> reason of every chunk found corrupt and skipped so far
        self.corrupt_chunks: dict[int, str] = {}
        self._checked_topics: set[str] = set()
        self._source: LogSource = open_source(self.path, size, self._note_corrupt,
                                              self.warnings.append)
        #: whether the file was read through its summary (else salvaged)
        self.complete = self._source.complete
        #: bytes from the start of the file that were read (its size when complete)
        self.salvaged_bytes = self._source.salvaged_bytes
        self._schemas: dict[int, Schema] = self._source.schemas
        self._channels: dict[int, Channel] = self._source.channels
        self._verified: set[int] = set(self._source.sound)  # offsets of chunks found sound
        self.metadata: dict[str, dict[str, Any]] = {}
        for rec in self._source.metadata:
            self.metadata[rec.name] = {k: _decode_value(v) for k, v in rec.metadata.items()}
        self._check_contract()
        self._topic_info: dict[str, TopicInfo] | None = None
        for w in self.warnings:
            _warnings.warn(w, LogWarning, stacklevel=2)

    @property
    def _chunk_indexes(self) -> list[ChunkIndex]:
        """The chunks the source reads (for tests and benchmarks that look at them)."""
        return self._source.chunk_indexes

    # ------------------------------------------------------------------ opening
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
    def _channel_ids(self, wanted: set[str] | None) -> set[int] | None:
        """The ids of the channels of the ``wanted`` topics; for every topic (``wanted`` None),
        None (every message) unless messages in the chunks name a channel the log does not
        define: then the ids of the defined ones (the others' messages cannot be read)."""
        if wanted is None and not self._source.unknown_channels:
            return None
        return {cid for cid, c in self._channels.items() if wanted is None or c.topic in wanted}

    def raw_messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Every stored message (or those of ``topics``) in log-time order, undecoded."""
        wanted = None if topics is None else set(topics)
        self.check_topics(wanted)
        yield from self._raw_messages(wanted)

    def _raw_messages(self, wanted: set[str] | None) -> Iterator[RawMessage]:
        ids = self._channel_ids(wanted)
        if ids is not None and not ids:
            return
        schemas = {sid: s.name for sid, s in self._schemas.items()}
        topic_of = {cid: (c.topic, schemas.get(c.schema_id, "")) for cid, c in self._channels.items()}
        with self._source.reading() as log:
            for log_time, cid, pub, data in iter_indexed(log.load, self._chunk_indexes, ids,
                                                         self._note_corrupt, self._verified):
                topic, schema = topic_of[cid]
                yield RawMessage(topic, schema, log_time, pub, data)

    def raw_blocks(self) -> Iterator[list[tuple[int, int, int, bytes]]]:
        """Every stored message in log-time order, undecoded, in blocks (about a chunk's):
        ``(log time ns, channel id, publish time ns, data)``; :meth:`channel_topic` names a
        channel id. The same messages in the same order as :meth:`raw_messages`."""
        self.check_topics(None)
        ids = self._channel_ids(None)
        if ids is not None and not ids:
            return
        with self._source.reading() as log:
            yield from iter_indexed_blocks(log.load, self._chunk_indexes, ids, self._note_corrupt,
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
        chunks' (chunks whose times overlap) or the chunks hold messages :meth:`raw_blocks`
        leaves out (on channels the log does not define)."""
        self.check_topics(None)
        if self._source.unknown_channels:
            return None
        order = sorted(self._chunk_indexes,
                       key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
        if any(b.message_start_time < a.message_end_time for a, b in pairwise(order)):
            return None
        return self._record_chunks(order)

    def _record_chunks(self, order: list[ChunkIndex]) -> Iterator[tuple[bytes, RecordColumns]]:
        group: list[ChunkWindow] = []
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

        with self._source.reading() as log:
            for ci in order:
                try:
                    window = log.load(ci)
                except CorruptChunkError as exc:
                    self._note_corrupt(ci, exc.reason)
                    continue
                group.append(window)
                sources.append(ci)
                size += len(window.records)
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

    def _topic_channels(self, topics: Iterable[str]) -> dict[str, list[int]]:
        """The ids of the channels of each of ``topics`` (checked, :meth:`check_topics`) that
        the log has."""
        wanted = set(topics)
        self.check_topics(wanted)
        by_topic: dict[str, list[int]] = {}
        for cid, c in self._channels.items():
            if c.topic in wanted:
                by_topic.setdefault(c.topic, []).append(cid)
        return by_topic

    def raw_columns(self, topics: Iterable[str]) -> dict[str, tuple[NDArray[np.int64],
                                                                   list[bytes]]]:
        """Every message of ``topics``, undecoded, per topic: the log times (ns since the
        epoch) and the JSON bytes, in log-time order. Faster than :meth:`raw_messages` for
        whole topics: only their chunks are decompressed and their messages are found through
        the chunks' indexes. Topics without messages are left out."""
        import numpy as np

        by_topic = self._topic_channels(topics)
        if not by_topic:
            return {}
        with self._source.reading() as log:
            per_channel = read_channels(log.load, self._chunk_indexes,
                                        [c for ids in by_topic.values() for c in ids],
                                        self._note_corrupt, self._verified)
        out: dict[str, tuple[NDArray[np.int64], list[bytes]]] = {}
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
        JSON bytes in stored order. Only one chunk is held at a time."""
        import numpy as np

        topic_of = {cid: t for t, ids in self._topic_channels(topics).items() for cid in ids}
        if not topic_of:
            return
        with self._source.reading() as log:
            for found in iter_channel_chunks(log.load, self._chunk_indexes, topic_of,
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
        file, no statistics, a corrupt chunk, or a topic to skip)."""
        counts = self._source.copy_counts()
        if counts is None:
            return None
        if any(c.topic in skip_topics for c in self._channels.values()):
            return None
        self.check_topics(None)
        if not self.verify_chunks():
            return None
        schemas = {sid: (s.name, s.encoding, s.data) for sid, s in self._schemas.items()}
        channels = {cid: (c.topic, c.message_encoding, c.schema_id)
                    for cid, c in self._channels.items()}
        return schemas, channels, list(self._chunk_indexes), counts

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
        """Decompress and check every chunk (CRC-32, size, record framing) not checked yet;
        corrupt ones are counted in :attr:`corrupt_chunks` with a warning. True when none is
        corrupt."""
        with self._source.reading() as log:
            for ci in self._chunk_indexes:
                if ci.chunk_start_offset in self._verified:
                    continue
                try:
                    chunk_messages(log.load(ci).records, set())
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
        """(count, first ns, last ns, largest gap ns) per topic from the message indexes of
        the sound chunks (a chunk without them read for its messages' times); None when the
        message indexes do not parse."""
        import numpy as np

        self.verify_chunks()
        sound = [ci for ci in self._chunk_indexes if ci.chunk_start_offset in self._verified]
        # a chunk without message indexes (a cut-off log's last one may have lost them, and
        # a salvaged run of messages outside chunks has none) is read for its messages' times
        indexed: list[ChunkIndex] = []
        walked: list[ChunkIndex] = []
        for ci in sound:
            (walked if ci.uncompressed_size and not ci.message_index_offsets
             else indexed).append(ci)
        with self._source.reading() as log:
            per_channel = indexed_times(log.file, indexed)
            if per_channel is None:
                return None
            more: dict[int, list[int]] = {}
            for block in iter_indexed_blocks(log.load, walked, None, self._note_corrupt):
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
        """(count, first ns, last ns, largest gap ns) per topic, reading every message."""
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


def _decode_value(value: str) -> JSON:
    try:
        decoded: JSON = json.loads(value)
        return decoded
    except (json.JSONDecodeError, ValueError):
        return value
