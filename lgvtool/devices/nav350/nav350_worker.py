"""The recorder's NAV350 thread: runs :class:`Nav350Session` over a TCP link into the log.

Logged: /nav350/tx and /nav350/rx (every byte), /nav/pose (with the device's figures and both
times), /nav/reflectors (every landmark), the device's stored layout as read (/map/reflectors,
and before and after a requested write, metadata ``device.nav350.layout_before`` / ``_after``),
the landmarks of a mapping run (metadata ``device.nav350.mapping`` and /diagnostics), device
identity and clock estimate (metadata ``device.nav350``), and on /diagnostics every sFA, error
code, timeout, decoder error, reconnect and gap.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

from lgvtool.config import Reflector, Vehicle
from lgvtool.devices.device_links import Link
from lgvtool.devices.link_worker import LinkTiming, SessionWorker
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu.mcu_worker import McuWorker
from lgvtool.devices.nav350.nav350_session import (
    ClockRead,
    Identity,
    LayoutRead,
    LayoutWritten,
    MappingDone,
    Nav350Session,
    NavigationEntered,
    PoseDataReceived,
    SessionFatal,
)
from lgvtool.devices.nav350.nav350_telegrams import StoredLandmark
from lgvtool.devices.session_events import DeviceSilent
from lgvtool.errors import LgvError
from lgvtool.log import topics
from lgvtool.log.messages import nav350_pose_message, nav350_scan_message
from lgvtool.wire.decode_events import ERROR, INFO, WARNING, DecodeEvent

__all__ = ["MOTION_SPEED", "MOTION_YAW_RATE", "Nav350Stopped", "Nav350Worker",
           "reflectors_of_layout"]

#: The MCU shows motion above this speed (m/s) or yaw rate (rad/s): a mapping run waits.
MOTION_SPEED, MOTION_YAW_RATE = 0.005, 0.005
#: Odometry older than this says nothing about motion now, s.
_MOTION_MAX_AGE = 1.0


def reflectors_of_layout(landmarks: tuple[StoredLandmark, ...]) -> tuple[Reflector, ...]:
    """The device's stored landmarks as the log's reflectors: id = the device's global id, x, y
    in m, radius = half the landmark size (m), layer = its first layer."""
    return tuple(Reflector(lm.global_id, lm.x_mm / 1000.0, lm.y_mm / 1000.0,
                           max(lm.size_mm, 1) / 2000.0, lm.layers[0] if lm.layers else 0)
                 for lm in landmarks)


class Nav350Stopped(LgvError):
    """The NAV350 cannot be recorded (e.g. it refused the login); the log holds what came."""


class Nav350Worker(SessionWorker):
    """One NAV350 link of a recording (see the module docstring): the polled devices'
    request/read cycle and speed input, with the NAV350 session's events."""

    device = "nav350"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 session: Nav350Session, *, vehicle: Vehicle,
                 known_map: tuple[Reflector, ...] = (), mcu: McuWorker | None = None,
                 warn: Callable[[str], None] | None = None) -> None:
        super().__init__(link, sink, stop, timing, session, vehicle=vehicle, mcu=mcu, warn=warn)
        self.session: Nav350Session = session
        self._known = known_map
        self._map_id: dict[int, int] | None = None
        #: the mapping run's landmarks (x, y m), once done; None: no run (yet)
        self.mapped: tuple[tuple[float, float], ...] | None = None
        self._layouts: dict[str, list[dict[str, Any]]] = {}
        self._mapping: dict[str, Any] = {}
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
            elif isinstance(event, LayoutRead):
                self._on_layout_read(event, t)
            elif isinstance(event, LayoutWritten):
                self._on_layout_written(event, t)
            elif isinstance(event, MappingDone):
                self._on_mapping(event, t)
            elif isinstance(event, NavigationEntered):
                self._applied = event.settings
                self.sink.diagnostic("nav350", "navigation", "NAV350 navigation", t,
                                     level=INFO, details=event.settings)
                self._metadata()
            elif isinstance(event, DeviceSilent):
                self.state = "silent"
                self.diag("device_silent", f"no NAV350 reply {event.timeouts} times in a row; "
                          "reconnecting", level=ERROR, timeouts=event.timeouts)
                if self._quiet_reconnect():
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

    def _speed_input(self, now: float) -> None:
        super()._speed_input(now)
        latest = None if self._mcu is None else self._mcu.motion
        if latest is None or time.monotonic() - latest[0] > _MOTION_MAX_AGE:
            self.session.vehicle_moving(None)
        else:
            m = latest[1]
            self.session.vehicle_moving(abs(m.v) > MOTION_SPEED or abs(m.omega) > MOTION_YAW_RATE)

    def _on_layout_read(self, event: LayoutRead, t: int) -> None:
        marks = [{"id": lm.global_id, "x_mm": lm.x_mm, "y_mm": lm.y_mm, "size_mm": lm.size_mm,
                  "layers": list(lm.layers)} for lm in event.landmarks]
        self._layouts[event.when] = marks
        writes = self.session.settings.write_layout
        if event.when == "before" and writes and not self.session.layout_written:
            self.sink.diagnostic("nav350", "layout_erasing", f"erasing the NAV350's layout of "
                                 f"layer {event.layer} ({len(marks)} landmarks, logged in "
                                 f"device.nav350.layout_before) to write {len(writes)}", t,
                                 level=WARNING, details={"layer": event.layer,
                                                         "stored": len(marks),
                                                         "writing": len(writes)})
        else:
            self.sink.diagnostic("nav350", "layout_read", f"{len(marks)} landmarks read from "
                                 f"the NAV350's layer {event.layer} ({event.when})", t,
                                 level=INFO, details={"layer": event.layer,
                                                      "landmarks": len(marks),
                                                      "when": event.when})
        in_layer = tuple(lm for lm in event.landmarks if event.layer in lm.layers
                         or not lm.layers)
        if in_layer and (event.when == "after" or not writes):
            # the layout the device navigates on is the log's map; its ids are the device's
            self._map_id = {lm.global_id: lm.global_id for lm in in_layer}
            self.sink.set_map(reflectors_of_layout(in_layer), t)
        self._metadata()

    def _on_layout_written(self, event: LayoutWritten, t: int) -> None:
        self.sink.diagnostic("nav350", "layout_written", f"{len(event.ids)} landmarks written "
                             f"into the NAV350's layer {event.layer} and stored", t,
                             level=WARNING, details={"landmarks": len(event.ids),
                                                     "layer": event.layer})
        if not self.session.settings.read_layout or "after" not in self._layouts:
            # the written layout is the map until it is read back
            layout = self._known
            self._map_id = {dev: r.id for dev, r in zip(event.ids, layout, strict=False)}
            self.sink.set_map(layout, t)
        self._metadata()

    def _on_mapping(self, event: MappingDone, t: int) -> None:
        found = tuple((x / 1000.0, y / 1000.0) for x, y in event.landmarks)
        st = event.stand
        self._mapping = {"stand_mm_mdeg": [st.x_mm, st.y_mm, st.phi_mdeg], "mean": st.mean,
                         "error_code": event.error_code,
                         "landmarks_m": [[round(x, 4), round(y, 4)] for x, y in found]}
        if event.error_code == 0:
            self.mapped = found
            self.sink.diagnostic("nav350", "mapping", f"mapping from ({st.x_mm / 1000:.3f}, "
                                 f"{st.y_mm / 1000:.3f}) m, {st.phi_mdeg / 1000:.1f} deg: "
                                 f"{len(found)} landmarks", t, level=INFO,
                                 details=self._mapping)
        self._metadata()

    def _metadata(self) -> None:
        record: dict[str, Any] = {"link": self.link.spec.url, **self._identity}
        if self._applied:
            record["settings"] = self._applied
        if self._clock:
            record["clock"] = self._clock
        if self._map_id is not None:
            record["global_ids"] = {str(k): v for k, v in self._map_id.items()}
        for when, marks in self._layouts.items():
            record[f"layout_{when}"] = marks
        if self._mapping:
            record["mapping"] = self._mapping
        self.sink.set_metadata("device.nav350", record)
