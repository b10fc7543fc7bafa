"""The recorder's MCU thread: reads the MCU frame stream into /mcu/rx, /mcu/frame and gaps.

The bytes are decoded by the MCU's log decoder through the one decoding path
(:func:`lgvtool.devices.log_decoding.decode_chunk`), over the worker's
:class:`~lgvtool.devices.mcu.mcu_session.McuLink`, which also tracks the vehicle's motion.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

from lgvtool.config import Vehicle
from lgvtool.devices.device_links import Link
from lgvtool.devices.link_worker import READ_SLICE, LinkTiming, LinkWorker
from lgvtool.devices.log_decoding import decode_chunk
from lgvtool.devices.logsink import LogSink
from lgvtool.devices.mcu.mcu_logdecode import McuLogDecoder
from lgvtool.devices.mcu.mcu_session import McuLink, Motion
from lgvtool.json_types import JSONRecord
from lgvtool.log import topics
from lgvtool.wire.decode_events import ERROR, INFO, DecodeEvent

__all__ = ["McuWorker"]


class McuWorker(LinkWorker):
    """Reads the MCU frame stream continuously: /mcu/rx, /mcu/frame, gaps to /diagnostics."""

    device = "mcu"

    def __init__(self, link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                 vehicle: Vehicle, warn: Callable[[str], None] | None = None) -> None:
        super().__init__(link, sink, stop, timing, warn)
        self.decoder = McuLink(vehicle)
        self.log_decoder = McuLogDecoder(self.decoder)
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
            # reopened after the back-off, like every reopen: the link of a device that stays
            # silent is never healthy, so it is reopened every reconnect_after s plus a wait
            # growing to backoff_max
            if (self._silent and quiet >= self.timing.reconnect_after
                    and self._quiet_reconnect()):
                self._opened_at = time.monotonic()
            return
        self._received()
        t = time.time_ns()
        self.sink.raw("mcu", "rx", data, t)
        if self._silent:
            gap = now - self._last_data
            self.diag("device_back", f"MCU data again after {gap:.1f} s", level=INFO,
                      gap_s=round(gap, 3))
            self._silent = False
        self._last_data = now
        self.state = "ok"
        decode_chunk(self.log_decoder, topics.MCU_RX, data, t, self)
        if self.decoder.motion is not None:
            self.motion = (now, self.decoder.motion)

    def message(self, topic: str, message: JSONRecord, t_ns: int) -> None:
        """A decoded frame (the worker is its decoder's output): to the sink; the first one
        also describes the MCU in the metadata."""
        self.sink.message(topic, message, t_ns)
        if not self._described:
            self._described = True
            self.sink.set_metadata("device.mcu", {
                "link": self.link.spec.url, "frame_version": message["version"],
                "gyro_scale_deg_s": message["gyro_scale"]})

    def event(self, event: DecodeEvent, t_ns: int) -> None:
        """A decoder event: to the sink."""
        self.sink.event(event, t_ns)

    def _flush_events(self, t: int) -> None:
        for event in self.decoder.pop_events():
            self.sink.event(event, t)
