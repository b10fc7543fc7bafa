"""The recording loop: device threads, one writer thread, the status line, signals.

::

    NAV200 link ──► Nav200Worker (Nav200Session)┐
    NAV350 link ──► Nav350Worker (Nav350Session)├─► LogSink queue ──► writer thread ──► OUT.mcap
    MCU link ─────► McuWorker (McuLink) ────────┘        (chunks closed every second, fsync)

The main thread only watches: the duration, SIGINT/SIGTERM, a failed disk, and the status line
on stderr. Stopping joins the device threads (each wakes at least every 0.1 s) and finishes the
file (summary and indexes), well within 2 s.
"""

from __future__ import annotations

import os
import platform
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, Any, TextIO

from lgvtool.config import Config, default_config
from lgvtool.devices.device_registry import listed, registration, registrations
from lgvtool.devices.link_worker import LinkTiming
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.status import StatusLine, format_bytes
from lgvtool.errors import InputError, LgvError
from lgvtool.json_types import JSON, JSONObject
from lgvtool.wire.decode_events import INFO

if TYPE_CHECKING:
    from lgvtool.live.tap import LiveFeed, LiveStats

__all__ = ["RecordError", "RecordResult", "RecordedDevice", "Recorder", "RecorderSettings",
           "no_device_message", "record"]


class RecordError(LgvError):
    """The recording had to stop (e.g. the disk is full); the message says what is on disk."""


@dataclass(frozen=True)
class RecordedDevice:
    """One device to record: its link URL (``serial://...`` or ``tcp://HOST:PORT``) and its
    family's settings (e.g. :class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings`;
    None: the family's defaults)."""

    url: str
    settings: Any = None


def no_device_message() -> str:
    """The usage line of a recording without a device:
    ``record: give --nav URL, --nav350 URL, --mcu URL or several``."""
    options = [f"{r.RECORD_URL_OPTION} URL" for r in listed()]
    return f"record: give {', '.join(options)} or several"


@dataclass(frozen=True)
class RecorderSettings:
    """What to record and how. Times in s, sizes in bytes."""

    output: Path
    devices: Mapping[str, RecordedDevice] = field(default_factory=dict)
    """Family (:data:`~lgvtool.devices.device_registry.FAMILIES`) -> the device to record."""
    duration: float | None = None
    """Stop after this long; None: until SIGINT/SIGTERM."""
    split_bytes: int | None = None
    split_seconds: float | None = None
    config: Config | None = None
    """Vehicle geometry (speed input) and the configuration stored in the log."""
    status: bool = True
    status_interval: float = 1.0
    chunk_seconds: float = 0.5
    fsync: bool = True
    timing: LinkTiming = field(default_factory=LinkTiming)
    overwrite: bool = False
    command: str | None = None
    live: Any = None
    """Serve the recording live here (a ``lgvtool.live.live_server.LiveAddress``); None: not."""
    live_estimators: tuple[str, ...] = ()
    """Online estimators whose estimate the live view shows."""


@dataclass
class RecordResult:
    """What a recording produced: files, per-topic counts, warnings, why it stopped."""

    files: list[Path]
    counts: dict[str, int]
    errors: int
    elapsed: float
    bytes: int
    stop_reason: str
    devices: dict[str, str]
    live: LiveStats | None = None
    """The live view's figures (URL, messages published, estimator latency), if served."""
    mapped: tuple[tuple[float, float], ...] | None = None
    """The landmarks a requested mapping run found (x, y m in the layout frame); None: no
    mapping run succeeded."""

    def summary(self) -> str:
        """One line for the terminal."""
        names = ", ".join(str(p) for p in self.files)
        shown = ", ".join(f"{t} {n}" for t, n in sorted(self.counts.items())
                          if t in ("/mcu/frame", "/nav/pose", "/diagnostics"))
        return (f"recorded {self.elapsed:.1f} s ({self.stop_reason}): {shown or 'no messages'}; "
                f"{self.errors} warnings/errors; {format_bytes(self.bytes)} -> {names}")


