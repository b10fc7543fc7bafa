"""The recorder's thread per device link: open with backoff, read, decode, hand everything to
the sink. A family's worker (``devices/<family>/<family>_worker.py``) subclasses :class:`LinkWorker`.

A worker never blocks longer than a tenth of a second, so it notices a stop request quickly.
Link failures are logged on /diagnostics as ``link_down`` and ``link_up`` (with the gap in s
and the attempts made); reopening backs off from ``backoff_initial`` to ``backoff_max`` s.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

from lgvtool.config import Vehicle
from lgvtool.devices.device_links import Link, LinkDown, LinkFatal
from lgvtool.devices.head_speed import head_velocity
from lgvtool.devices.logsink import LogSink
from lgvtool.wire.decode_events import ERROR, INFO, WARNING

__all__ = ["READ_SLICE", "LinkTiming", "LinkWorker", "SessionWorker"]

#: Longest single wait for bytes, s (bounds the reaction time to a stop request).
READ_SLICE = 0.1


@dataclass(frozen=True)
class LinkTiming:
    """Reconnect and silence timing of a worker, s."""

    backoff_initial: float = 0.2
    backoff_max: float = 2.0
    silence: float = 1.0
    """No bytes for this long (MCU) counts as a silent device."""
    reconnect_after: float = 3.0
    """Silence on an open link for this long makes the worker reopen the link (a TCP
    connection to a device server can die without an error)."""


class LinkWorker(threading.Thread):
    """Shared open/reopen/backoff logic; subclasses implement ``_opened`` and ``_cycle``."""

    device = "device"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event,
                 timing: LinkTiming, warn: Any = None) -> None:
        super().__init__(name=f"{self.device}-link", daemon=True)
        self.link = link
        self.sink = sink
        self.stop_event = stop
        self.timing = timing
        self._warn = warn
        #: short state for the status line
        self.state = "connecting"
        self.link_failures = 0
        self.crashed: BaseException | None = None

    def diag(self, kind: str, message: str, level: int = WARNING, **details: Any) -> None:
        """A diagnostic from this device at the present host time."""
        self.sink.diagnostic(self.device, kind, message, time.time_ns(), level=level,
                             details=details)

    def run(self) -> None:
        try:
            self._loop()
        except LinkFatal as exc:  # retrying cannot help: stop the recording with this line
            self.crashed = LinkFatal(f"record: {self.device}: {exc}; recording stopped")
            self.diag("link_failed", f"{self.device}: {exc}", level=ERROR,
                      url=self.link.spec.url, error=str(exc))
            self.stop_event.set()
        except BaseException as exc:  # a bug must stop the recording, not hang it
            self.crashed = exc
            self.diag("internal_error", f"{type(exc).__name__}: {exc}", level=ERROR)
            self.stop_event.set()
        finally:
            self.link.close()

    def _loop(self) -> None:
        backoff = self.timing.backoff_initial
        down_since: float | None = None
        last_error = ""
        attempts = 0
        first = True
        while not self.stop_event.is_set():
            if not self.link.is_open:
                try:
                    self.link.open()
                except LinkDown as exc:
                    attempts += 1
                    last_error = str(exc)
                    if down_since is None:  # only the first failure of an outage is logged
                        down_since = time.monotonic()
                        self.diag("link_down", f"cannot open {self.link.spec.describe()}: "
                                  f"{exc}", level=ERROR, url=self.link.spec.url, error=str(exc))
                        if self._warn is not None:
                            self._warn(f"{self.device}: cannot open "
                                       f"{self.link.spec.describe()} ({exc}); retrying")
                    self.state = "down"
                    self.stop_event.wait(backoff)
                    backoff = min(self.timing.backoff_max, backoff * 2)
                    continue
                now = time.monotonic()
                if first:
                    note = f" ({self.link.note})" if self.link.note else ""
                    waited = {} if down_since is None else {
                        "gap_s": round(now - down_since, 3), "last_error": last_error}
                    self.diag("link_open", f"opened {self.link.spec.describe()}{note}",
                              level=INFO, url=self.link.spec.url, attempts=attempts, **waited)
                elif down_since is not None:
                    gap = now - down_since
                    self.diag("link_up", f"{self.link.spec.describe()} back after {gap:.1f} s",
                              level=INFO, gap_s=round(gap, 3), attempts=attempts,
                              last_error=last_error, url=self.link.spec.url)
                first = False
                backoff = self.timing.backoff_initial
                down_since, last_error, attempts = None, "", 0
                self.state = "open"
                self._opened(now)
            try:
                self._cycle()
            except LinkDown as exc:
                self.link_failures += 1
                self.link.close()
                down_since = time.monotonic()
                last_error = str(exc)
                self.state = "down"
                self.diag("link_down", f"{self.link.spec.describe()} lost: {exc}",
                          level=ERROR, url=self.link.spec.url, error=str(exc))
                self._lost()

    def _quiet_reconnect(self) -> None:
        """Reopen the link without logging a link failure (the device is merely silent)."""
        self.link.close()
        self.link.open()

    def _opened(self, now: float) -> None:
        """The link has just been opened."""

    def _lost(self) -> None:
        """The link has just failed."""

    def _cycle(self) -> None:
        """One bounded read/decode/write step; raises LinkDown."""
        raise NotImplementedError


class SessionWorker(LinkWorker):
    """The request/read cycle of a polled device: runs a family's host session (``poll``,
    ``feed``, ``next_deadline``, ``link_up``/``link_down``, ``set_speed``, all with the time
    passed in) over the link, logs the traffic as /DEVICE/tx and /DEVICE/rx, and sends the
    MCU worker's latest motion as speed input when the session's settings ask for it.
    Subclasses implement ``_handle_events`` (the session's events at host time ``t`` ns)."""

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 session: Any, *, vehicle: Vehicle, mcu: Any = None, warn: Any = None) -> None:
        super().__init__(link, sink, stop, timing, warn)
        self.session = session
        self.vehicle = vehicle
        self._mcu = mcu

    def _opened(self, now: float) -> None:
        self.session.link_up(now)

    def _lost(self) -> None:
        self.session.link_down(time.monotonic())

    def _cycle(self) -> None:
        now = time.monotonic()
        self._speed_input(now)
        request = self.session.poll(now)
        if request is not None:
            data = request.encode()
            self.link.write(data)
            self.sink.raw(self.device, "tx", data, time.time_ns())
        self._handle_events(time.time_ns())
        wait = min(READ_SLICE, max(0.0, self.session.next_deadline(now) - time.monotonic()))
        data = self.link.read(wait)
        if data:
            t = time.time_ns()
            self.sink.raw(self.device, "rx", data, t)
            self.session.feed(data, time.monotonic())
            self._handle_events(t)
        self.state = self.session.state

    def _speed_input(self, now: float) -> None:
        if not self.session.settings.speed_input or self._mcu is None:
            return
        latest = self._mcu.motion
        if latest is None:
            return
        at, motion = latest
        vx, vy = head_velocity(motion, self.vehicle)
        self.session.set_speed(vx, vy, motion.omega, at)

    def _handle_events(self, t: int) -> None:
        """The session's events since the last call, at host time ``t`` ns."""
        raise NotImplementedError
