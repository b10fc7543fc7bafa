"""How the MCU plugs into lgvtool: its topics, log decoder, emulator and recorder parts.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only click and
the topic names):

- topics: raw traffic on ``/mcu/rx``; decoded frames on ``/mcu/frame``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :func:`serve_options` / :func:`emulator`: the virtual MCU of ``simulate serve --mcu PORT``;
- :func:`record_options` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --mcu URL`` and its thread.
  The MCU is the recorder's odometry source (:data:`ODOMETRY`): the laser families' speed
  input comes from its worker.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import click

from lgvtool.devices.device_registry import SERVE_PORT_HELP
from lgvtool.log import topics

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_URL_OPTION", "RECORD_URL_PARAM", "SERVE_DEFAULT", "SERVE_PARAM", "TITLE",
           "TOPICS", "emulator", "log_decoder", "record_options", "recorder_link",
           "recorder_metadata", "recorder_settings", "recorder_worker", "serve_emulator",
           "serve_options"]

DEVICE = "mcu"
#: the device in messages: "the MCU"
TITLE = "the MCU"
#: the recorder's odometry source (its worker is the laser workers' speed input)
ODOMETRY = True
#: ``record``'s option naming the MCU's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--mcu", "mcu_url"
#: ``simulate serve``'s parameter of the MCU's port, and where it streams by default
SERVE_PARAM, SERVE_DEFAULT = "mcu", "pty"
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


def emulator_class() -> Any:
    """The class of :func:`emulator` (its ``FAULT_KINDS``: the faults it takes)."""
    from lgvtool.devices.mcu.mcu_emulator import VirtualMcu

    return VirtualMcu


def serve_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``simulate serve`` option of the MCU (``--mcu PORT``)."""
    return click.option("--mcu", SERVE_PARAM, default=SERVE_DEFAULT, show_default=True,
                        metavar="PORT", help=f"Where the virtual MCU streams: {SERVE_PORT_HELP}"
                        )(f)


def serve_emulator(playback: Any, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, Any]:
    """``simulate serve``'s MCU: the port ``spec`` (None: not served) and its :func:`emulator`,
    made even when not served (its stream decides when the run has been played)."""
    return spec, emulator(playback, loop=loop)


def record_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``record`` option of the MCU (``--mcu URL``)."""
    return click.option("--mcu", RECORD_URL_PARAM, metavar="URL",
                        help="MCU link: serial:///dev/ttyUSB0?baud=115200 (default 115200 8N1) "
                             "or tcp://HOST:PORT.")(f)


def recorder_settings(options: dict[str, Any], *, layout: Any, speed_input: bool,
                      reply_timeout: float, config: Any) -> Any:
    """Take the MCU's :func:`record_options` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` (no settings of its own), None without
    ``--mcu`` (the shared options are the laser families')."""
    from lgvtool.devices.recorder import RecordedDevice

    url = options.pop(RECORD_URL_PARAM, None)
    return None if url is None else RecordedDevice(url)


def recorder_link(url: str) -> Any:
    """The MCU's link at ``url`` (serial defaults 115200 8N1)."""
    from lgvtool.devices.device_links import MCU_SERIAL_DEFAULTS, open_link

    return open_link(url, MCU_SERIAL_DEFAULTS)


def recorder_metadata(device: Any) -> dict[str, Any]:
    """The MCU's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded)."""
    return {"mcu_url": None if device is None else device.url}


def recorder_worker(link: Any, sink: Any, stop: Any, timing: Any, settings: Any, config: Any,
                    *, mcu: Any = None, warn: Any = None) -> Any:
    """The recorder thread of one MCU link (``settings``, ``mcu``: unused)."""
    from lgvtool.devices.mcu.mcu_worker import McuWorker

    return McuWorker(link, sink, stop, timing, config.vehicle, warn=warn)
