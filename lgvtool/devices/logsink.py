"""The recorder's single log writer: one thread owns the LogWriter and is fed through a queue.

Device threads never touch the file: they hand raw bytes, decoded messages and diagnostics to
:class:`LogSink`, whose thread writes them, closes a chunk at least once a second (so a crash
loses at most about a second), splits long shifts into time-named files, and stops cleanly
with a clear message when the disk is full.
"""

from __future__ import annotations

import contextlib
import errno
import os
import queue
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from lgvtool.config import Config, Reflector
from lgvtool.json_types import JSONObject, JSONRecord
from lgvtool.log import topics
from lgvtool.log.writer import LogWriter
from lgvtool.wire.decode_events import WARNING, DecodeEvent

if TYPE_CHECKING:
    from lgvtool.live.tap import LogTap

__all__ = ["LogSink", "SinkFailure", "split_name"]

#: errno values that mean "no more room for the file".
_FULL = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}
_STOP = object()
#: what the writer thread is handed: raw bytes, a decoded message, a diagnostic, a metadata
#: record or the reflector map (times in ns since the Unix epoch)
_Item = (tuple[Literal["raw"], str, str, bytes, int]
         | tuple[Literal["msg"], str, Mapping[str, object], int]
         | tuple[Literal["diag"], str, str, str, int, int, int, JSONObject]
         | tuple[Literal["meta"], str, dict[str, object]]
         | tuple[Literal["map"], tuple[Reflector, ...], int])
#: How often the writer thread looks at the split limits and the chunk age, s.
_TICK = 0.2


@dataclass(frozen=True)
class SinkFailure:
    """Why the sink stopped writing: ``disk_full`` for ENOSPC/EDQUOT/EFBIG, the file concerned,
    and the OS message."""

    disk_full: bool
    path: Path | None
    message: str


def split_name(output: Path, start: datetime, taken: set[Path] | None = None) -> Path:
    """``OUT-YYYYmmddTHHMMSSZ.mcap`` beside ``output`` for a file started at ``start`` (UTC);
    ``-2``, ``-3``, ... appended when that name exists or is in ``taken``."""
    stamp = start.astimezone(UTC).strftime("%Y%m%dT%H%M%SZ")
    suffix = output.suffix or ".mcap"
    base = output.with_name(f"{output.stem}-{stamp}")
    candidate = base.with_suffix(suffix)
    n = 2
    while candidate.exists() or (taken is not None and candidate in taken):
        candidate = base.with_name(f"{base.name}-{n}").with_suffix(suffix)
        n += 1
    return candidate


