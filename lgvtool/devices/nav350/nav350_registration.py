"""How the NAV350 plugs into lgvtool: its topics, decoders and recorder parts, a
:class:`~lgvtool.devices.device_registry.DeviceFamily`.

Everything the rest of lgvtool needs to know about the device family is here, imported lazily
(this module imports only the registry's declarations and the topic names, so ``lgvtool
--help`` stays light):

- topics: raw traffic on ``/nav350/tx`` and ``/nav350/rx``; decoded data on the shared
  ``/nav/pose`` and ``/nav/reflectors``;
- :func:`stream_decoder`: the resynchronising decoder of either direction;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :data:`RECORD_OPTIONS` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --nav350 tcp://HOST:2112`` and
  its thread.

Its emulator (the virtual NAV350 of ``simulate serve --nav350 PORT``), its simulator link and
the recorder-against-emulator loopback are the simulator's, one layer up
(``sim/emulate/nav350/``, ``sim/nav350_simlink.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, cast

from lgvtool.devices.device_registry import (
    JSON,
    ChoiceValue,
    JSONObject,
    OptionValue,
    RecordOption,
)
from lgvtool.log import topics

if TYPE_CHECKING:
    import threading

    from lgvtool.config import Config, Reflector
    from lgvtool.devices.device_links import Link
    from lgvtool.devices.layout_plan import LayoutPlan
    from lgvtool.devices.link_worker import LinkTiming, LinkWorker
    from lgvtool.devices.logsink import LogSink
    from lgvtool.devices.mcu.mcu_worker import McuWorker
    from lgvtool.devices.nav350.nav350_logdecode import Nav350LogDecoder
    from lgvtool.devices.nav350.nav350_session import Nav350Settings
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
    from lgvtool.devices.recorder import RecordedDevice

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_OPTIONS", "RECORD_URL_OPTION", "RECORD_URL_PARAM", "RX", "TITLE", "TOPICS",
           "TX", "log_decoder", "recorder_link", "recorder_metadata", "recorder_settings",
           "recorder_worker", "stream_decoder"]

DEVICE = "nav350"
#: the device in messages: "the NAV350"
TITLE = "the NAV350"
#: not an odometry source (its speed input comes from the MCU)
ODOMETRY = False
#: ``record``'s option naming the NAV350's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--nav350", "nav350_url"
#: the ``record`` options of the NAV350 (``--nav350 URL``, ``--nav350-cola``)
RECORD_OPTIONS = (
    RecordOption(RECORD_URL_OPTION, RECORD_URL_PARAM, metavar="URL",
                 help="NAV350 over Ethernet: tcp://HOST:2112. Logs in, reads its stored layout "
                      "of --layer into the log (writes one only with --write-layout), navigates "
                      "and polls pose + landmarks at the device's rate; --speed-input sends "
                      "mNPOSSetSpeed."),
    RecordOption("--nav350-cola", "nav350_cola", value=ChoiceValue(("binary", "ascii")),
                 default="binary", show_default=True,
                 help="NAV350 SOPAS dialect: CoLa-B (binary) or CoLa-A (ascii)."),
)
RX, TX = topics.NAV350_RX, topics.NAV350_TX
#: topic -> schema of the NAV350's own topics
TOPICS = {RX: "lgvtool.RawBytes", TX: "lgvtool.RawBytes"}
#: the raw topics the NAV350's traffic is logged on
RAW_TOPICS = (TX, RX)
#: a log without NAV350 traffic has no NAV350 section in the decode report
ABSENT_REPORT: JSONObject | None = None
ABSENT_METADATA: dict[str, dict[str, int]] = {}
DEFAULT_PORT = 2112


def stream_decoder(*, deliver_unknown: bool = False) -> Nav350StreamDecoder:
    """A :class:`~lgvtool.devices.nav350.nav350_stream.Nav350StreamDecoder`."""
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder

    return Nav350StreamDecoder(deliver_unknown=deliver_unknown)


def log_decoder(metadata: Mapping[str, Mapping[str, JSON]]) -> Nav350LogDecoder:
    """A :class:`~lgvtool.devices.nav350.nav350_logdecode.Nav350LogDecoder`; the global ids of
    the log's ``device.nav350`` metadata (if any) map the landmarks to map ids."""
    from lgvtool.devices.nav350.nav350_logdecode import Nav350LogDecoder

    ids = metadata.get("device.nav350", {}).get("global_ids")
    return Nav350LogDecoder(map_id=None if not isinstance(ids, dict) else
                            {int(k): int(cast("int | str", v)) for k, v in ids.items()})


