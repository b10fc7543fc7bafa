"""The recorder's thread per device link: open with back-off, read, decode, hand everything to
the sink. A family's worker (``devices/<family>/<family>_worker.py``) subclasses :class:`LinkWorker`.

A worker never blocks longer than a tenth of a second at a time, and every wait is a wait on the
stop event, so it notices a stop request at once.

Reconnecting (docs/recording.md, "Reconnecting and back-off"): every open but the very first
waits for the back-off, whether the last connect failed, the link opened and dropped at once, or
a silent device's link is being reopened (:meth:`LinkWorker._quiet_reconnect`). The wait is
``backoff_initial * backoff_factor ** (n - 1)`` s, at most ``backoff_max``, where ``n`` counts
the connect attempts since the link was last *healthy* (at least 1). A link is healthy once it
has stayed open ``healthy_after`` s and the device sent bytes on it; only the end of a healthy
link starts the count again, so a link that opens and drops at once is retried at most every
``backoff_max`` s, not thousands of times a second.

Logged on /diagnostics: ``link_open`` (the first open), ``link_down`` (a connect failed, the
first of a series; every drop of an open link), ``link_up`` (open again), each with the counts
(``attempts``, ``backoff_s``, ``connections``, ``drops``), and ``link_stats`` when the worker
ends (totals).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from lgvtool.config import Vehicle
from lgvtool.devices.device_links import Link, LinkDown, LinkFatal
from lgvtool.devices.head_speed import head_velocity
from lgvtool.devices.logsink import LogSink
from lgvtool.json_types import JSON, JSONObject
from lgvtool.wire.decode_events import ERROR, INFO, WARNING

if TYPE_CHECKING:
    from lgvtool.devices.mcu.mcu_session import Motion


class Encodable(Protocol):
    """A request a host session sends: its bytes on the wire."""

    def encode(self) -> bytes: ...


class SpeedInputSettings(Protocol):
    """The part of a host session's settings the worker reads: whether the device takes the
    vehicle's speed."""

    @property
    def speed_input(self) -> bool: ...


class HostSession(Protocol):
    """A family's host session as a :class:`SessionWorker` runs it (times ``now`` in s of
    the monotonic clock; speeds in m/s and rad/s)."""

    @property
    def settings(self) -> SpeedInputSettings: ...
    @property
    def state(self) -> str: ...
    def link_up(self, now: float) -> None: ...
    def link_down(self, now: float) -> None: ...
    def poll(self, now: float) -> Encodable | None: ...
    def feed(self, data: bytes, now: float) -> None: ...
    def next_deadline(self, now: float) -> float: ...
    def set_speed(self, vx: float, vy: float, omega: float, now: float) -> None: ...


class MotionSource(Protocol):
    """Where the vehicle's latest motion comes from (the MCU worker): ``(time s, motion)``,
    or None before the first."""

    @property
    def motion(self) -> tuple[float, Motion] | None: ...

__all__ = ["READ_SLICE", "LinkTiming", "LinkWorker", "SessionWorker"]

#: Longest single wait for bytes, s (bounds the reaction time to a stop request).
READ_SLICE = 0.1


