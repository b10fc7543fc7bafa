"""Recording the MCU and the NAV200 (and a NAV350) into a crash-safe log (``lgvtool
record``)."""

from __future__ import annotations

from collections.abc import Sequence

from lgvtool.app.job_output import JobOutput


def record_devices(output: str, *, nav_url: str | None = None, mcu_url: str | None = None,
                   duration: float | None = None, poll_period: float = 0.45,
                   speed_input: bool = False, omega_units: str = "rev",
                   sliding_mean: int | None = None,
                   action_radii: tuple[float, float] | None = None, nearest: int | None = None,
                   layer: int = 0, upload_map: bool = True, reply_timeout: float = 1.0,
                   split_size: float | None = None, split_duration: float | None = None,
                   config_file: str | None = None, status: bool = True, force: bool = False,
                   live: str | None = None, live_estimators: Sequence[str] = (),
                   nav350_url: str | None = None, nav350_cola: str = "binary",
                   command: str = "") -> JobOutput:
    """Record the devices at ``nav_url`` (NAV200), ``mcu_url`` and ``nav350_url`` (link URLs:
    ``serial:///dev/ttyS0?baud=19200&parity=E`` or ``tcp://HOST:PORT``) into ``output`` until
    ``duration`` s have passed, Ctrl-C or SIGTERM. The NAV200 is polled every ``poll_period``
    s (replies awaited ``reply_timeout`` s), with ``speed_input`` sending the MCU odometry's
    speed (yaw rate in ``omega_units``: rev or half-deg); ``sliding_mean``, ``action_radii``
    (m), ``nearest`` and ``layer`` set its positioning, ``upload_map`` uploads the stored map.
    A new file starts every ``split_size`` MB (10^6 bytes) or ``split_duration`` s.
    ``config_file``: the vehicle and reflector configuration (TOML) stored in the log. ``live``
    (``[HOST:]PORT``) also serves the recording live, with the online ``live_estimators``.
    ``command`` is stored in the log's metadata as the command line that recorded it.

    The document holds the files written, the message counts, the errors, the elapsed s, the
    bytes, why the recording stopped, the devices and the live view's figures; the text is the
    summary, the epilogue the live view's line.

    :raises InputError: (exit 2) no device, inconsistent options, a refused output, a device
        that fails for good.
    """
    from pathlib import Path

    from lgvtool.config import load_config
    from lgvtool.devices.nav200.nav200_session import Nav200Settings
    from lgvtool.devices.nav350.nav350_registration import recorder_settings
    from lgvtool.devices.recorder import RecorderSettings, record
    from lgvtool.errors import InputError
    from lgvtool.outputs import guard_output
    from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S, OMEGA_UNITS_PER_RAD_S_HALF_DEG

    guard_output(output, [config_file], force=force)
    if nav_url is None and mcu_url is None and nav350_url is None:
        raise InputError("record: give --nav URL, --nav350 URL, --mcu URL or several")
    if speed_input and mcu_url is None:
        raise InputError("record: --speed-input needs the MCU's odometry (--mcu URL)")
    if action_radii is not None and action_radii[0] >= action_radii[1]:
        raise InputError("record: --action-radii RMIN must be below RMAX")
    live_at = _live_options(live, live_estimators)
    nav = Nav200Settings(
        poll_period=poll_period, reply_timeout=reply_timeout, layer=layer,
        sliding_mean=sliding_mean, action_radii=action_radii, nearest_reflectors=nearest,
        upload_map=upload_map, speed_input=speed_input,
        omega_scale=OMEGA_UNITS_PER_RAD_S if omega_units == "rev"
        else OMEGA_UNITS_PER_RAD_S_HALF_DEG,
    )
    config = load_config(config_file)
    nav350 = recorder_settings(nav350_url, nav350_cola, layer=layer, upload=upload_map,
                               speed_input=speed_input, reply_timeout=reply_timeout,
                               config=config)
    settings = RecorderSettings(
        output=Path(output), nav_url=nav_url, mcu_url=mcu_url, duration=duration, nav=nav,
        split_bytes=None if split_size is None else int(split_size * 1e6),
        split_seconds=split_duration, config=config, status=status,
        overwrite=force, command=command,
        live=live_at, live_estimators=tuple(live_estimators),
        nav350_url=nav350_url, nav350=nav350,
    )
    result = record(settings)
    document = {
        "files": [str(p) for p in result.files], "counts": result.counts,
        "errors": result.errors, "elapsed_s": round(result.elapsed, 3),
        "bytes": result.bytes, "stop_reason": result.stop_reason,
        "devices": result.devices, "live": result.live,
    }
    epilogue = None
    if result.live is not None:
        from lgvtool.live.tap import describe

        epilogue = describe(result.live)
    return JobOutput(document, result.summary(), epilogue=epilogue)


def _live_options(live: str | None, estimators: Sequence[str]) -> object:
    """The live server's address (None without ``live``); checks the estimators' names."""
    from lgvtool.errors import InputError

    if live is None:
        if estimators:
            raise InputError("record: --live-estimator needs --live [HOST:]PORT")
        return None
    from lgvtool.live.live_server import parse_address
    from lgvtool.localize.registry import check_names

    check_names(list(estimators))
    return parse_address(live)
