"""``lgvtool record``: the MCU and the NAV200 into a crash-safe log
(:func:`lgvtool.app.record_job.record_devices`)."""

from __future__ import annotations

import click

from lgvtool.devices.nav350.nav350_registration import record_options as nav350_options
from lgvtool.options import force_option, positive, print_output, split_names
from lgvtool.values import MAX_BYTES, MAX_WALL_S

_POSITIVE = positive(MAX_WALL_S)
_PERIOD = positive(3600.0)
_METRES = positive(1000.0)


@click.command()
@click.option("--nav", "nav_url", metavar="URL",
              help="NAV200 link: serial:///dev/ttyS0?baud=19200&parity=E (default 19200 8E1) "
                   "or tcp://HOST:PORT.")
@click.option("--mcu", "mcu_url", metavar="URL",
              help="MCU link: serial:///dev/ttyUSB0?baud=115200 (default 115200 8N1) or "
                   "tcp://HOST:PORT.")
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="The log to write (MCAP). With splitting: OUT-YYYYmmddTHHMMSSZ.mcap files.")
@click.option("--duration", type=_POSITIVE, metavar="S",
              help="Stop after S seconds (default: until Ctrl-C or SIGTERM).")
@click.option("--poll-period", type=_PERIOD, default=0.45, show_default=True, metavar="S",
              help="NAV200 pose request period, s.")
@click.option("--speed-input", is_flag=True,
              help="Poll with Pw, sending the head's vehicle-frame speed (mm/s) and yaw rate "
                   "from the MCU odometry.")
@click.option("--omega-units", type=click.Choice(["rev", "half-deg"]), default="rev",
              show_default=True,
              help="Pw yaw-rate unit: 'rev' = 65536 per revolution per s, 'half-deg' = 0.5 deg/s.")
@click.option("--sliding-mean", type=click.IntRange(1, 255), metavar="N",
              help="Enter positioning with PN N (sliding mean over N poses) instead of PA.")
@click.option("--action-radii", type=(_METRES, _METRES), metavar="RMIN RMAX",
              help="Set the NAV200 action radii (PO), m.")
@click.option("--nearest", type=click.IntRange(1, 255), metavar="N",
              help="Use the N nearest reflectors (PC).")
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
@nav350_options
def record(nav_url: str | None, mcu_url: str | None, output: str, duration: float | None,
           poll_period: float, speed_input: bool, omega_units: str, sliding_mean: int | None,
           action_radii: tuple[float, float] | None, nearest: int | None, layer: int,
           no_map_upload: bool, reply_timeout: float, split_size: float | None,
           split_duration: float | None, config_file: str | None, status: bool, force: bool,
           as_json: bool, live: str | None = None, live_estimators: tuple[str, ...] = (),
           nav350_url: str | None = None, nav350_cola: str = "binary") -> None:
    """Record the MCU frame stream and the NAV200 (polled for its pose) into OUTPUT.

    Logged: raw bytes both ways (/mcu/rx, /nav200/tx, /nav200/rx), decoded frames (/mcu/frame)
    and poses (/nav/pose), the uploaded reflector map (/map/reflectors and metadata), device
    identity, and every link failure, gap, checksum error and NAV200 error reply
    (/diagnostics), all stamped with the host receive time. A link that fails is retried with
    backoff and the recording goes on. Ctrl-C or SIGTERM finishes the file; after a crash,
    'lgvtool recover' saves all but about the last second. See docs/recording.md.
    """
    import shlex
    import sys

    from lgvtool.app.record_job import record_devices

    print_output(record_devices(
        output, nav_url=nav_url, mcu_url=mcu_url, duration=duration, poll_period=poll_period,
        speed_input=speed_input, omega_units=omega_units, sliding_mean=sliding_mean,
        action_radii=action_radii, nearest=nearest, layer=layer,
        upload_map=not no_map_upload, reply_timeout=reply_timeout, split_size=split_size,
        split_duration=split_duration, config_file=config_file, status=status, force=force,
        live=live, live_estimators=split_names(live_estimators), nav350_url=nav350_url,
        nav350_cola=nav350_cola, command=shlex.join(["lgvtool", *sys.argv[1:]])), as_json)