class LogSink:
    """A writer thread that owns the log file(s).

    :param output: the log to write; with splitting, the base of the time-named files.
    :param split_bytes: start a new file once the current one holds this many bytes.
    :param split_seconds: start a new file once the current one spans this many seconds.
    :param config: configuration stored in every file (metadata 'config').
    :param command: command line stored in every file.
    :param chunk_seconds: LogWriter chunk span, s (crash loss bound).
    :param fsync: fsync every chunk (power loss).
    :param tap: also hand every message written to this (``lgvtool.live.tap.LogTap``).
    """

    def __init__(self, output: Path, *, split_bytes: int | None = None,
                 split_seconds: float | None = None, config: Config | None = None,
                 command: str | None = None, chunk_seconds: float = 0.5,
                 fsync: bool = True, tap: LogTap | None = None) -> None:
        self.output = Path(output)
        self.split_bytes = split_bytes
        self.split_seconds = split_seconds
        self.splitting = split_bytes is not None or split_seconds is not None
        self._config = config
        self._command = command
        self._chunk_seconds = chunk_seconds
        self._fsync = fsync
        self._tap = tap
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._thread = threading.Thread(target=self._run, name="log-writer", daemon=True)
        self._sticky_meta: dict[str, dict[str, object]] = {}
        self._sticky_map: tuple[Reflector, ...] | None = None
        self._writer: LogWriter | None = None
        self._path: Path | None = None
        self._opened_wall = 0.0
        self._closed_bytes = 0
        #: every file written so far, in order
        self.files: list[Path] = []
        #: messages written per topic (all files)
        self.counts: dict[str, int] = {}
        #: diagnostics of level warning or worse written (all files)
        self.errors = 0
        #: set (with the reason) when writing failed; the thread then drops what it gets
        self.failure: SinkFailure | None = None
        self.failed = threading.Event()

    # ------------------------------------------------------------------ producer side
    def start(self) -> None:
        """Open the first file (in the caller's thread, so a bad path fails at once) and
        start the writer thread."""
        self._open_file()
        self._thread.start()

    def raw(self, device: str, direction: str, data: bytes, t_ns: int) -> None:
        """Raw bytes received from (rx) or sent to (tx) ``device`` at host time ``t_ns``."""
        self._queue.put(("raw", device, direction, bytes(data), t_ns))

    def message(self, topic: str, message: Mapping[str, object], t_ns: int) -> None:
        """A decoded message dict for ``topic`` at host time ``t_ns``."""
        self._queue.put(("msg", topic, message, t_ns))

    def diagnostic(self, source: str, kind: str, message: str, t_ns: int, *,
                   level: int = WARNING, count: int = 1,
                   details: JSONRecord | None = None) -> None:
        """A structured event on /diagnostics."""
        self._queue.put(("diag", source, kind, message, t_ns, level, count, dict(details or {})))

    def event(self, event: DecodeEvent, t_ns: int) -> None:
        """A decoder or session event as a diagnostic."""
        self.diagnostic(event.source, event.kind, event.message, t_ns, level=event.level,
                        count=event.count, details=event.details)

    def set_metadata(self, name: str, data: Mapping[str, object]) -> None:
        """A metadata record, written now and again at the start of every later split file."""
        self._queue.put(("meta", name, dict(data)))

    def set_map(self, reflectors: Iterable[Reflector], t_ns: int) -> None:
        """The reflector map, written now and again at the start of every later split file."""
        self._queue.put(("map", tuple(reflectors), t_ns))

    def close(self, timeout: float = 5.0) -> None:
        """Write what is queued, finish the file (summary, indexes), stop the thread."""
        if self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join(timeout)

    # ------------------------------------------------------------------ state
    def bytes_written(self) -> int:
        """Bytes on disk in every file so far (the chunk in progress not included)."""
        current = 0
        if self._path is not None:
            with contextlib.suppress(OSError):
                current = self._path.stat().st_size
        return self._closed_bytes + current

    # ------------------------------------------------------------------ writer thread
    def _run(self) -> None:
        last_tick = time.monotonic()
        while True:
            try:
                item = self._queue.get(timeout=_TICK)
            except queue.Empty:
                item = None
            if item is _STOP:
                break
            if self.failure is not None:
                continue
            try:
                if item is not None:
                    self._handle(item)
                now = time.monotonic()
                if now - last_tick >= _TICK:
                    last_tick = now
                    self._tick(now)
            except OSError as exc:
                self._fail(exc)
        if self.failure is None:
            try:
                self._close_file()
            except OSError as exc:
                self._fail(exc)

    def _handle(self, item: _Item) -> None:
        w = self._writer
        assert w is not None
        if item[0] == "raw":
            _, device, direction, data, t = item
            w.write_raw(device, direction, data, t)
            self._count(topics.raw_topic(device, direction))
        elif item[0] == "msg":
            _, topic, message, t = item
            w.write(topic, message, t)
            self._count(topic)
        elif item[0] == "diag":
            _, source, what, text, t, level, count, details = item
            w.write_diagnostic(source, what, text, t, level=level, count=count,
                               details=details)
            self._count(topics.DIAGNOSTICS)
            if level >= WARNING:
                self.errors += 1
        elif item[0] == "meta":
            _, name, record = item
            self._sticky_meta[name] = record
            w.add_metadata(name, record)
        elif item[0] == "map":
            _, reflectors, t = item
            self._sticky_map = reflectors
            w.write_map(reflectors, t)
            self._count(topics.MAP)

    def _count(self, topic: str) -> None:
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def _tick(self, now: float) -> None:
        w = self._writer
        assert w is not None
        w.maybe_flush()
        if not self.splitting:
            return
        too_long = self.split_seconds is not None and now - self._opened_wall >= self.split_seconds
        too_big = False
        if self.split_bytes is not None and self._path is not None:
            with contextlib.suppress(OSError):
                too_big = self._path.stat().st_size >= self.split_bytes
        if too_long or too_big:
            self._close_file()
            self._open_file()

    def _open_file(self) -> None:
        started = datetime.now(UTC)
        path = split_name(self.output, started, set(self.files)) if self.splitting \
            else self.output
        if self._tap is None:
            writer = LogWriter(path, chunk_seconds=self._chunk_seconds, fsync=self._fsync,
                               source="record", command=self._command)
        else:
            from lgvtool.live.tap import TappedLogWriter

            writer = TappedLogWriter(path, tap=self._tap, chunk_seconds=self._chunk_seconds,
                                     fsync=self._fsync, source="record", command=self._command)
        self._writer, self._path = writer, path
        self._opened_wall = time.monotonic()
        self.files.append(path)
        if self._config is not None:
            writer.write_config(self._config)
        if self.splitting:
            writer.add_metadata("split", {"index": len(self.files),
                                          "previous": self.files[-2].name
                                          if len(self.files) > 1 else None,
                                          "started_utc": started.strftime("%Y-%m-%dT%H:%M:%SZ")})
        for name, data in self._sticky_meta.items():
            writer.add_metadata(name, data)
        if self._sticky_map is not None:
            writer.write_map(self._sticky_map, time.time_ns())
            self._count(topics.MAP)

    def _close_file(self) -> None:
        w, path = self._writer, self._path
        if w is None:
            return
        self._writer = None
        w.close()
        if path is not None:
            with contextlib.suppress(OSError):
                self._closed_bytes += path.stat().st_size
        self._path = None

    def _fail(self, exc: OSError) -> None:
        full = exc.errno in _FULL
        path = self._path
        reason = os.strerror(exc.errno) if exc.errno else str(exc)
        self.failure = SinkFailure(full, path, reason)
        w, self._writer = self._writer, None
        if w is not None:
            try:
                w.close()
            except (OSError, ValueError):
                w.abort()
        self.failed.set()
