"""Where a :class:`~lgvtool.log.reader.LogReader` reads a log's messages from: one source object.

A log is read through its summary section when it has a usable one (:class:`IndexedSource`:
the chunk indexes, schemas, channels, statistics and metadata records the summary points at),
else salvaged (:class:`SalvagedSource`: one walk of the file up to where it stops being whole,
:func:`lgvtool.log.mcap_scan.scan_records`, which finds the chunks it still holds, checks them,
and gathers the messages written outside chunks into runs read like chunks). Both answer the
questions of :class:`LogSource`, so that the reader reads every chunk the same way whichever
it has, as rosbags puts each storage format of a bag behind one storage protocol.
:func:`open_source` picks the source of a file. Offsets and sizes in bytes, times in ns.
"""

from __future__ import annotations

import mmap
import struct
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from functools import cached_property
from pathlib import Path
from typing import IO, NamedTuple, Protocol

import zstandard

from lgvtool.log.mcap_chunks import (
    ChunkWindow,
    CorruptChunkError,
    LoadChunk,
    chunk_messages,
    load_chunk,
)
from lgvtool.log.mcap_records import (
    MAGIC,
    Channel,
    ChunkIndex,
    CorruptSummaryError,
    Metadata,
    Schema,
    Summary,
    data_section_crc,
    read_metadata,
    read_summary,
)
from lgvtool.log.mcap_scan import scan_records

__all__ = ["IndexedSource", "LogSource", "OpenLog", "SalvagedSource", "open_source"]

#: called with the file offset of a chunk found corrupt and the reason, one phrase
OnCorrupt = Callable[[int, str], None]
#: called with a sentence about the file a reader should pass on as a warning
Say = Callable[[str], None]

_UNREADABLE_SUMMARY = (OSError, ValueError, IndexError, struct.error)
"""What reading a summary section that is damaged (past what its CRC-32 catches: a CRC of 0,
or offsets in the footer or the summary that point nowhere) raises: a seek beyond what an
offset can be (OSError, ValueError), a field that runs past the bytes read (struct.error,
IndexError), a string that is not UTF-8 (UnicodeDecodeError, a ValueError). The file is then
salvaged as one without a summary is."""


class OpenLog(NamedTuple):
    """A source's file open for reading: the file, and how one of its chunks is read."""

    file: IO[bytes]
    load: LoadChunk


class LogSource(Protocol):
    """What a reader asks of the file it reads: the registrations, the metadata records and
    the chunks (their indexes, and how one is read and checked). Both sources answer each
    question, so that every reading method is written once."""

    @property
    def complete(self) -> bool:
        """Whether the file was read through its summary (it is whole)."""
        ...

    @property
    def salvaged_bytes(self) -> int:
        """Bytes from the file's start that were read (the file's size when complete)."""
        ...

    @property
    def schemas(self) -> dict[int, Schema]:
        """The schemas by id."""
        ...

    @property
    def channels(self) -> dict[int, Channel]:
        """The channels by id."""
        ...

    @property
    def metadata(self) -> list[Metadata]:
        """The metadata records, in file order."""
        ...

    @property
    def chunk_indexes(self) -> list[ChunkIndex]:
        """Every chunk to read (those still whole, for a salvaged file), with their message
        indexes where the file has them."""
        ...

    @property
    def sound(self) -> frozenset[int]:
        """File offsets of the chunks already checked (CRC-32, size, framing) when the file
        was opened."""
        ...

    @property
    def unknown_channels(self) -> bool:
        """Whether messages of the chunks name a channel the file does not define (they
        cannot be read; a corrupt chunk held the definition)."""
        ...

    def copy_counts(self) -> dict[int, int] | None:
        """Messages per channel id of a copy of the chunks as they are stored (the file's
        statistics); None when the chunks cannot be copied so (no statistics, or not every
        entry of :attr:`chunk_indexes` is a chunk record of a whole file)."""
        ...

    def reading(self) -> AbstractContextManager[OpenLog]:
        """The file opened for reading chunks, until the context ends."""
        ...


class IndexedSource:
    """A file read through its summary section: its chunk indexes (with message indexes),
    schemas, channels, statistics and metadata records.

    :param path: the file.
    :param size: its size, bytes.
    :param summary: its summary section.
    :param metadata: its metadata records.
    """

    complete = True
    sound: frozenset[int] = frozenset()

    def __init__(self, path: Path, size: int, summary: Summary, metadata: list[Metadata]
                 ) -> None:
        self.path = path
        self.salvaged_bytes = size
        self.schemas = summary.schemas
        self.channels = summary.channels
        self.metadata = metadata
        self.chunk_indexes = summary.chunk_indexes
        self._counts = summary.channel_message_counts

    @cached_property
    def unknown_channels(self) -> bool:
        """See :attr:`LogSource.unknown_channels`: from the channels the chunks' message
        indexes name (asked when first needed: opening a file does not pay for it)."""
        indexed: set[int] = set().union(*[ci.message_index_offsets for ci in self.chunk_indexes])
        return not indexed <= self.channels.keys()

    @classmethod
    def open(cls, path: Path, size: int, say: Say) -> IndexedSource | None:
        """The file at ``path`` (``size`` bytes) read through its summary section; None when
        it has none, or one that cannot be trusted (``say`` is told when it fails its CRC-32)
        or read. A data section that fails its CRC-32 is said too (the chunks' own CRCs tell
        which messages are affected)."""
        try:
            with open(path, "rb") as f:
                try:
                    summary = read_summary(f)
                except CorruptSummaryError as exc:
                    say(f"{path}: {exc}; reading the file record by record instead of through "
                        "its index")
                    return None
                if summary is None:
                    return None
                if not _data_section_sound(f):
                    say(f"{path}: the data section does not match its CRC-32")
                metadata = [read_metadata(f, i) for i in summary.metadata_indexes]
        except _UNREADABLE_SUMMARY:
            return None
        return cls(path, size, summary, metadata)

    def copy_counts(self) -> dict[int, int] | None:
        """See :meth:`LogSource.copy_counts`."""
        if not self._counts and self.chunk_indexes:
            return None
        return dict(self._counts or {})

    @contextmanager
    def reading(self) -> Iterator[OpenLog]:
        """See :meth:`LogSource.reading`."""
        zstd = zstandard.ZstdDecompressor()
        with open(self.path, "rb") as f:
            yield OpenLog(f, lambda ci: load_chunk(f, ci, zstd))


