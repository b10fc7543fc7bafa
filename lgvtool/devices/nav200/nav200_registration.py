"""How the NAV200 plugs into lgvtool: its topics, log decoder, emulator and recorder parts.

Imported lazily by :mod:`lgvtool.devices.device_registry` (this module imports only click and
the topic names):

- topics: raw traffic on ``/nav200/tx`` and ``/nav200/rx``; decoded poses on the shared
  ``/nav/pose``;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :func:`serve_options` / :func:`emulator`: the virtual NAV200 of ``simulate serve --nav PORT``;
- :func:`record_options` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --nav URL`` (polled every
  ``--poll-period`` s) and its thread.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import click

from lgvtool.devices.device_registry import SERVE_PORT_HELP
from lgvtool.log import topics
from lgvtool.options import positive

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_URL_OPTION", "RECORD_URL_PARAM", "SERVE_DEFAULT", "SERVE_PARAM", "TITLE",
           "TOPICS", "emulator", "log_decoder", "record_options", "recorder_link",
           "recorder_metadata", "recorder_settings", "recorder_worker", "serve_emulator",
           "serve_options"]

DEVICE = "nav200"
#: the device in messages: "the NAV200"
TITLE = "the NAV200"
#: not an odometry source (its speed input comes from the MCU)
ODOMETRY = False
#: ``record``'s option naming the NAV200's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--nav", "nav_url"
#: ``simulate serve``'s parameter of the NAV200's port, and where it listens by default
SERVE_PARAM, SERVE_DEFAULT = "nav", "pty"
#: the defaults of :func:`record_options`: pose request period s, yaw-rate unit of Pw
POLL_PERIOD, OMEGA_UNITS = 0.45, "rev"
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


def emulator_class() -> Any:
    """The class of :func:`emulator` (its ``FAULT_KINDS``: the faults it takes)."""
    from lgvtool.devices.nav200.nav200_emulator import VirtualNav200

    return VirtualNav200


def serve_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``simulate serve`` option of the NAV200 (``--nav PORT``)."""
    return click.option("--nav", SERVE_PARAM, default=SERVE_DEFAULT, show_default=True,
                        metavar="PORT",
                        help=f"Where the virtual NAV200 listens: {SERVE_PORT_HELP}")(f)


def serve_emulator(playback: Any, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, Any]:
    """``simulate serve``'s NAV200: the port ``spec`` (None: not served) and its
    :func:`emulator` (made even when not served; ``loop``: unused, it only answers)."""
    return spec, emulator(playback)


def record_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``record`` options of the NAV200 (``--nav URL``, ``--poll-period``,
    ``--omega-units``, ``--sliding-mean``, ``--action-radii``, ``--nearest``)."""
    metres = positive(1000.0)
    for option in reversed((
        click.option("--nav", RECORD_URL_PARAM, metavar="URL",
                     help="NAV200 link: serial:///dev/ttyS0?baud=19200&parity=E (default 19200 "
                          "8E1) or tcp://HOST:PORT."),
        click.option("--poll-period", type=positive(3600.0), default=POLL_PERIOD,
                     show_default=True, metavar="S", help="NAV200 pose request period, s."),
        click.option("--omega-units", type=click.Choice(["rev", "half-deg"]),
                     default=OMEGA_UNITS, show_default=True,
                     help="Pw yaw-rate unit: 'rev' = 65536 per revolution per s, 'half-deg' = "
                          "0.5 deg/s."),
        click.option("--sliding-mean", type=click.IntRange(1, 255), metavar="N",
                     help="Enter positioning with PN N (sliding mean over N poses) instead of "
                          "PA."),
        click.option("--action-radii", type=(metres, metres), metavar="RMIN RMAX",
                     help="Set the NAV200 action radii (PO), m."),
        click.option("--nearest", type=click.IntRange(1, 255), metavar="N",
                     help="Use the N nearest reflectors (PC)."),
    )):
        f = option(f)
    return f


def recorder_settings(options: dict[str, Any], *, layout: Any, speed_input: bool,
                      reply_timeout: float, config: Any) -> Any:
    """Take the NAV200's :func:`record_options` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` with
    :class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings` (``layout``: the shared
    :class:`~lgvtool.devices.layout_plan.LayoutPlan`, whose read is the NAV200's map upload;
    ``speed_input``, ``reply_timeout`` s), None without ``--nav``; InputError for action radii
    out of order, and for a layout write or a mapping run, which the NAV200 recorder does not
    do (nothing is ever written to a NAV200)."""
    from lgvtool.devices.nav200.nav200_session import Nav200Settings
    from lgvtool.devices.recorder import RecordedDevice
    from lgvtool.errors import InputError
    from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S, OMEGA_UNITS_PER_RAD_S_HALF_DEG

    url = options.pop(RECORD_URL_PARAM, None)
    poll_period = options.pop("poll_period", POLL_PERIOD)
    omega_units = options.pop("omega_units", OMEGA_UNITS)
    sliding_mean = options.pop("sliding_mean", None)
    action_radii = options.pop("action_radii", None)
    nearest = options.pop("nearest", None)
    if action_radii is not None and action_radii[0] >= action_radii[1]:
        raise InputError("record: --action-radii RMIN must be below RMAX")
    if url is None:
        return None
    if layout.write or layout.map_at is not None:
        what = "--write-layout" if layout.write else "--map-at"
        raise InputError(f"record: {what} is for the NAV350; the NAV200 recorder only reads "
                         "its stored layout (nothing is written to a NAV200)")
    return RecordedDevice(url, Nav200Settings(
        poll_period=poll_period, reply_timeout=reply_timeout, layer=layout.layer,
        sliding_mean=sliding_mean, action_radii=action_radii, nearest_reflectors=nearest,
        upload_map=layout.read, speed_input=speed_input,
        omega_scale=OMEGA_UNITS_PER_RAD_S if omega_units == "rev"
        else OMEGA_UNITS_PER_RAD_S_HALF_DEG,
    ))


def recorder_link(url: str) -> Any:
    """The NAV200's link at ``url`` (serial defaults 19200 8E1)."""
    from lgvtool.devices.device_links import NAV200_SERIAL_DEFAULTS, open_link

    return open_link(url, NAV200_SERIAL_DEFAULTS)


def recorder_metadata(device: Any) -> dict[str, Any]:
    """The NAV200's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded): the URL and the
    poll period, s."""
    if device is None:
        return {"nav_url": None, "poll_period_s": None}
    from lgvtool.devices.nav200.nav200_session import Nav200Settings

    settings = device.settings if device.settings is not None else Nav200Settings()
    return {"nav_url": device.url, "poll_period_s": settings.poll_period}


def recorder_worker(link: Any, sink: Any, stop: Any, timing: Any, settings: Any, config: Any,
                    *, mcu: Any = None, warn: Any = None) -> Any:
    """The recorder thread of one NAV200 link: a :class:`Nav200Session` with ``settings``
    (:class:`~lgvtool.devices.nav200.nav200_session.Nav200Settings`), speed input from ``mcu``."""
    from lgvtool.devices.nav200.nav200_session import Nav200Session, Nav200Settings
    from lgvtool.devices.nav200.nav200_worker import Nav200Worker

    s = settings if settings is not None else Nav200Settings()
    return Nav200Worker(link, sink, stop, timing, Nav200Session(s), vehicle=config.vehicle,
                     known_map=config.reflectors, mcu=mcu, warn=warn)
