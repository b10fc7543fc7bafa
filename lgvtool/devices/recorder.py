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
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, TextIO

from lgvtool.config import Config, default_config
from lgvtool.devices.device_links import MCU_SERIAL_DEFAULTS, NAV200_SERIAL_DEFAULTS, open_link
from lgvtool.devices.device_registry import registration
from lgvtool.devices.link_worker import LinkTiming
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.nav200.nav200_session import Nav200Settings
from lgvtool.devices.status import StatusLine, format_bytes
from lgvtool.errors import InputError, LgvError
from lgvtool.wire.decode_events import INFO

__all__ = ["RecordError", "RecordResult", "Recorder", "RecorderSettings", "record"]


class RecordError(LgvError):
    """The recording had to stop (e.g. the disk is full); the message says what is on disk."""


@dataclass(frozen=True)
class RecorderSettings:
    """What to record and how. Times in s, sizes in bytes."""

    output: Path
    nav_url: str | None = None
    mcu_url: str | None = None
    duration: float | None = None
    """Stop after this long; None: until SIGINT/SIGTERM."""
    nav: Nav200Settings = field(default_factory=Nav200Settings)
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
    nav350_url: str | None = None
    """The NAV350 (tcp://HOST:2112), recorded by lgvtool.devices.nav350."""
    nav350: Any = None
    """Its :class:`lgvtool.devices.nav350.nav350_session.Nav350Settings` (None: the defaults)."""


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
    live: dict[str, Any] | None = None
    """The live view's figures (URL, messages published, estimator latency), if served."""

    def summary(self) -> str:
        """One line for the terminal."""
        names = ", ".join(str(p) for p in self.files)
        shown = ", ".join(f"{t} {n}" for t, n in sorted(self.counts.items())
                          if t in ("/mcu/frame", "/nav/pose", "/diagnostics"))
        return (f"recorded {self.elapsed:.1f} s ({self.stop_reason}): {shown or 'no messages'}; "
                f"{self.errors} warnings/errors; {format_bytes(self.bytes)} -> {names}")


class Recorder:
    """Record the NAV200 and the MCU into a log (or a series of split logs).

    Use :meth:`run` from the main thread (it installs SIGINT/SIGTERM handlers there) or from
    any thread with :meth:`stop` to end it.
    """

    def __init__(self, settings: RecorderSettings, *, status_stream: TextIO | None = None
                 ) -> None:
        if settings.nav_url is None and settings.mcu_url is None and settings.nav350_url is None:
            raise InputError("record: give --nav URL, --nav350 URL, --mcu URL or several")
        if settings.duration is not None and settings.duration <= 0:
            raise InputError("record: --duration must be positive")
        self.settings = settings
        self.config = settings.config or default_config()
        self._stream = status_stream if status_stream is not None else sys.stderr
        self._stop = threading.Event()
        self._reason = "stopped"
        self._nav_link = None if settings.nav_url is None else open_link(
            settings.nav_url, NAV200_SERIAL_DEFAULTS)
        self._mcu_link = None if settings.mcu_url is None else open_link(
            settings.mcu_url, MCU_SERIAL_DEFAULTS)
        self._nav350_link = None if settings.nav350_url is None else open_link(
            settings.nav350_url, NAV200_SERIAL_DEFAULTS)
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

    def _start_live(self) -> Any:
        """Bind the live server now, before anything is recorded (a port in use or a host
        that does not resolve fails here, as bad input)."""
        from lgvtool.live.live_server import LiveServer
        from lgvtool.live.online import OnlineEstimator
        from lgvtool.live.tap import LiveFeed
        from lgvtool.log import topics

        estimators = [OnlineEstimator(n, self.config) for n in self.settings.live_estimators]
        server = LiveServer(self.settings.live)
        # the contract's fixed topics a recorder may write (not the simulator's or importers')
        server.prepare({t: s for t, s in topics.FIXED.items()
                        if t not in (topics.TRUTH, topics.ODOM)})
        return LiveFeed(server, estimators, warn=self._warn)

    def stop(self, reason: str = "stopped") -> None:
        """Ask the recording to end (thread-safe, idempotent)."""
        if not self._stop.is_set():
            self._reason = reason
            self._stop.set()

    def _warn(self, text: str) -> None:
        self._stream.write(f"lgvtool: warning: {text}\n")
        self._stream.flush()

    def _build_workers(self) -> None:
        """One worker per link, made by its family's registration (the MCU's first: the NAV
        workers take their speed input from it)."""
        s, timing = self.settings, self.settings.timing
        mcu: Any = None
        for family, link, settings in (("mcu", self._mcu_link, None),
                                       ("nav200", self._nav_link, s.nav),
                                       ("nav350", self._nav350_link, s.nav350)):
            if link is None:
                continue
            worker = registration(family).recorder_worker(
                link, self.sink, self._stop, timing, settings, self.config, mcu=mcu,
                warn=self._warn)
            if family == "mcu":
                mcu = worker
            self.workers.append(worker)

    def _recording_metadata(self) -> dict[str, Any]:
        s = self.settings
        return {
            "nav_url": s.nav_url, "mcu_url": s.mcu_url, "duration_s": s.duration,
            "nav350_url": s.nav350_url,
            "poll_period_s": s.nav.poll_period if s.nav_url else None,
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
                            live=None if self.live is None else self.live.stats())

    def _install_signals(self) -> Any:
        if threading.current_thread() is not threading.main_thread():
            return lambda: None
        previous: dict[int, Any] = {}

        def handler(signum: int, frame: Any) -> None:
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
