"""How the NAV200 plugs into lgvtool: its topics, log decoder and recorder parts, a
:class:`~lgvtool.devices.device_registry.DeviceFamily`.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only the
registry's declarations and the topic names):

- topics: raw traffic on ``/nav200/tx`` and ``/nav200/rx``; decoded poses on the shared
  ``/nav/pose``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :data:`RECORD_OPTIONS` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --nav URL`` (polled every
  ``--poll-period`` s) and its thread.

Its emulator (the virtual NAV200 of ``simulate serve --nav PORT``) and its simulator link are
the simulator's, one layer up (``sim/emulate/nav200/``, ``sim/nav200_simlink.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, cast

from lgvtool.devices.device_registry import (
    JSON,
    ChoiceValue,
    IntegerValue,
    JSONObject,
    NumberValue,
    OptionValue,
    PairValue,
    RecordOption,
)
from lgvtool.log import topics

if TYPE_CHECKING:
    import threading

    from lgvtool.config import Config
    from lgvtool.devices.device_links import Link
    from lgvtool.devices.layout_plan import LayoutPlan
    from lgvtool.devices.link_worker import LinkTiming, LinkWorker
    from lgvtool.devices.logsink import LogSink
    from lgvtool.devices.mcu.mcu_worker import McuWorker
    from lgvtool.devices.nav200.nav200_logdecode import Nav200LogDecoder
    from lgvtool.devices.nav200.nav200_session import Nav200Settings
    from lgvtool.devices.recorder import RecordedDevice

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_OPTIONS", "RECORD_URL_OPTION", "RECORD_URL_PARAM", "TITLE", "TOPICS",
           "log_decoder", "recorder_link", "recorder_metadata", "recorder_settings",
           "recorder_worker"]

DEVICE = "nav200"
#: the device in messages: "the NAV200"
TITLE = "the NAV200"
#: not an odometry source (its speed input comes from the MCU)
ODOMETRY = False
#: ``record``'s option naming the NAV200's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--nav", "nav_url"
#: the defaults of :data:`RECORD_OPTIONS`: pose request period s, yaw-rate unit of Pw
POLL_PERIOD, OMEGA_UNITS = 0.45, "rev"
_METRES = NumberValue(0.0, 1000.0, min_open=True)
#: the ``record`` options of the NAV200 (``--nav URL``, ``--poll-period``, ``--omega-units``,
#: ``--sliding-mean``, ``--action-radii``, ``--nearest``)
RECORD_OPTIONS = (
    RecordOption(RECORD_URL_OPTION, RECORD_URL_PARAM, metavar="URL",
                 help="NAV200 link: serial:///dev/ttyS0?baud=19200&parity=E (default 19200 8E1) "
                      "or tcp://HOST:PORT."),
    RecordOption("--poll-period", "poll_period", value=NumberValue(0.0, 3600.0, min_open=True),
                 default=POLL_PERIOD, show_default=True, metavar="S",
                 help="NAV200 pose request period, s."),
    RecordOption("--omega-units", "omega_units", value=ChoiceValue(("rev", "half-deg")),
                 default=OMEGA_UNITS, show_default=True,
                 help="Pw yaw-rate unit: 'rev' = 65536 per revolution per s, 'half-deg' = 0.5 "
                      "deg/s."),
    RecordOption("--sliding-mean", "sliding_mean", value=IntegerValue(1, 255), metavar="N",
                 help="Enter positioning with PN N (sliding mean over N poses) instead of PA."),
    RecordOption("--action-radii", "action_radii", value=PairValue(_METRES),
                 metavar="RMIN RMAX", help="Set the NAV200 action radii (PO), m."),
    RecordOption("--nearest", "nearest", value=IntegerValue(1, 255), metavar="N",
                 help="Use the N nearest reflectors (PC)."),
)
#: the raw topics the NAV200's traffic is logged on
RAW_TOPICS = (topics.NAV_TX, topics.NAV_RX)
#: topic -> schema of the NAV200's own topics
TOPICS = {topics.NAV_TX: "lgvtool.RawBytes", topics.NAV_RX: "lgvtool.RawBytes"}
#: the decode report's section, and its metadata, for a log without NAV200 traffic
ABSENT_REPORT: JSONObject | None = {"replies": 0, "poses": 0, "requests": 0, "stats": {},
                                   "request_stats": {}}
ABSENT_METADATA: dict[str, dict[str, int]] = {"nav200": {}, "nav200_requests": {}}


def log_decoder(metadata: Mapping[str, Mapping[str, JSON]]) -> Nav200LogDecoder:
    """A :class:`~lgvtool.devices.nav200.nav200_logdecode.Nav200LogDecoder` (``metadata``:
    the log's)."""
    from lgvtool.devices.nav200.nav200_logdecode import Nav200LogDecoder

    return Nav200LogDecoder()


def recorder_settings(options: dict[str, OptionValue], *, layout: LayoutPlan,
                      speed_input: bool, reply_timeout: float, config: Config
                      ) -> RecordedDevice | None:
    """Take the NAV200's :data:`RECORD_OPTIONS` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` with
    :class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings` (``layout``: the shared
    :class:`~lgvtool.devices.layout_plan.LayoutPlan`, whose read is the NAV200's map upload;
    ``speed_input``, ``reply_timeout`` s; a layout write is a download of the plan's reflectors
    numbered by their ids), None without ``--nav``; InputError for action radii out of order,
    reflector ids a NAV200 cannot number (0..254) and a mapping run (the NAV200 recorder does
    not map)."""
    from lgvtool.devices.nav200.nav200_session import Nav200Settings
    from lgvtool.devices.recorder import RecordedDevice
    from lgvtool.errors import InputError
    from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S, OMEGA_UNITS_PER_RAD_S_HALF_DEG

    # the values of RECORD_OPTIONS, of the types their declarations give
    url = cast("str | None", options.pop(RECORD_URL_PARAM, None))
    poll_period = cast(float, options.pop("poll_period", POLL_PERIOD))
    omega_units = options.pop("omega_units", OMEGA_UNITS)
    sliding_mean = cast("int | None", options.pop("sliding_mean", None))
    action_radii = cast("tuple[float, float] | None", options.pop("action_radii", None))
    nearest = cast("int | None", options.pop("nearest", None))
    if action_radii is not None and action_radii[0] >= action_radii[1]:
        raise InputError("record: --action-radii RMIN must be below RMAX")
    if url is None:
        return None
    if layout.map_at is not None:
        raise InputError("record: --map-at is for the NAV350; the NAV200 recorder does not map")
    bad = [r.id for r in layout.write if not 0 <= r.id <= 254]
    if bad:
        raise InputError(f"record: --write-layout: a NAV200 numbers its reflectors 0..254; "
                         f"reflector id {bad[0]} cannot be written")
    return RecordedDevice(url, Nav200Settings(
        poll_period=poll_period, reply_timeout=reply_timeout, layer=layout.layer,
        sliding_mean=sliding_mean, action_radii=action_radii, nearest_reflectors=nearest,
        upload_map=layout.read, speed_input=speed_input,
        write_layout=tuple((r.id, r.x, r.y) for r in layout.write),
        omega_scale=OMEGA_UNITS_PER_RAD_S if omega_units == "rev"
        else OMEGA_UNITS_PER_RAD_S_HALF_DEG,
    ))


def recorder_link(url: str) -> Link:
    """The NAV200's link at ``url`` (serial defaults 19200 8E1)."""
    from lgvtool.devices.device_links import NAV200_SERIAL_DEFAULTS, open_link

    return open_link(url, NAV200_SERIAL_DEFAULTS)


def recorder_metadata(device: RecordedDevice | None) -> JSONObject:
    """The NAV200's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded): the URL and the
    poll period, s."""
    if device is None:
        return {"nav_url": None, "poll_period_s": None}
    from lgvtool.devices.nav200.nav200_session import Nav200Settings

    settings = device.settings if device.settings is not None else Nav200Settings()
    return {"nav_url": device.url, "poll_period_s": settings.poll_period}


def recorder_worker(link: Link, sink: LogSink, stop: threading.Event, timing: LinkTiming,
                    settings: object, config: Config, *, mcu: LinkWorker | None = None,
                    warn: Callable[[str], None] | None = None) -> LinkWorker:
    """The recorder thread of one NAV200 link: a :class:`Nav200Session` with ``settings``
    (:class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings`, made by
    :func:`recorder_settings`), speed input from ``mcu`` (the MCU's worker)."""
    from lgvtool.devices.nav200.nav200_session import Nav200Session, Nav200Settings
    from lgvtool.devices.nav200.nav200_worker import Nav200Worker

    s = cast("Nav200Settings", settings) if settings is not None else Nav200Settings()
    return Nav200Worker(link, sink, stop, timing, Nav200Session(s), vehicle=config.vehicle,
                        known_map=config.reflectors, mcu=cast("McuWorker | None", mcu),
                        warn=warn)
