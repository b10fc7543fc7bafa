"""How the NAV350 plugs into lgvtool: its topics, decoders, emulator and recorder options.

Everything the rest of lgvtool needs to know about the device family is here, imported lazily
(this module imports only click and the topic names, so ``lgvtool --help`` stays light):

- topics: raw traffic on ``/nav350/tx`` and ``/nav350/rx``; decoded data on the shared
  ``/nav/pose`` and ``/nav/reflectors``;
- :func:`stream_decoder`: the resynchronising decoder of either direction;
- :func:`log_decoder`: its :class:`~lgvtool.devices.log_decoding.LogDecoder`;
- :func:`serve_options` / :func:`serve_emulator` / :func:`emulator`: the virtual NAV350 of
  ``simulate serve --nav350 PORT``;
- :func:`record_options` / :func:`recorder_settings` / :func:`recorder_link` /
  :func:`recorder_worker` / :func:`recorder_metadata`: ``record --nav350 tcp://HOST:2112`` and
  its thread.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import click

from lgvtool.log import topics

__all__ = ["ABSENT_METADATA", "ABSENT_REPORT", "DEVICE", "ODOMETRY", "RAW_TOPICS",
           "RECORD_URL_OPTION", "RECORD_URL_PARAM", "RX", "SERVE_DEFAULT", "SERVE_PARAM", "TITLE",
           "TOPICS", "TX", "emulator", "log_decoder", "record_options", "recorder_link",
           "recorder_metadata", "recorder_settings", "recorder_worker", "serve_emulator",
           "serve_options", "split_port_spec", "stream_decoder"]

DEVICE = "nav350"
#: the device in messages: "the NAV350"
TITLE = "the NAV350"
#: not an odometry source (its speed input comes from the MCU)
ODOMETRY = False
#: ``record``'s option naming the NAV350's link, and its parameter name
RECORD_URL_OPTION, RECORD_URL_PARAM = "--nav350", "nav350_url"
#: ``simulate serve``'s parameter of the NAV350's port, and its default (not served)
SERVE_PARAM, SERVE_DEFAULT = "nav350", None
RX, TX = topics.NAV350_RX, topics.NAV350_TX
#: topic -> schema of the NAV350's own topics
TOPICS = {RX: "lgvtool.RawBytes", TX: "lgvtool.RawBytes"}
#: the raw topics the NAV350's traffic is logged on
RAW_TOPICS = (TX, RX)
#: a log without NAV350 traffic has no NAV350 section in the decode report
ABSENT_REPORT: dict[str, Any] | None = None
ABSENT_METADATA: dict[str, dict[str, int]] = {}
DEFAULT_PORT = 2112


def stream_decoder(*, deliver_unknown: bool = False) -> Any:
    """A :class:`~lgvtool.devices.nav350.nav350_stream.Nav350StreamDecoder`."""
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder

    return Nav350StreamDecoder(deliver_unknown=deliver_unknown)


def log_decoder(metadata: Mapping[str, Any]) -> Any:
    """A :class:`~lgvtool.devices.nav350.nav350_logdecode.Nav350LogDecoder`; the global ids of
    the log's ``device.nav350`` metadata (if any) map the landmarks to map ids."""
    from lgvtool.devices.nav350.nav350_logdecode import Nav350LogDecoder

    ids = metadata.get("device.nav350", {}).get("global_ids")
    return Nav350LogDecoder(map_id=None if not isinstance(ids, dict) else
                            {int(k): int(v) for k, v in ids.items()})


def emulator(playback: Any, **clock: float) -> Any:
    """A :class:`~lgvtool.devices.nav350.nav350_emulator.VirtualNav350` playing ``playback``."""
    from lgvtool.devices.nav350.nav350_emulator import VirtualNav350

    return VirtualNav350(playback, **clock)  # type: ignore[arg-type]


def split_port_spec(spec: str) -> tuple[str, dict[str, float]]:
    """``simulate serve --nav350 PORT?drift_ppm=..&offset_ms=..``: the port and the clock
    settings of the emulator (:func:`emulator`); InputError for a bad setting."""
    from lgvtool.devices.nav350.nav350_emulator import split_port_spec as split

    return split(spec)


