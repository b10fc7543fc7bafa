"""``lgvtool record``: the devices into a crash-safe log
(:func:`lgvtool.app.record_job.record_devices`); each device family's options come from its
registration (:mod:`lgvtool.devices.device_registry`)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import click

from lgvtool.devices.device_registry import registrations
from lgvtool.options import force_option, positive, print_output, split_names
from lgvtool.values import MAX_BYTES, MAX_WALL_S

_POSITIVE = positive(MAX_WALL_S)
_PERIOD = positive(3600.0)


def _family_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """Every registered device family's ``record`` options, in family order."""
    for reg in reversed(registrations()):
        f = reg.record_options(f)
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
              help="Reflector layer to upload.")
@click.option("--no-map-upload", is_flag=True, help="Do not upload the stored reflector map.")
@click.option("--reply-timeout", type=_PERIOD, default=1.0, show_default=True, metavar="S",
              help="NAV200 reply timeout, s.")
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
           no_map_upload: bool, reply_timeout: float, split_size: float | None,
           split_duration: float | None, config_file: str | None, status: bool, force: bool,
           as_json: bool, live: str | None = None, live_estimators: tuple[str, ...] = (),
           **device_options: Any) -> None:
    """Record the MCU frame stream and the NAV200 (polled for its pose, --nav) or the NAV350
    (pose and landmarks, --nav350) into OUTPUT.

    Logged: raw bytes both ways (/mcu/rx, /nav200/tx, /nav200/rx, /nav350/tx, /nav350/rx),
    decoded frames (/mcu/frame), poses (/nav/pose) and NAV350 landmarks (/nav/reflectors), the
    uploaded reflector map (/map/reflectors and metadata), device identity, and every link
    failure, gap, checksum error and device error reply (/diagnostics), all stamped with the
    host receive time. A link that fails is retried with backoff and the recording goes on.
    Ctrl-C or SIGTERM finishes the file; after a crash, 'lgvtool recover' saves all but about
    the last second. See docs/recording.md.
    """
    import shlex
    import sys

    from lgvtool.app.record_job import record_devices

    print_output(record_devices(
        output, duration=duration, speed_input=speed_input, layer=layer,
        upload_map=not no_map_upload, reply_timeout=reply_timeout, split_size=split_size,
        split_duration=split_duration, config_file=config_file, status=status, force=force,
        live=live, live_estimators=split_names(live_estimators, "--live-estimator"),
        command=shlex.join(["lgvtool", *sys.argv[1:]]), **device_options), as_json)
