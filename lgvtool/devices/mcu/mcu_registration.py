"""How the MCU plugs into lgvtool: its topics, log decoder and recorder parts, a
:class:`~lgvtool.devices.device_registry.DeviceFamily`.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only the
registry's declarations and the topic names):

- topics: raw traffic on ``/mcu/rx``; decoded frames on ``/mcu/frame``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :data:`RECORD_OPTIONS` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --mcu URL`` and its thread.
  The MCU is the recorder's odometry source (:data:`ODOMETRY`): the laser families' speed
  input comes from its worker.

Its emulator (the virtual MCU of ``simulate serve --mcu PORT``) and its simulator link are the
simulator's, one layer up (``sim/emulate/mcu/``, ``sim/mcu_simlink.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING

from lgvtool.devices.device_registry import JSON, JSONObject, OptionValue, RecordOption
from lgvtool.log import topics

if TYPE_CHECKING:
    import threading

    from lgvtool.config import Config
    from lgvtool.devices.device_links import Link
    from lgvtool.devices.layout_plan import LayoutPlan
    from lgvtool.devices.link_worker import LinkTiming, LinkWorker
    from lgvtool.devices.logsink import LogSink
    from lgvtool.devices.mcu.mcu_logdecode import McuLogDecoder
    from lgvtool.devices.recorder import RecordedDevice

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_OPTIONS", "RECORD_URL_OPTION", "RECORD_URL_PARAM", "TITLE", "TOPICS",
           "log_decoder", "recorder_link", "recorder_metadata", "recorder_settings",
           "recorder_worker"]

DEVICE = "mcu"
#: the device in messages: "the MCU"
TITLE = "the MCU"
#: the recorder's odometry source (its worker is the laser workers' speed input)
ODOMETRY = True
#: ``record``'s option naming the MCU's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--mcu", "mcu_url"
#: the ``record`` option of the MCU (``--mcu URL``)
RECORD_OPTIONS = (
    RecordOption(RECORD_URL_OPTION, RECORD_URL_PARAM, metavar="URL",
                 help="MCU link: serial:///dev/ttyUSB0?baud=115200 (default 115200 8N1) or "
                      "tcp://HOST:PORT."),
)
#: the raw topics the MCU's traffic is logged on
RAW_TOPICS = (topics.MCU_RX,)
#: topic -> schema of the MCU's own topics
TOPICS = {topics.MCU_RX: "lgvtool.RawBytes", topics.MCU_FRAME: "lgvtool.McuFrame"}
#: the decode report's section, and its metadata, for a log without MCU traffic
ABSENT_REPORT: JSONObject | None = {"frames": 0, "stats": {}}
ABSENT_METADATA: dict[str, dict[str, int]] = {"mcu": {}}


def log_decoder(metadata: Mapping[str, Mapping[str, JSON]]) -> McuLogDecoder:
    """A :class:`~lgvtool.devices.mcu.mcu_logdecode.McuLogDecoder` (``metadata``: the log's)."""
    from lgvtool.devices.mcu.mcu_logdecode import McuLogDecoder

    return McuLogDecoder()


def recorder_settings(options: dict[str, OptionValue], *, layout: LayoutPlan,
                      speed_input: bool, reply_timeout: float, config: Config
                      ) -> RecordedDevice | None:
    """Take the MCU's :data:`RECORD_OPTIONS` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` (no settings of its own), None without
    ``--mcu`` (the shared options are the laser families')."""
    from lgvtool.devices.recorder import RecordedDevice

    url = options.pop(RECORD_URL_PARAM, None)
    return None if url is None else RecordedDevice(str(url))


def recorder_link(url: str) -> Link:
    """The MCU's link at ``url`` (serial defaults 115200 8N1)."""
    from lgvtool.devices.device_links import MCU_SERIAL_DEFAULTS, open_link

    return open_link(url, MCU_SERIAL_DEFAULTS)


def recorder_metadata(device: RecordedDevice | None) -> JSONObject:
    """The MCU's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded)."""
    return {"mcu_url": None if device is None else device.url}


def recorder_worker(link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                    settings: object, config: Config, *, mcu: LinkWorker | None = None,
                    warn: Callable[[str], None] | None = None) -> LinkWorker:
    """The recorder thread of one MCU link (``settings``, ``mcu``: unused)."""
    from lgvtool.devices.mcu.mcu_worker import McuWorker

    return McuWorker(link, sink, stop, timing, config.vehicle, warn=warn)