def recorder_settings(options: dict[str, OptionValue], *, layout: LayoutPlan,
                      speed_input: bool, reply_timeout: float, config: Config
                      ) -> RecordedDevice | None:
    """Take the NAV350's :data:`RECORD_OPTIONS` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` with
    :class:`~lgvtool.devices.nav350.nav350_session.Nav350Settings` (``layout``: the shared
    :class:`~lgvtool.devices.layout_plan.LayoutPlan`; ``speed_input``, ``reply_timeout`` s),
    None without ``--nav350``; InputError for a URL that is not TCP or a layer out of range."""
    # the values of RECORD_OPTIONS, of the types their declarations give
    url = cast("str | None", options.pop(RECORD_URL_PARAM, None))
    cola = cast(str, options.pop("nav350_cola", "binary"))
    if url is None:
        return None
    import math

    from lgvtool.devices.device_links import parse_link_url
    from lgvtool.devices.nav350.nav350_session import MapStand, Nav350Settings
    from lgvtool.devices.nav350.nav350_telegrams import LayoutLandmark
    from lgvtool.devices.recorder import RecordedDevice
    from lgvtool.errors import InputError

    if parse_link_url(url).scheme != "tcp":
        raise InputError(f"record: --nav350 {url!r}: the NAV350 is reached over Ethernet, "
                         f"tcp://HOST:{DEFAULT_PORT}")
    if layout.layer > 0xFFFF:
        raise InputError("record: --layer must be 0..65535")
    write = tuple(LayoutLandmark(round(r.x * 1000), round(r.y * 1000), 1, 1,
                                 max(1, round(r.radius * 2000)), (layout.layer,))
                  for r in layout.write)
    stand = None
    if layout.map_at is not None:
        m = layout.map_at
        stand = MapStand(round(m.x * 1000), round(m.y * 1000),
                         round(math.degrees(m.heading) * 1000) % 360_000)
    return RecordedDevice(url, Nav350Settings(dialect=cola, layer=layout.layer,
                                              read_layout=layout.read, write_layout=write,
                                              map_at=stand, speed_input=speed_input,
                                              reply_timeout=reply_timeout))


def recorder_link(url: str) -> Link:
    """The NAV350's link at ``url`` (tcp://HOST:2112; :func:`recorder_settings` refuses
    others)."""
    from lgvtool.devices.device_links import NAV200_SERIAL_DEFAULTS, open_link

    return open_link(url, NAV200_SERIAL_DEFAULTS)


def recorder_metadata(device: RecordedDevice | None) -> JSONObject:
    """The NAV350's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded)."""
    return {"nav350_url": None if device is None else device.url}


def recorder_worker(link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                    settings: object, config: Config, *, mcu: LinkWorker | None = None,
                    warn: Callable[[str], None] | None = None) -> LinkWorker:
    """The recorder thread of one NAV350 link (``settings``: its
    :class:`~lgvtool.devices.nav350.nav350_session.Nav350Settings`, made by
    :func:`recorder_settings`; speed input from ``mcu``, the MCU's worker)."""
    from lgvtool.devices.nav350.nav350_session import Nav350Session, Nav350Settings
    from lgvtool.devices.nav350.nav350_worker import Nav350Worker

    s = cast("Nav350Settings", settings) if settings is not None else Nav350Settings()
    # the landmarks written (if asked for) in the order written: the device's new ids map to
    # these reflectors until the layout is read back
    known = tuple(r for r in _written(s))
    return Nav350Worker(link, sink, stop, timing, Nav350Session(s), vehicle=config.vehicle,
                        known_map=known, mcu=cast("McuWorker | None", mcu), warn=warn)


def _written(settings: Nav350Settings) -> tuple[Reflector, ...]:
    """The reflectors of a requested layout write, as the log's map (ids from 1 in the order
    written; the device's own ids replace them once the layout is read back)."""
    from lgvtool.config import Reflector

    return tuple(Reflector(i + 1, m.x_mm / 1000.0, m.y_mm / 1000.0, m.size_mm / 2000.0,
                           settings.layer) for i, m in enumerate(settings.write_layout))
