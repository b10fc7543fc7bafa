"""``lgvtool record``: the devices into a crash-safe log
(:func:`lgvtool.app.record_job.record_devices`); each device family's options are made from
the declarations of its registration (``RECORD_OPTIONS``, :mod:`lgvtool.devices.device_registry`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeAlias, TypeVar

import click

from lgvtool.devices.device_registry import (
    ChoiceValue,
    IntegerValue,
    NumberValue,
    OptionValue,
    PairValue,
    RecordOption,
    TextValue,
    ValueKind,
    registrations,
)
from lgvtool.options import Number, force_option, positive, print_output, split_names
from lgvtool.values import MAX_BYTES, MAX_WALL_S

_POSITIVE = positive(MAX_WALL_S)
_PERIOD = positive(3600.0)


#: a click option's type: a parameter type, None (click's string) or a pair of them (a tuple)
ClickType: TypeAlias = "click.ParamType[object, str] | tuple[ClickType, ClickType] | None"
#: a command function, before and after an option decorates it
Command = TypeVar("Command", bound="Callable[..., object]")


def _click_type(value: ValueKind) -> ClickType:
    """The click type of a declared option value (None: click's string)."""
    if isinstance(value, TextValue):
        return None
    if isinstance(value, NumberValue):
        return Number(float, value.minimum, value.maximum, min_open=value.min_open)
    if isinstance(value, IntegerValue):
        return click.IntRange(value.minimum, value.maximum)
    if isinstance(value, ChoiceValue):
        return click.Choice(list(value.choices))
    if isinstance(value, PairValue):
        item = _click_type(value.item)
        return (item, item)
    raise TypeError(f"record: no click type for {value!r}")


def _click_option(option: RecordOption) -> Callable[[Command], Command]:
    """The click option of a family's declared ``record`` option."""
    given: dict[str, Any] = {"type": _click_type(option.value), "default": option.default,
                             "show_default": option.show_default or None,
                             "metavar": option.metavar}
    return click.option(option.flag, option.param, help=option.help,
                        **{k: v for k, v in given.items() if v is not None})


def _family_options(f: Command) -> Command:
    """Every registered device family's ``record`` options (``RECORD_OPTIONS``), in family
    order."""
    for option in reversed([o for reg in registrations() for o in reg.RECORD_OPTIONS]):
        f = _click_option(option)(f)
    return f


@click.command()
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The log to write (MCAP). With splitting: OUT-YYYYmmddTHHMMSSZ.mcap files.")
@click.option("--duration", type=_POSITIVE, metavar="S",
              help="Stop after S seconds (default: until Ctrl-C or SIGTERM).")
@click.option("--speed-input", is_flag=True,
              help="Poll with Pw, sending the head's vehicle-frame speed (mm/s) and yaw rate "
                   "from the MCU odometry.")
@click.option("--layer", type=click.IntRange(0, 255), default=0, show_default=True,
              help="Reflector layer read, written, mapped and navigated on.")
@click.option("--read-layout/--no-read-layout", default=True, show_default=True,
              help="Read the device's stored layout of --layer into the log (nothing is "
                   "written).")
@click.option("--no-map-upload", "no_map_upload", is_flag=True, hidden=True,
              help="Old name of --no-read-layout.")
@click.option("--write-layout", "write_layout", metavar="FILE",
              type=click.Path(dir_okay=False, path_type=str),
              help="ERASE the device's (NAV350 or NAV200) stored layout of --layer and write FILE's "
                   "reflectors of that layer instead (lgvtool TOML [[reflectors]] or SICK "
                   ".imk), once per recording; the layout before and after is logged. "
                   "Nothing is ever written to a device without this option.")
@click.option("--map-at", "map_at", metavar="X,Y,DEG",
              help="NAV350: run the device's mapping once from where the vehicle stands (the "
                   "NAV head at X, Y m, heading DEG in the layout frame); waits while the MCU "
                   "shows motion. The landmarks found are logged.")
@click.option("--map-layout", "map_layout", metavar="FILE",
              type=click.Path(dir_okay=False, path_type=str),
              help="With --map-at: merge the landmarks found into the layout file FILE "
                   "(created if missing; a landmark within 0.25 m of one of FILE's reflectors "
                   "is that reflector), so stands mapped one after the other build one "
                   "layout.")
@click.option("--reply-timeout", type=_PERIOD, default=1.0, show_default=True, metavar="S",
              help="Reply timeout of the NAV200 and the NAV350, s.")
@click.option("--split-size", type=positive(MAX_BYTES / 1e6), metavar="MB",
              help="Start a new file once the current one holds MB megabytes (10^6 bytes).")
@click.option("--split-duration", type=_POSITIVE, metavar="S",
              help="Start a new file every S seconds.")
@click.option("--config", "config_file", type=click.Path(dir_okay=False, path_type=str),
              help="Vehicle/reflector configuration (TOML), stored in the log; its geometry "
                   "turns odometry into speed input.")
@click.option("--status/--no-status", default=True, show_default=True,
              help="Live status line on stderr.")
@click.option("--live", "live", metavar="[HOST:]PORT",
              help="Also serve the recording as it happens over the Foxglove WebSocket "
                   "protocol on PORT (host 127.0.0.1 unless given; 0.0.0.0 for every "
                   "interface). See docs/live.md.")
@click.option("--live-estimator", "live_estimators", multiple=True, metavar="NAME[,NAME]",
              help="Online estimate shown live (repeatable or comma-separated): laser, "
                   "deadreckoning, ekf, pf-paper, pf. Needs --live.")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@_family_options
def record(output: str, duration: float | None, speed_input: bool, layer: int,
           read_layout: bool, no_map_upload: bool, write_layout: str | None,
           map_at: str | None, map_layout: str | None, reply_timeout: float,
           split_size: float | None,
           split_duration: float | None, config_file: str | None, status: bool, force: bool,
           as_json: bool, live: str | None = None, live_estimators: tuple[str, ...] = (),
           **device_options: OptionValue) -> None:
    """Record the MCU frame stream and the NAV200 (polled for its pose, --nav) or the NAV350
    (pose and landmarks, --nav350) into OUTPUT.

    Logged: raw bytes both ways (/mcu/rx, /nav200/tx, /nav200/rx, /nav350/tx, /nav350/rx),
    decoded frames (/mcu/frame), poses (/nav/pose) and NAV350 landmarks (/nav/reflectors), the
    device's stored reflector layout as read (/map/reflectors and metadata), device identity,
    and every link failure, gap, checksum error and device error reply (/diagnostics), all
    stamped with the host receive time. Nothing is written to a device's layout unless
    --write-layout names the file. A link that fails, or opens and drops, is retried with
    backoff and the recording goes on.
    Ctrl-C or SIGTERM finishes the file; after a crash, 'lgvtool recover' saves all but about
    the last second. See docs/recording.md.
    """
    import shlex
    import sys

    from lgvtool.app.option_values import parse_live_address
    from lgvtool.app.record_job import RecordOptions, record_devices
    from lgvtool.errors import InputError

    warning = None
    if no_map_upload:
        warning = ("record: --no-map-upload is now --no-read-layout (nothing is written to a "
                   "device unless --write-layout names the file)")
        read_layout = False
    if map_layout is not None and map_at is None:
        raise InputError("record: --map-layout needs --map-at X,Y,DEG")
    print_output(record_devices(RecordOptions(
        output, device_options=device_options, duration=duration, speed_input=speed_input,
        layer=layer, read_layout=read_layout, write_layout=write_layout,
        map_at=None if map_at is None else _map_pose(map_at), map_layout=map_layout,
        warning=warning, reply_timeout=reply_timeout, split_size=split_size,
        split_duration=split_duration, config_file=config_file, status=status, force=force,
        live=None if live is None else parse_live_address(live),
        live_estimators=tuple(split_names(live_estimators, "--live-estimator")),
        command=shlex.join(["lgvtool", *sys.argv[1:]]))), as_json)


def _map_pose(text: str) -> tuple[float, float, float]:
    """``X,Y,DEG`` -> (x m, y m, heading deg); InputError when it is not three finite numbers
    within 10^6 m and a heading within +-360 deg."""
    import math

    from lgvtool.errors import InputError

    parts = text.split(",")
    try:
        x, y, deg = (float(p) for p in parts)
    except ValueError:
        raise InputError(f"record: --map-at {text!r}: give X,Y,DEG (m, m, degrees), e.g. "
                         "--map-at 12.5,4.0,90") from None
    if not all(math.isfinite(v) for v in (x, y, deg)) or max(abs(x), abs(y)) > 1e6 \
            or abs(deg) > 360.0:
        raise InputError(f"record: --map-at {text!r}: X and Y within 10^6 m, DEG within "
                         "+-360")
    return x, y, deg