@dataclass(frozen=True)
class LinkTiming:
    """Reconnect and silence timing of a worker, s.

    After the ``n``-th connect attempt since the link was last healthy failed or dropped, the
    next one waits ``min(backoff_max, backoff_initial * backoff_factor ** (n - 1))`` s
    (``backoff_initial`` after a healthy link ended): with the defaults 0.2, 0.4, 0.8, 1.6,
    then 2 s for every further attempt (at most 8 connections in 10 s to a peer
    that accepts and closes every connection). Only the very first open of a recording goes
    without a wait.
    """

    backoff_initial: float = 0.2
    """The shortest wait before reopening a link, s: after a connect that failed, a link that
    dropped (even a healthy one), or a silent device's link being reopened. Must be > 0."""
    backoff_max: float = 2.0
    """The cap of the wait before reopening, s (>= ``backoff_initial``)."""
    backoff_factor: float = 2.0
    """Each further attempt without a healthy link in between waits this many times longer
    (>= 1)."""
    healthy_after: float = 5.0
    """A link that stayed open this long, s, with bytes from the device on it, was healthy:
    when it ends, the back-off starts again from ``backoff_initial``. A link that drops sooner,
    or on which the device sent nothing, does not reset it."""
    silence: float = 1.0
    """No bytes for this long (MCU) counts as a silent device."""
    reconnect_after: float = 3.0
    """Silence on an open link for this long makes the worker reopen the link (a TCP
    connection to a device server can die without an error)."""

    def __post_init__(self) -> None:
        if not (self.backoff_initial > 0 and self.backoff_max >= self.backoff_initial
                and self.backoff_factor >= 1 and self.healthy_after >= 0):
            raise ValueError("LinkTiming: need 0 < backoff_initial <= backoff_max, "
                             "backoff_factor >= 1 and healthy_after >= 0")

    def backoff(self, attempts: int) -> float:
        """The wait, s, after ``attempts`` connect attempts without a healthy link (0: after a
        healthy link ended)."""
        n = min(max(0, attempts - 1), 64)
        return min(self.backoff_max, self.backoff_initial * self.backoff_factor ** n)


