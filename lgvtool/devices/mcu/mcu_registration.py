"""How the MCU plugs into lgvtool: its topics, log decoder, emulator and recorder worker.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only the topic names):

- topics: raw traffic on ``/mcu/rx``; decoded frames on ``/mcu/frame``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :func:`emulator`: the virtual MCU of ``simulate serve --mcu PORT``;
- :func:`recorder_worker`: the thread of ``record --mcu URL``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.log import topics

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "RAW_TOPICS", "TOPICS", "emulator",
           "log_decoder", "recorder_worker"]

DEVICE = "mcu"
#: the raw topics the MCU's traffic is logged on
RAW_TOPICS = (topics.MCU_RX,)
#: topic -> schema of the MCU's own topics
TOPICS = {topics.MCU_RX: "lgvtool.RawBytes", topics.MCU_FRAME: "lgvtool.McuFrame"}
#: the decode report's section, and its metadata, for a log without MCU traffic
ABSENT_REPORT: dict[str, Any] | None = {"frames": 0, "stats": {}}
ABSENT_METADATA: dict[str, dict[str, int]] = {"mcu": {}}


def log_decoder(metadata: Mapping[str, Any]) -> Any:
    """A :class:`~lgvtool.devices.mcu.mcu_logdecode.McuLogDecoder` (``metadata``: the log's)."""
    from lgvtool.devices.mcu.mcu_logdecode import McuLogDecoder

    return McuLogDecoder()


def emulator(playback: Any, *, loop: bool = False) -> Any:
    """A :class:`~lgvtool.devices.mcu.mcu_emulator.VirtualMcu` playing ``playback``."""
    from lgvtool.devices.mcu.mcu_emulator import VirtualMcu

    return VirtualMcu(playback, loop=loop)


def recorder_worker(link: Any, sink: Any, stop: Any, timing: Any, settings: Any, config: Any,
                    *, mcu: Any = None, warn: Any = None) -> Any:
    """The recorder thread of one MCU link (``settings``, ``mcu``: unused)."""
    from lgvtool.devices.mcu.mcu_worker import McuWorker

    return McuWorker(link, sink, stop, timing, config.vehicle, warn=warn)
