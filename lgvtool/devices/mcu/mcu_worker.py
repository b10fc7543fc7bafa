"""The recorder's MCU thread: reads the MCU frame stream into /mcu/rx, /mcu/frame and gaps."""

from __future__ import annotations

import threading
import time
from typing import Any

from lgvtool.config import Vehicle
from lgvtool.devices.device_links import Link
from lgvtool.devices.link_worker import READ_SLICE, LinkTiming, LinkWorker
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu.mcu_session import McuLink, Motion
from lgvtool.log import topics
from lgvtool.log.messages import mcu_frame_message
from lgvtool.timestamps import stamp as to_stamp
from lgvtool.wire.decode_events import ERROR, INFO

__all__ = ["McuWorker"]


class McuWorker(LinkWorker):
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
        data = self.link.read(READ_SLICE)
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
        stamp = to_stamp(t)
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