class LinkWorker(threading.Thread):
    """Shared open/reopen/back-off logic; subclasses implement ``_opened`` and ``_cycle``, and
    call :meth:`_received` when bytes arrived."""

    device = "device"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event,
                 timing: LinkTiming, warn: Callable[[str], None] | None = None) -> None:
        super().__init__(name=f"{self.device}-link", daemon=True)
        self.link = link
        self.sink = sink
        self.stop_event = stop
        self.timing = timing
        self._warn = warn
        #: short state for the status line
        self.state = "connecting"
        #: open links lost (LinkDown while open)
        self.link_failures = 0
        self.crashed: BaseException | None = None
        #: links opened, connects that failed, silent links reopened
        self.connections = 0
        self.failed_opens = 0
        self.quiet_reconnects = 0
        #: connect attempts since the link was last healthy (drives the back-off)
        self._attempts = 0
        #: earliest time (monotonic s) of the next open, and the wait that set it, s; the
        #: first open goes at once
        self._next_open_at = -math.inf
        self._wait_s = 0.0
        #: when the open link was opened (None: no link open), and whether bytes came on it
        self._open_since: float | None = None
        self._data_since_open = False

    @property
    def drops(self) -> int:
        """Open links lost so far."""
        return self.link_failures

    def diag(self, kind: str, message: str, level: int = WARNING, **details: JSON) -> None:
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
            self.diag("link_stats", f"{self.link.spec.describe()}: {self.connections} "
                      f"connections, {self.drops} drops, {self.failed_opens} failed connects",
                      level=INFO, url=self.link.spec.url, connections=self.connections,
                      drops=self.drops, failed_opens=self.failed_opens,
                      quiet_reconnects=self.quiet_reconnects)

    # ------------------------------------------------------------------ back-off
    def _received(self) -> None:
        """Bytes came from the device on the open link (one half of "healthy")."""
        self._data_since_open = True

    def _wait_to_open(self) -> bool:
        """Wait (on the stop event) until the back-off allows the next open; False when the
        recording is stopping."""
        delay = self._next_open_at - time.monotonic()
        if delay > 0:
            return not self.stop_event.wait(delay)
        return not self.stop_event.is_set()

    def _open_link(self) -> None:
        """One connect attempt, counted; LinkDown (the next one scheduled) when it fails."""
        self._attempts += 1
        try:
            self.link.open()
        except LinkDown:
            self.failed_opens += 1
            self._schedule(time.monotonic())
            raise
        self.connections += 1
        self._open_since = time.monotonic()
        self._data_since_open = False

    def _schedule(self, now: float) -> float:
        """Set the time of the next open from the attempts so far; the wait, s."""
        delay = self.timing.backoff(self._attempts)
        self._next_open_at, self._wait_s = now + delay, delay
        return delay

    def _end_connection(self, now: float) -> tuple[float, bool]:
        """The open link ended (dropped, or closed to reopen it): if it was healthy the
        back-off starts again; the next open is scheduled. (s it was open, healthy)."""
        since = self._open_since if self._open_since is not None else now
        self._open_since = None
        open_s = now - since
        healthy = open_s >= self.timing.healthy_after and self._data_since_open
        if healthy:
            self._attempts = 0
        self._schedule(now)
        return open_s, healthy

    # ------------------------------------------------------------------ the loop
    def _loop(self) -> None:
        down_since: float | None = None  # when the link was lost (or first failed to open)
        down_logged = False  # a link_down was logged since the link was last open
        last_error = ""
        failed = 0  # connects that failed since the link was last open
        first = True
        while not self.stop_event.is_set():
            if not self.link.is_open:
                if not self._wait_to_open():
                    break
                try:
                    self._open_link()
                except LinkDown as exc:
                    failed += 1
                    last_error = str(exc)
                    if down_since is None:
                        down_since = time.monotonic()
                    if not down_logged:  # only the first failure of a series is logged
                        down_logged = True
                        self.diag("link_down", f"cannot open {self.link.spec.describe()}: "
                                  f"{exc}", level=ERROR, url=self.link.spec.url, error=str(exc),
                                  **self._counts())
                        if self._warn is not None:
                            self._warn(f"{self.device}: cannot open "
                                       f"{self.link.spec.describe()} ({exc}); retrying")
                    self.state = "down"
                    continue
                now = time.monotonic()
                if first:
                    note = f" ({self.link.note})" if self.link.note else ""
                    waited: JSONObject = {} if down_since is None else {
                        "gap_s": round(now - down_since, 3), "last_error": last_error}
                    self.diag("link_open", f"opened {self.link.spec.describe()}{note}",
                              level=INFO, url=self.link.spec.url, attempts=failed,
                              connections=self.connections, **waited)
                elif down_since is not None:
                    gap = now - down_since
                    self.diag("link_up", f"{self.link.spec.describe()} back after {gap:.1f} s",
                              level=INFO, gap_s=round(gap, 3), attempts=failed,
                              last_error=last_error, url=self.link.spec.url,
                              connections=self.connections)
                first = False
                down_since, down_logged, last_error, failed = None, False, "", 0
                self.state = "open"
                self._opened(now)
            try:
                self._cycle()
            except LinkDown as exc:
                now = time.monotonic()
                self.link.close()
                lost: JSONObject = {}
                if self._open_since is not None:  # an open link was lost
                    self.link_failures += 1
                    open_s, healthy = self._end_connection(now)
                    lost = {"open_s": round(open_s, 3), "healthy": healthy}
                # else: a silent device's link could not be reopened (a failed connect, its
                # next attempt scheduled already)
                down_since, down_logged, last_error = now, True, str(exc)
                self.state = "down"
                self.diag("link_down", f"{self.link.spec.describe()} lost: {exc}",
                          level=ERROR, url=self.link.spec.url, error=str(exc),
                          **self._counts(), **lost)
                self._lost()

    def _counts(self) -> JSONObject:
        """The back-off's figures for a ``link_down``: the connect attempts since the link was
        last healthy, the wait before the next one, links opened and lost so far."""
        return {"attempts": self._attempts,
                "backoff_s": round(self._wait_s, 3),
                "connections": self.connections, "drops": self.drops}

    def _quiet_reconnect(self) -> bool:
        """Reopen the link of a silent device, without logging a link failure (the silence is
        its own diagnostic), after the back-off like every reopen. False when the recording
        stopped during the wait (the link is then closed); LinkDown when the reopen failed."""
        now = time.monotonic()
        self.link.close()
        self.quiet_reconnects += 1
        if self._open_since is not None:
            self._end_connection(now)
        if not self._wait_to_open():
            return False
        self._open_link()
        return True

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
                 session: HostSession, *, vehicle: Vehicle, mcu: MotionSource | None = None,
                 warn: Callable[[str], None] | None = None) -> None:
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
        if not self.link.is_open:  # stopped while waiting to reopen a silent device's link
            return
        wait = min(READ_SLICE, max(0.0, self.session.next_deadline(now) - time.monotonic()))
        data = self.link.read(wait)
        if data:
            self._received()
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
