"""The recorder's NAV200 thread: runs :class:`Nav200Session` over its link into the log."""

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
from lgvtool.devices.nav200.nav200_session import (
    DeviceIdentity,
    MapUploaded,
    Nav200Session,
    PoseReceived,
)
from lgvtool.devices.session_events import DeviceSilent, PositioningEntered
from lgvtool.log import topics
from lgvtool.log.messages import nav_pose_message
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import INFO, DecodeEvent

__all__ = ["Nav200Worker"]


class Nav200Worker(SessionWorker):
    """Runs the NAV200 host session over its link: /nav200/tx, /nav200/rx, /nav/pose, the map,
    the device identity, and every error reply and timeout on /diagnostics."""

    device = "nav200"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 session: Nav200Session, *, vehicle: Vehicle,
                 known_map: tuple[Reflector, ...] = (), mcu: McuWorker | None = None,
                 warn: Callable[[str], None] | None = None) -> None:
        super().__init__(link, sink, stop, timing, session, vehicle=vehicle, mcu=mcu, warn=warn)
        self.session: Nav200Session = session
        self._radius = {r.id: r.radius for r in known_map}
        self.identity: dict[str, Any] = {}
        self.applied: dict[str, Any] = {}
        self.map: tuple[Reflector, ...] | None = None

    def _handle_events(self, t: int) -> None:
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
                # reopened after the back-off, like every reopen; a new device session
                if self._quiet_reconnect():
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