class Recorder:
    """Record the devices (the NAV200, the NAV350, the MCU) into a log (or a series of split
    logs).

    Use :meth:`run` from the main thread (it installs SIGINT/SIGTERM handlers there) or from
    any thread with :meth:`stop` to end it.
    """

    def __init__(self, settings: RecorderSettings, *, status_stream: TextIO | None = None
                 ) -> None:
        if not settings.devices:
            raise InputError(no_device_message())
        if settings.duration is not None and settings.duration <= 0:
            raise InputError("record: --duration must be positive")
        self.settings = settings
        self.config = settings.config or default_config()
        self._stream = status_stream if status_stream is not None else sys.stderr
        self._stop = threading.Event()
        self._reason = "stopped"
        self._links = {family: registration(family).recorder_link(device.url)
                       for family, device in settings.devices.items()}
        out = Path(settings.output)
        if out.exists() and not settings.overwrite:
            raise InputError(f"record: {out} exists (use --force to overwrite it)")
        if not out.parent.is_dir():
            raise InputError(f"record: no such directory: {out.parent}")
        self.live = None if settings.live is None else self._start_live()
        self.sink = LogSink(out, split_bytes=settings.split_bytes,
                            split_seconds=settings.split_seconds, config=self.config,
                            command=settings.command, chunk_seconds=settings.chunk_seconds,
                            fsync=settings.fsync, tap=self.live)
        self.workers: list[Any] = []

    def _start_live(self) -> LiveFeed:
        """Bind the live server now, before anything is recorded (a port in use or a host
        that does not resolve fails here, as bad input)."""
        from lgvtool.live.drawing import drawing_of
        from lgvtool.live.live_server import LiveServer
        from lgvtool.live.online import OnlineEstimator
        from lgvtool.live.tap import LiveFeed
        from lgvtool.log import topics

        estimators = [OnlineEstimator(n, self.config) for n in self.settings.live_estimators]
        server = LiveServer(self.settings.live)
        # the contract's fixed topics a recorder may write (not the simulator's or importers'),
        # and every family's own topics (its raw traffic)
        fixed = {t: s for t, s in topics.FIXED.items() if t not in (topics.TRUTH, topics.ODOM)}
        server.prepare({**fixed, **{t: s for reg in registrations()
                                    for t, s in reg.TOPICS.items()}})
        return LiveFeed(server, estimators, warn=self._warn,
                        drawing=drawing_of(self.config))

    def stop(self, reason: str = "stopped") -> None:
        """Ask the recording to end (thread-safe, idempotent)."""
        if not self._stop.is_set():
            self._reason = reason
            self._stop.set()

    def _warn(self, text: str) -> None:
        self._stream.write(f"lgvtool: warning: {text}\n")
        self._stream.flush()

    def _build_workers(self) -> None:
        """One worker per link, made by its family's registration (the odometry source's
        first: the other workers take their speed input from it)."""
        regs = registrations()
        mcu: Any = None
        for reg in [r for r in regs if r.ODOMETRY] + [r for r in regs if not r.ODOMETRY]:
            device = self.settings.devices.get(reg.DEVICE)
            if device is None:
                continue
            worker = reg.recorder_worker(
                self._links[reg.DEVICE], self.sink, self._stop, self.settings.timing,
                device.settings, self.config, mcu=mcu, warn=self._warn)
            if reg.ODOMETRY:
                mcu = worker
            self.workers.append(worker)

    def _recording_metadata(self) -> JSONObject:
        s = self.settings
        devices: dict[str, JSON] = {}
        for reg in registrations():
            devices.update(reg.recorder_metadata(s.devices.get(reg.DEVICE)))
        return {
            **devices, "duration_s": s.duration,
            "split_bytes": s.split_bytes, "split_seconds": s.split_seconds,
            "chunk_seconds": s.chunk_seconds, "fsync": s.fsync,
            "host": platform.node(), "pid": os.getpid(),
            "started_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        }

    def _device_states(self) -> dict[str, str]:
        return {w.device: w.state for w in self.workers}

    def run(self) -> RecordResult:
        """Record until the duration is over, :meth:`stop` is called, SIGINT/SIGTERM arrives
        or the disk fails. Raises :class:`RecordError` when the disk fails."""
        restore = self._install_signals()
        status = StatusLine(self._stream) if self.settings.status else None
        t0 = time.monotonic()
        if self.live is not None:
            self._stream.write(f"lgvtool: live view on {self.live.server.url} "
                               f"(Foxglove: open connection, Foxglove WebSocket)\n")
            self._stream.flush()
        try:
            self.sink.start()
            self.sink.set_metadata("recorder", self._recording_metadata())
            self._build_workers()
            for w in self.workers:
                w.start()
            next_status = t0
            while not self._stop.wait(0.05):
                now = time.monotonic()
                if self.settings.duration is not None and now - t0 >= self.settings.duration:
                    self.stop("duration reached")
                if self.sink.failed.is_set():
                    self.stop("write failed")
                if status is not None and now >= next_status:
                    next_status = now + self.settings.status_interval
                    status.update(now, now - t0, self.sink.counts, self.sink.errors,
                                  self.sink.bytes_written(), self._device_states())
        finally:
            self._stop.set()
            # each worker wakes within 0.1 s (a TCP connect attempt within its 1 s timeout)
            deadline = time.monotonic() + 1.2
            for w in self.workers:
                w.join(max(0.0, deadline - time.monotonic()))
            self.sink.diagnostic("recorder", "stopped", f"recording stopped: {self._reason}",
                                 time.time_ns(), level=INFO,
                                 details={"reason": self._reason,
                                          "elapsed_s": round(time.monotonic() - t0, 3)})
            self.sink.close()
            if self.live is not None:
                self.live.close()
            restore()
        elapsed = time.monotonic() - t0
        if status is not None:
            status.update(time.monotonic(), elapsed, self.sink.counts, self.sink.errors,
                          self.sink.bytes_written(), self._device_states(), force=True)
            status.finish()
        for w in self.workers:
            if w.crashed is not None:
                raise w.crashed
        failure = self.sink.failure
        if failure is not None:
            what = "disk full" if failure.disk_full else "write failed"
            raise RecordError(
                f"{what} while writing {failure.path}: {failure.message}; recording stopped. "
                f"The file holds everything up to the last second before the failure; "
                f"'lgvtool recover {failure.path} -o FIXED.mcap' makes it a complete log")
        return RecordResult(files=list(self.sink.files), counts=dict(self.sink.counts),
                            errors=self.sink.errors, elapsed=elapsed,
                            bytes=self.sink.bytes_written(), stop_reason=self._reason,
                            devices=self._device_states(),
                            live=None if self.live is None else self.live.stats(),
                            mapped=next((w.mapped for w in self.workers
                                         if getattr(w, "mapped", None) is not None), None))

    def _install_signals(self) -> Callable[[], None]:
        if threading.current_thread() is not threading.main_thread():
            return lambda: None
        previous: dict[int, Any] = {}

        def handler(signum: int, frame: FrameType | None) -> None:
            self.stop(f"{signal.Signals(signum).name} received")

        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, handler)

        def restore() -> None:
            for sig, old in previous.items():
                signal.signal(sig, old)

        return restore


def record(settings: RecorderSettings, *, status_stream: TextIO | None = None) -> RecordResult:
    """Record with ``settings`` until done; see :class:`Recorder`."""
    return Recorder(settings, status_stream=status_stream).run()