def _data_section_sound(f: IO[bytes]) -> bool:
    """Whether the data section of the indexed file ``f`` matches the CRC-32 its data end
    record gives (True without one, or when the file cannot be mapped).

    :raises IndexError: the footer points outside the file.
    """
    f.seek(-(9 + 20 + len(MAGIC)), 2)
    (summary_start,) = struct.unpack_from("<Q", f.read(17), 9)
    try:
        buf = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    except (OSError, ValueError):  # not a regular file (a pipe), or one that cannot be mapped
        return True
    try:
        crcs = data_section_crc(buf, summary_start)
    finally:
        buf.close()
    return crcs is None or crcs[0] == crcs[1]


class SalvagedSource:
    """A file without a usable summary, read as far as it is whole: the chunks one walk of it
    found sound (:func:`lgvtool.log.mcap_scan.scan_records`, each chunk checked) and its runs
    of message records outside chunks, read from the file one at a time as chunks are.

    :param path: the file.
    :param size: its size, bytes.
    :param on_corrupt: told of each chunk the walk finds corrupt (its offset and the reason).
    :param say: told how much was salvaged, in one sentence.
    """

    complete = False

    def __init__(self, path: Path, size: int, on_corrupt: OnCorrupt, say: Say) -> None:
        self.path = path
        with open(path, "rb") as f:
            scan = scan_records(f, size, on_corrupt)
        self.schemas = scan.schemas
        self.channels = scan.channels
        self.metadata = scan.metadata
        self.chunk_indexes = scan.chunk_indexes
        self.sound = frozenset(ci.chunk_start_offset for ci in scan.chunk_indexes)
        self.unknown_channels = scan.unknown_channels()
        self.salvaged_bytes = scan.good_end
        self._loose = scan.loose
        messages = sum(n for cid, n in scan.counts.items() if cid in self.channels)
        last_ns = self._latest() if self.unknown_channels else scan.last_time
        where = f", last message at {last_ns / 1e9:.3f} s" if last_ns is not None else ""
        say(f"{path}: incomplete log (no summary; cut off after {scan.good_end} of {size} "
            f"bytes): salvaged {messages} complete messages{where}")

    def _latest(self) -> int | None:
        """The latest log time (ns) of the messages on the channels the file defines (None:
        none), read from the chunks: the walk gives that of every message, and a file whose
        channel definitions were lost (in a corrupt chunk) holds messages that cannot be
        read."""
        known = set(self.channels)
        latest: int | None = None
        with self.reading() as log:
            for ci in self.chunk_indexes:
                try:
                    times = [m[0] for m in chunk_messages(log.load(ci).records, known)]
                except CorruptChunkError:  # checked by the walk: only if the file changed since
                    continue
                if times and (latest is None or max(times) > latest):
                    latest = max(times)
        return latest

    def copy_counts(self) -> dict[int, int] | None:
        """See :meth:`LogSource.copy_counts`: None, the file has no statistics."""
        return None

    @contextmanager
    def reading(self) -> Iterator[OpenLog]:
        """See :meth:`LogSource.reading`."""
        zstd = zstandard.ZstdDecompressor()
        loose = self._loose

        with open(self.path, "rb") as f:
            def load(ci: ChunkIndex) -> ChunkWindow:
                length = loose.get(ci.chunk_start_offset)
                return load_chunk(f, ci, zstd) if length is None else _loose_run(f, ci, length)

            yield OpenLog(f, load)


def _loose_run(f: IO[bytes], ci: ChunkIndex, length: int) -> ChunkWindow:
    """The run of ``length`` bytes of message records outside chunks that ``ci`` describes, as
    a chunk's records (the walk checked their framing).

    :raises CorruptChunkError: the file no longer holds them.
    """
    f.seek(ci.chunk_start_offset)
    records = f.read(length)
    if len(records) != length:
        raise CorruptChunkError(ci.chunk_start_offset, "the file ends inside its records")
    local = ChunkIndex(ci.message_start_time, ci.message_end_time, 0, length, {}, 0, "",
                       length, length)
    return ChunkWindow(records, local, records)


def open_source(path: Path, size: int, on_corrupt: OnCorrupt, say: Say) -> LogSource:
    """The source of the MCAP file at ``path`` (``size`` bytes, its magic checked): through its
    summary when it has a usable one, else salvaged. ``say`` is told what a reader should warn
    of (a summary or data section that fails its CRC-32, how much was salvaged), in order,
    and ``on_corrupt`` of each corrupt chunk the salvage's walk finds, in between."""
    indexed = IndexedSource.open(path, size, say)
    if indexed is not None:
        return indexed
    return SalvagedSource(path, size, on_corrupt, say)
