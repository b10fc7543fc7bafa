"""The recorder's NAV350 thread: runs :class:`Nav350Session` over a TCP link into the log.

Logged: /nav350/tx and /nav350/rx (every byte), /nav/pose (with the device's figures and both
times), /nav/reflectors (every landmark), the uploaded layout (/map/reflectors), device identity
and clock estimate (metadata ``device.nav350``), and on /diagnostics every sFA, error code,
timeout, decoder error, reconnect and gap.
"""

from __future__ import annotations

import threading
import time
from typing import Any

from lgvtool.config import Reflector, Vehicle
from lgvtool.devices.device_links import Link
from lgvtool.devices.link_worker import LinkTiming, SessionWorker
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu.mcu_worker import McuWorker
from lgvtool.devices.nav350.nav350_session import (
    ClockRead,
    Identity,
    LayoutUploaded,
    Nav350Session,
    NavigationEntered,
    PoseDataReceived,
    SessionFatal,
)
from lgvtool.devices.session_events import DeviceSilent
from lgvtool.errors import LgvError
from lgvtool.log import topics
from lgvtool.log.messages import nav350_pose_message, nav350_scan_message
from lgvtool.wire.decode_events import ERROR, INFO, DecodeEvent

__all__ = ["Nav350Stopped", "Nav350Worker"]


class Nav350Stopped(LgvError):
    """The NAV350 cannot be recorded (e.g. it refused the login); the log holds what came."""


class Nav350Worker(SessionWorker):
    """One NAV350 link of a recording (see the module docstring): the polled devices'
    request/read cycle and speed input, with the NAV350 session's events."""

    device = "nav350"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 session: Nav350Session, *, vehicle: Vehicle,
                 known_map: tuple[Reflector, ...] = (), mcu: McuWorker | None = None,
                 warn: Any = None) -> None:
        super().__init__(link, sink, stop, timing, session, vehicle=vehicle, mcu=mcu, warn=warn)
        self.session: Nav350Session = session
        self._known = known_map
        self._map_id: dict[int, int] | None = None
        self._identity: dict[str, str] = {}
        self._applied: dict[str, Any] = {}
        self._clock: dict[str, Any] = {}
        #: host wall ns minus monotonic ns (fixed at start), to log monotonic times
        self._wall_minus_mono = time.time_ns() - time.monotonic_ns()
        self._last_clock_meta = 0.0

    def _host_ns(self, mono_s: float) -> int:
        return round(mono_s * 1e9) + self._wall_minus_mono

    def _host_ns_of_tick(self, tick: int) -> int | None:
        host = self.session.clock.host_time_of(tick)
        return None if host is None else self._host_ns(host)

    def _lost(self) -> None:
        self.session.link_down(time.monotonic())
        self._handle_events(time.time_ns())

    def _handle_events(self, t: int) -> None:
        for event in self.session.pop_events():
            if isinstance(event, PoseDataReceived):
                rx = self._host_ns(event.received)
                pose = nav350_pose_message(event.data, rx, self._host_ns_of_tick)
                if pose is not None:
                    self.sink.message(topics.NAV_POSE, pose, rx)
                scan = nav350_scan_message(event.data, rx, self._host_ns_of_tick, self._map_id)
                if scan is not None:
                    self.sink.message(topics.NAV_REFLECTORS, scan, rx)
            elif isinstance(event, DecodeEvent):
                self.sink.event(event, t)
            elif isinstance(event, ClockRead):
                self._on_clock(event, t)
            elif isinstance(event, Identity):
                self._identity = dict(event.values)
                self._metadata()
            elif isinstance(event, LayoutUploaded):
                self._on_layout(event, t)
            elif isinstance(event, NavigationEntered):
                self._applied = event.settings
                self.sink.diagnostic("nav350", "navigation", "NAV350 navigation", t,
                                     level=INFO, details=event.settings)
                self._metadata()
            elif isinstance(event, DeviceSilent):
                self.state = "silent"
                self.diag("device_silent", f"no NAV350 reply {event.timeouts} times in a row; "
                          "reconnecting", level=ERROR, timeouts=event.timeouts)
                self._quiet_reconnect()
                self.session.link_up(time.monotonic())
            elif isinstance(event, SessionFatal):
                self.diag("fatal", event.message, level=ERROR)
                self.crashed = Nav350Stopped(f"record: {event.message}; the log holds "
                                             "everything recorded until then")
                self.stop_event.set()

    def _on_clock(self, event: ClockRead, t: int) -> None:
        est = event.estimate
        if est is None:
            return
        now = time.monotonic()
        self._clock = {"offset_s": est.offset, "drift_ppm": est.drift * 1e6,
                       "bound_ms": est.bound_s * 1e3, "reads": self.session.clock.reads,
                       "one_sided": est.one_sided}
        if now - self._last_clock_meta >= 10.0:
            self._last_clock_meta = now
            self.sink.diagnostic("nav350", "clock", f"NAV350 clock: drift {est.drift * 1e6:.1f}"
                                 f" ppm, offset bound {est.bound_s * 1e3:.2f} ms", t, level=INFO,
                                 details={"tick_ms": event.tick, **self._clock})
            self._metadata()

    def _on_layout(self, event: LayoutUploaded, t: int) -> None:
        layout = self._known
        self._map_id = {dev: r.id for dev, r in zip(event.ids, layout, strict=False)}
        self.sink.set_map(layout, t)
        self.sink.diagnostic("nav350", "layout_uploaded", f"{len(event.ids)} landmarks uploaded"
                             f" into layer {event.layer}", t, level=INFO,
                             details={"landmarks": len(event.ids), "layer": event.layer})
        self._metadata()

    def _metadata(self) -> None:
        record: dict[str, Any] = {"link": self.link.spec.url, **self._identity}
        if self._applied:
            record["settings"] = self._applied
        if self._clock:
            record["clock"] = self._clock
        if self._map_id is not None:
            record["global_ids"] = {str(k): v for k, v in self._map_id.items()}
        self.sink.set_metadata("device.nav350", record)
