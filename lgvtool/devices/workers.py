"""One thread per device link: open with backoff, read, decode, hand everything to the sink.

A worker never blocks longer than a tenth of a second, so it notices a stop request quickly.
Link failures are logged on /diagnostics as ``link_down`` and ``link_up`` (with the gap in s
and the attempts made); reopening backs off from ``backoff_initial`` to ``backoff_max`` s.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from typing import Any

from lgvtool.config import Reflector, Vehicle
from lgvtool.devices.links import Link, LinkDown, LinkFatal
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu_link import McuLink, Motion, head_velocity
from lgvtool.devices.nav200_session import (
    DeviceIdentity,
    DeviceSilent,
    MapUploaded,
    Nav200Session,
    PoseReceived,
    PositioningEntered,
)
from lgvtool.log import topics
from lgvtool.wire.events import ERROR, INFO, WARNING, DecodeEvent
from lgvtool.wire.messages import mcu_frame_message, nav_pose_message, timestamp_from_ns

__all__ = ["LinkTiming", "McuWorker", "NavWorker"]

#: Longest single wait for bytes, s (bounds the reaction time to a stop request).
_READ_SLICE = 0.1


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


class _Worker(threading.Thread):
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


class McuWorker(_Worker):
    """Reads the MCU frame stream continuously: /mcu/rx, /mcu/frame, gaps to /diagnostics."""

    device = "mcu"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 vehicle: Vehicle, warn: Any = None) -> None:
        super().__init__(link, sink, stop, timing, warn)
        self.decoder = McuLink(vehicle)
        self._last_data = time.monotonic()
        self._opened_at = self._last_data
        self._silent = False
        self._described = False
        #: latest velocity estimate and when it was made (monotonic s)
        self.motion: tuple[float, Motion] | None = None

    def _opened(self, now: float) -> None:
        # silence is counted from here: the time the link was down is its own event
        self._opened_at = now
        self._last_data = max(self._last_data, now)
        self._silent = False

    def _lost(self) -> None:
        self.decoder.link_lost()
        self._flush_events(time.time_ns())
        self.motion = None

    def _cycle(self) -> None:
        data = self.link.read(_READ_SLICE)
        now = time.monotonic()
        if not data:
            quiet = now - max(self._last_data, self._opened_at)
            if not self._silent and now - self._last_data >= self.timing.silence:
                self._silent = True
                self.state = "silent"
                self.diag("device_silent", f"no MCU data for {now - self._last_data:.1f} s",
                          level=ERROR, silence_s=round(now - self._last_data, 3))
            if self._silent and quiet >= self.timing.reconnect_after:
                self._quiet_reconnect()
                self._opened_at = time.monotonic()
            return
        t = time.time_ns()
        self.sink.raw("mcu", "rx", data, t)
        if self._silent:
            gap = now - self._last_data
            self.diag("device_back", f"MCU data again after {gap:.1f} s", level=INFO,
                      gap_s=round(gap, 3))
            self._silent = False
        self._last_data = now
        self.state = "ok"
        stamp = timestamp_from_ns(t)
        for frame in self.decoder.feed(data):
            self.sink.message(topics.MCU_FRAME, mcu_frame_message(frame, stamp), t)
            if not self._described:
                self._described = True
                self.sink.set_metadata("device.mcu", {
                    "link": self.link.spec.url, "frame_version": frame.version,
                    "gyro_scale_deg_s": frame.gyro_scale_deg_s})
        if self.decoder.motion is not None:
            self.motion = (now, self.decoder.motion)
        self._flush_events(t)

    def _flush_events(self, t: int) -> None:
        for event in self.decoder.pop_events():
            self.sink.event(event, t)


class NavWorker(_Worker):
    """Runs the NAV200 host session over its link: /nav200/tx, /nav200/rx, /nav/pose, the map,
    the device identity, and every error reply and timeout on /diagnostics."""

    device = "nav200"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 session: Nav200Session, *, vehicle: Vehicle,
                 known_map: tuple[Reflector, ...] = (), mcu: McuWorker | None = None,
                 warn: Any = None) -> None:
        super().__init__(link, sink, stop, timing, warn)
        self.session = session
        self.vehicle = vehicle
        self._radius = {r.id: r.radius for r in known_map}
        self._mcu = mcu
        self.identity: dict[str, Any] = {}
        self.applied: dict[str, Any] = {}
        self.map: tuple[Reflector, ...] | None = None

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
        self._handle(time.time_ns())
        wait = min(_READ_SLICE, max(0.0, self.session.next_deadline(now) - time.monotonic()))
        data = self.link.read(wait)
        if data:
            t = time.time_ns()
            self.sink.raw(self.device, "rx", data, t)
            self.session.feed(data, time.monotonic())
            self._handle(t)
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

    def _handle(self, t: int) -> None:
        for event in self.session.pop_events():
            if isinstance(event, PoseReceived):
                self.sink.message(topics.NAV_POSE,
                                  nav_pose_message(event.pose, timestamp_from_ns(t)), t)
            elif isinstance(event, DecodeEvent):
                self.sink.event(event, t)
            elif isinstance(event, DeviceIdentity):
                self.identity = {"version": event.version, "serial": event.serial}
                self._metadata()
            elif isinstance(event, MapUploaded):
                self.map = tuple(
                    Reflector(id=rp.number, x=rp.x, y=rp.y,
                              radius=self._radius.get(rp.number, Reflector.radius),
                              layer=rp.layer)
                    for rp in event.reflectors)
                self.sink.set_map(self.map, t)
                self.sink.diagnostic("nav200", "map_uploaded",
                                     f"{len(self.map)} reflectors uploaded from layer "
                                     f"{event.layer}", t, level=INFO,
                                     details={"reflectors": len(self.map), "layer": event.layer})
                self._metadata()
            elif isinstance(event, PositioningEntered):
                self.applied = event.settings
                self.sink.diagnostic("nav200", "positioning", "NAV200 positioning", t,
                                     level=INFO, details=event.settings)
                self._metadata()
            elif isinstance(event, DeviceSilent):
                self.state = "silent"
                self._quiet_reconnect()
                self.session.link_up(time.monotonic())

    def _metadata(self) -> None:
        record: dict[str, Any] = {"link": self.link.spec.url, **self.identity}
        if self.applied:
            record["settings"] = self.applied
        if self.map is not None:
            record["map_layer"] = self.session.settings.layer
            record["map"] = [{"id": r.id, "x": r.x, "y": r.y, "layer": r.layer}
                             for r in self.map]
        self.sink.set_metadata("device.nav200", record)
