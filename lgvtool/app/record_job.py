"""Recording the devices (the MCU, the NAV200, the NAV350: every registered family) into a
crash-safe log (``lgvtool record``)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from lgvtool.app.job_output import JobOutput


def record_devices(output: str, *, duration: float | None = None, speed_input: bool = False,
                   layer: int = 0, read_layout: bool = True, write_layout: str | None = None,
                   map_at: tuple[float, float, float] | None = None,
                   map_layout: str | None = None, warn: str | None = None,
                   reply_timeout: float = 1.0,
                   split_size: float | None = None, split_duration: float | None = None,
                   config_file: str | None = None, status: bool = True, force: bool = False,
                   live: str | None = None, live_estimators: Sequence[str] = (),
                   command: str = "", **device_options: Any) -> JobOutput:
    """Record the devices into ``output`` until ``duration`` s have passed, Ctrl-C or SIGTERM.

    ``device_options`` are the device families' ``record`` options, by parameter name (each
    family's registration takes its own, :mod:`lgvtool.devices.device_registry`): the link URLs
    ``nav_url`` (NAV200), ``mcu_url`` and ``nav350_url`` (``serial:///dev/ttyS0?baud=19200&
    parity=E`` or ``tcp://HOST:PORT``); the NAV200's ``poll_period`` s (default 0.45),
    ``omega_units`` (rev or half-deg: the yaw rate unit of its speed input), ``sliding_mean``,
    ``action_radii`` (m) and ``nearest``; the NAV350's ``nav350_cola`` (binary or ascii).
    Shared by the laser devices (:mod:`lgvtool.devices.layout_plan`): replies are awaited
    ``reply_timeout`` s, ``speed_input`` sends the MCU odometry's speed, ``layer`` is the
    reflector layer, ``read_layout`` reads the device's stored layout into the log,
    ``write_layout`` (a layout file) is written as the device's layout (erasing the stored
    one: said on stderr first), ``map_at`` (x m, y m, heading deg of the NAV head) runs one
    mapping from there and ``map_layout`` (a layout file, created or merged into) receives the
    landmarks found. ``warn``: a line for stderr before recording (e.g. an old option's new
    name). A new file starts every ``split_size`` MB (10^6 bytes) or
    ``split_duration`` s. ``config_file``: the vehicle and reflector configuration (TOML)
    stored in the log. ``live`` (``[HOST:]PORT``) also serves the recording live, with the
    online ``live_estimators``. ``command`` is stored in the log's metadata as the command line
    that recorded it.

    The document holds the files written, the message counts, the errors, the elapsed s, the
    bytes, why the recording stopped, the devices and the live view's figures; the text is the
    summary, the epilogue the live view's line.

    :raises InputError: (exit 2) no device, two devices that write the same topic (the NAV200
        and the NAV350), inconsistent options, a refused output, a device that fails for good.
    :raises TypeError: an option no family knows.
    """
    import math
    import sys
    from pathlib import Path

    from lgvtool.config import load_config
    from lgvtool.devices.device_registry import registrations
    from lgvtool.devices.layout_plan import LayoutPlan, MapPose
    from lgvtool.devices.recorder import RecorderSettings, no_device_message, record
    from lgvtool.errors import ConfigError, InputError
    from lgvtool.layout_file import read_layout as read_layout_file
    from lgvtool.outputs import guard_output

    # the recording is written where it is (crash-safe, no rename), so /dev/null may take it
    guard_output(output, [config_file, write_layout, map_layout], force=force, in_place=True)
    if map_layout is not None:
        guard_output(map_layout, [output, config_file, write_layout], force=True)
    regs = registrations()
    if all(device_options.get(r.RECORD_URL_PARAM) is None for r in regs):
        raise InputError(no_device_message())
    chosen = [r for r in regs if device_options.get(r.RECORD_URL_PARAM) is not None]
    for i, a in enumerate(chosen):
        for b in chosen[i + 1:]:
            shared = sorted(a.log_decoder({}).decoded_topics & b.log_decoder({}).decoded_topics)
            if shared:
                raise InputError(f"record: {a.TITLE} and {b.TITLE} would both write "
                                 f"{', '.join(shared)}; record one of them")
    if speed_input and all(device_options.get(r.RECORD_URL_PARAM) is None
                           for r in regs if r.ODOMETRY):
        raise InputError("record: --speed-input needs the MCU's odometry (--mcu URL)")
    live_at = _live_options(live, live_estimators)
    config = load_config(config_file)
    written: tuple[Any, ...] = ()
    if write_layout is not None:
        try:
            written = tuple(r for r in read_layout_file(write_layout) if r.layer == layer)
        except ConfigError as exc:
            raise InputError(f"record: --write-layout: {exc}") from None
        if len(written) < 3:
            raise InputError(f"record: --write-layout {write_layout}: {len(written)} "
                             f"reflectors in layer {layer}; a layout needs at least 3")
    existing: tuple[Any, ...] = ()
    if map_layout is not None and Path(map_layout).exists():
        try:
            existing = read_layout_file(map_layout)
        except ConfigError as exc:
            raise InputError(f"record: --map-layout: {exc}") from None
    plan = LayoutPlan(layer=layer, read=read_layout, write=written, write_source=write_layout,
                      map_at=None if map_at is None else MapPose(
                          map_at[0], map_at[1], math.radians(map_at[2])))
    options = dict(device_options)
    devices = {}
    for reg in regs:
        device = reg.recorder_settings(options, layout=plan, speed_input=speed_input,
                                       reply_timeout=reply_timeout, config=config)
        if device is not None:
            devices[reg.DEVICE] = device
    if options:
        raise TypeError(f"record_devices: no device family has the option(s) "
                        f"{', '.join(sorted(options))}")
    settings = RecorderSettings(
        output=Path(output), devices=devices, duration=duration,
        split_bytes=None if split_size is None else int(split_size * 1e6),
        split_seconds=split_duration, config=config, status=status,
        overwrite=force, command=command,
        live=live_at, live_estimators=tuple(live_estimators),
    )
    if warn is not None:
        print(f"lgvtool: warning: {warn}", file=sys.stderr)
    if written:
        print(f"lgvtool: warning: record: --write-layout {write_layout}: the device's stored "
              f"layout of layer {layer} will be ERASED and replaced by {len(written)} "
              "reflectors, once, at the first connection (the layout before and after is "
              "logged)", file=sys.stderr)
    result = record(settings)
    mapping = None
    if map_at is not None:
        mapping = {"found": None if result.mapped is None else len(result.mapped),
                   "layout": map_layout}
        if result.mapped is not None and map_layout is not None:
            from lgvtool.layout_file import merge_mapped
            from lgvtool.layout_file import write_layout as write_layout_file

            merged = merge_mapped(existing, result.mapped, layer=layer)
            write_layout_file(map_layout, merged,
                              comment=f"reflector layout, mapped by lgvtool record --map-at "
                                      f"({len(merged)} reflectors)")
            mapping["reflectors"] = len(merged)
    document = {
        "files": [str(p) for p in result.files], "counts": result.counts,
        "errors": result.errors, "elapsed_s": round(result.elapsed, 3),
        "bytes": result.bytes, "stop_reason": result.stop_reason,
        "devices": result.devices, "live": result.live, "mapping": mapping,
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
