"""The recorder's NAV200 thread: runs :class:`Nav200Session` over its link into the log."""

from __future__ import annotations

import threading
import time
from typing import Any

from lgvtool.config import Reflector, Vehicle
from lgvtool.devices.device_links import Link
from lgvtool.devices.link_worker import READ_SLICE, LinkTiming, LinkWorker
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu.mcu_session import head_velocity
from lgvtool.devices.mcu.mcu_worker import McuWorker
from lgvtool.devices.nav200.nav200_session import (
    DeviceIdentity,
    DeviceSilent,
    MapUploaded,
    Nav200Session,
    PoseReceived,
    PositioningEntered,
)
from lgvtool.log import topics
from lgvtool.log.messages import nav_pose_message
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import INFO, DecodeEvent

__all__ = ["NavWorker"]


class NavWorker(LinkWorker):
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
        wait = min(READ_SLICE, max(0.0, self.session.next_deadline(now) - time.monotonic()))
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
                                  nav_pose_message(event.pose, stamp(t)), t)
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
