"""How the NAV200 plugs into lgvtool: its topics, log decoder, emulator and recorder worker.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only the topic names):

- topics: raw traffic on ``/nav200/tx`` and ``/nav200/rx``; decoded poses on the shared
  ``/nav/pose``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :func:`emulator`: the virtual NAV200 of ``simulate serve --nav PORT``;
- :func:`recorder_worker`: the thread of ``record --nav URL``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.log import topics

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "RAW_TOPICS", "TOPICS", "emulator",
           "log_decoder", "recorder_worker"]

DEVICE = "nav200"
#: the raw topics the NAV200's traffic is logged on
RAW_TOPICS = (topics.NAV_TX, topics.NAV_RX)
#: topic -> schema of the NAV200's own topics
TOPICS = {topics.NAV_TX: "lgvtool.RawBytes", topics.NAV_RX: "lgvtool.RawBytes"}
#: the decode report's section, and its metadata, for a log without NAV200 traffic
ABSENT_REPORT: dict[str, Any] | None = {"replies": 0, "poses": 0, "requests": 0, "stats": {},
                                        "request_stats": {}}
ABSENT_METADATA: dict[str, dict[str, int]] = {"nav200": {}, "nav200_requests": {}}


def log_decoder(metadata: Mapping[str, Any]) -> Any:
    """A :class:`~lgvtool.devices.nav200.nav200_logdecode.Nav200LogDecoder` (``metadata``:
    the log's)."""
    from lgvtool.devices.nav200.nav200_logdecode import Nav200LogDecoder

    return Nav200LogDecoder()


def emulator(playback: Any) -> Any:
    """A :class:`~lgvtool.devices.nav200.nav200_emulator.VirtualNav200` playing ``playback``."""
    from lgvtool.devices.nav200.nav200_emulator import VirtualNav200

    return VirtualNav200(playback)


def recorder_worker(link: Any, sink: Any, stop: Any, timing: Any, settings: Any, config: Any,
                    *, mcu: Any = None, warn: Any = None) -> Any:
    """The recorder thread of one NAV200 link: a :class:`Nav200Session` with ``settings``
    (:class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings`), speed input from ``mcu``."""
    from lgvtool.devices.nav200.nav200_session import Nav200Session
    from lgvtool.devices.nav200.nav200_worker import Nav200Worker

    return Nav200Worker(link, sink, stop, timing, Nav200Session(settings), vehicle=config.vehicle,
                     known_map=config.reflectors, mcu=mcu, warn=warn)
