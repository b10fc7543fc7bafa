"""The scanning engine shared by the incremental stream decoders.

A subclass says where a frame may start and judges the candidate at a position; this base class
does the buffering, resynchronisation and bookkeeping. After a bad candidate, scanning restarts
at the byte after the candidate's start (never after its claimed end), so a good frame that a
corrupted or truncated one overlaps is still found. ``feed()`` never raises for any input bytes.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from lgvtool.json_types import JSON
from lgvtool.wire.decode_events import WARNING, DecodeEvent, DecoderStats

T = TypeVar("T")

#: Events kept until :meth:`StreamDecoder.pop_events`; beyond this, new events are dropped
#: (the counters in ``stats`` stay exact).
MAX_PENDING_EVENTS = 10_000


@dataclass(frozen=True)
class Wait:
    """The candidate is incomplete; ``claimed`` is the size it announces (bytes), if known."""

    claimed: int | None = None


@dataclass(frozen=True)
class Reject:
    """Not a frame: skip one byte. ``kind`` is the stats counter to increment (None: garbage)."""

    kind: str | None
    message: str = ""


@dataclass(frozen=True)
class SkipFrame:
    """An intact frame that is not delivered (e.g. unknown version): skip ``size`` bytes."""

    kind: str
    size: int
    message: str = ""


@dataclass(frozen=True)
class Accept(Generic[T]):
    """A good frame of ``size`` bytes."""

    frame: T
    size: int


Verdict = Wait | Reject | SkipFrame | Accept[Any]


class StreamDecoder(ABC, Generic[T]):
    """Incremental decoder: ``feed(chunk)`` returns the frames completed by ``chunk``.

    Attributes:
        source: name used in events (``"mcu"``, ``"nav200"``).
        stats: :class:`DecoderStats` counters since creation.
    """

    source: str = "wire"

    def __init__(self) -> None:
        self.stats = DecoderStats()
        self._buf = bytearray()
        self._offset = 0  # stream offset of _buf[0], bytes
        self._events: list[DecodeEvent] = []
        self._skip_run = 0
        self._skip_run_start = 0
        self._truncated_end = -1

    @property
    def pending_bytes(self) -> int:
        """Bytes held back waiting for the rest of a possible frame."""
        return len(self._buf)

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[T]:
        """Add received bytes; return the frames they complete, in stream order."""
        data = bytes(chunk)
        self.stats.bytes_received += len(data)
        self._buf += data
        return self._scan(final=False)

    def flush(self) -> list[T]:
        """End of stream: decode what can be, count an incomplete frame as truncated, reset."""
        frames = self._scan(final=True)
        self._end_skip_run()
        return frames

    def pop_events(self) -> list[DecodeEvent]:
        """The events since the last call (errors, resynchronisations, gaps), oldest first."""
        events, self._events = self._events, []
        return events

    def _event(
        self, kind: str, message: str, *, level: int = WARNING, count: int = 1, **details: JSON
    ) -> None:
        if len(self._events) < MAX_PENDING_EVENTS:
            self._events.append(DecodeEvent(self.source, kind, message, level, count, details))

    @abstractmethod
    def _find_start(self, buf: bytearray, pos: int) -> int:
        """Index >= pos of the next possible frame start, or -1 when there is none."""

    def _keep_back(self, buf: bytearray) -> int:
        """Trailing bytes (with no start found) that may begin a start marker; kept for later."""
        return 0

    @abstractmethod
    def _examine(self, buf: bytearray, pos: int) -> Verdict:
        """Judge the candidate starting at ``buf[pos]``."""

    def _complete_at(self, buf: bytearray, pos: int) -> bool:
        """True when a complete frame that checks starts at ``buf[pos]`` (only bytes already
        received are looked at); used by :meth:`_overlaps_frame`."""
        return False

    def _overlaps_frame(self, buf: bytearray, pos: int, size: int) -> bool:
        """True when a complete frame that checks starts inside the ``size``-byte candidate at
        ``pos``: the candidate is then taken for a spurious or cut-off one and rejected, so
        that the frame inside it is found (resumption at the byte after the candidate's
        start). Only bytes already received are looked at, so no frame is held back waiting.
        """
        end = pos + size
        inner = self._find_start(buf, pos + 1)
        while 0 <= inner < end:
            if self._complete_at(buf, inner):
                return True
            inner = self._find_start(buf, inner + 1)
        return False

    def _delivered(self, frame: T, offset: int) -> None:
        """Hook called for each delivered frame (e.g. sequence tracking)."""

    def _skip(self, n: int, at: int) -> None:
        if n <= 0:
            return
        if self._skip_run == 0:
            self._skip_run_start = at
        self._skip_run += n
        self.stats.bytes_skipped += n

    def _end_skip_run(self) -> None:
        if self._skip_run:
            self._event(
                "bytes_skipped",
                f"{self._skip_run} bytes skipped",
                count=1,
                offset_bytes=self._skip_run_start,
                skipped_bytes=self._skip_run,
            )
            self._skip_run = 0

    def _scan(self, *, final: bool) -> list[T]:
        buf = self._buf
        out: list[T] = []
        pos = 0
        while pos < len(buf):
            start = self._find_start(buf, pos)
            if start < 0:
                end = len(buf) if final else max(pos, len(buf) - self._keep_back(buf))
                self._skip(end - pos, self._offset + pos)
                pos = end
                break
            self._skip(start - pos, self._offset + pos)
            pos = start
            verdict = self._examine(buf, pos)
            at = self._offset + pos
            if isinstance(verdict, Wait):
                if not final:
                    break
                if at >= self._truncated_end:
                    claimed = verdict.claimed or (len(buf) - pos)
                    self._truncated_end = at + claimed
                    self.stats.truncated += 1
                    self._event(
                        "truncated",
                        "incomplete frame at end of stream",
                        offset_bytes=at,
                        received_bytes=len(buf) - pos,
                        claimed_bytes=claimed,
                    )
                self._skip(1, at)
                pos += 1
            elif isinstance(verdict, Reject):
                if verdict.kind is not None:
                    setattr(self.stats, verdict.kind, getattr(self.stats, verdict.kind) + 1)
                    self._event(verdict.kind, verdict.message, offset_bytes=at)
                self._skip(1, at)
                pos += 1
            elif isinstance(verdict, SkipFrame):
                setattr(self.stats, verdict.kind, getattr(self.stats, verdict.kind) + 1)
                self._event(verdict.kind, verdict.message, offset_bytes=at)
                self._skip(verdict.size, at)
                pos += verdict.size
            else:
                self._end_skip_run()
                self.stats.frames += 1
                self.stats.bytes_decoded += verdict.size
                out.append(verdict.frame)
                self._delivered(verdict.frame, at)
                pos += verdict.size
        del buf[:pos]
        self._offset += pos
        return out