def emulator_class() -> Any:
    """The class of :func:`emulator` (its ``FAULT_KINDS``: the faults it takes)."""
    from lgvtool.devices.nav350.nav350_emulator import VirtualNav350

    return VirtualNav350


def serve_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``simulate serve`` option of the NAV350 (``--nav350 PORT[?CLOCK]``)."""
    return click.option("--nav350", SERVE_PARAM, default="none", show_default=True,
                        metavar="PORT",
                        help="Where a virtual NAV350 listens (SOPAS CoLa-A and CoLa-B): "
                             "tcp://HOST:PORT, 'pty' or 'none'; '?drift_ppm=50&offset_ms=987654' "
                             "sets its millisecond clock.")(f)


def serve_emulator(playback: Any, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, Any]:
    """``simulate serve``'s NAV350: the port of ``spec`` (:func:`split_port_spec`; None: not
    served, and no emulator) and its :func:`emulator` with the spec's clock settings
    (``loop``: unused, it only answers and streams on request)."""
    if spec is None:
        return None, None
    port, clock = split_port_spec(spec)
    return port, emulator(playback, **clock)


def record_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """The ``record`` options of the NAV350 (``--nav350 URL``, ``--nav350-cola``)."""
    f = click.option("--nav350-cola", "nav350_cola", type=click.Choice(["binary", "ascii"]),
                     default="binary", show_default=True,
                     help="NAV350 SOPAS dialect: CoLa-B (binary) or CoLa-A (ascii).")(f)
    return click.option("--nav350", "nav350_url", metavar="URL",
                        help="NAV350 over Ethernet: tcp://HOST:2112. Logs in, reads its stored "
                             "layout of --layer into the log (writes one only with "
                             "--write-layout), navigates and polls pose + landmarks at the "
                             "device's rate; --speed-input sends mNPOSSetSpeed.")(f)


def recorder_settings(options: dict[str, Any], *, layout: Any, speed_input: bool,
                      reply_timeout: float, config: Any) -> Any:
    """Take the NAV350's :func:`record_options` out of ``options``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice` with
    :class:`~lgvtool.devices.nav350.nav350_session.Nav350Settings` (``layout``: the shared
    :class:`~lgvtool.devices.layout_plan.LayoutPlan`; ``speed_input``, ``reply_timeout`` s),
    None without ``--nav350``; InputError for a URL that is not TCP or a layer out of range."""
    url = options.pop(RECORD_URL_PARAM, None)
    cola = options.pop("nav350_cola", "binary")
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


def recorder_link(url: str) -> Any:
    """The NAV350's link at ``url`` (tcp://HOST:2112; :func:`recorder_settings` refuses
    others)."""
    from lgvtool.devices.device_links import NAV200_SERIAL_DEFAULTS, open_link

    return open_link(url, NAV200_SERIAL_DEFAULTS)


def recorder_metadata(device: Any) -> dict[str, Any]:
    """The NAV350's entries of the log's ``recorder`` metadata (``device``: its
    :class:`~lgvtool.devices.recorder.RecordedDevice`, None when not recorded)."""
    return {"nav350_url": None if device is None else device.url}


def recorder_worker(link: Any, sink: Any, stop: Any, timing: Any, settings: Any, config: Any,
                    *, mcu: Any = None, warn: Any = None) -> Any:
    """The recorder thread of one NAV350 link."""
    from lgvtool.devices.nav350.nav350_session import Nav350Session, Nav350Settings
    from lgvtool.devices.nav350.nav350_worker import Nav350Worker

    s = settings if settings is not None else Nav350Settings()
    # the landmarks written (if asked for) in the order written: the device's new ids map to
    # these reflectors until the layout is read back
    known = tuple(r for r in _written(s))
    return Nav350Worker(link, sink, stop, timing, Nav350Session(s), vehicle=config.vehicle,
                        known_map=known, mcu=mcu, warn=warn)


def _written(settings: Any) -> tuple[Any, ...]:
    """The reflectors of a requested layout write, as the log's map (ids from 1 in the order
    written; the device's own ids replace them once the layout is read back)."""
    from lgvtool.config import Reflector

    return tuple(Reflector(i + 1, m.x_mm / 1000.0, m.y_mm / 1000.0, m.size_mm / 2000.0,
                           settings.layer) for i, m in enumerate(settings.write_layout))
