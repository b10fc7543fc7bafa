"""Recording the devices (the MCU, the NAV200, the NAV350: every registered family) into a
crash-safe log (``lgvtool record``)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from lgvtool.app.job_output import JobOutput

if TYPE_CHECKING:
    from lgvtool.devices.device_registry import OptionValue
    from lgvtool.live.live_server import LiveAddress


@dataclass(frozen=True, slots=True)
class RecordOptions:
    """What :func:`record_devices` records, from which devices, and how (``lgvtool
    record``)."""

    output: str
    """The log (MCAP) to write, in place (crash-safe; with splitting
    OUT-YYYYmmddTHHMMSSZ.mcap files)."""
    device_options: Mapping[str, OptionValue] = field(default_factory=dict)
    """The device families' ``record`` options by parameter name, each taken by its family's
    registration (:attr:`lgvtool.devices.device_registry.DeviceFamily.RECORD_OPTIONS`): the
    link URLs ``nav_url`` (NAV200), ``mcu_url`` and ``nav350_url`` (``serial:///dev/ttyS0?
    baud=19200&parity=E`` or ``tcp://HOST:PORT``); the NAV200's ``poll_period`` s (default
    0.45), ``omega_units`` (rev or half-deg: the yaw rate unit of its speed input),
    ``sliding_mean``, ``action_radii`` (m, m) and ``nearest``; the NAV350's ``nav350_cola``
    (binary or ascii). A family's option left out takes its declared default; a link left out
    (or None) is not recorded."""
    duration: float | None = None
    """Recording length, s; None: until Ctrl-C or SIGTERM."""
    speed_input: bool = False
    """Poll the laser devices with the MCU odometry's speed (needs ``mcu_url``)."""
    layer: int = 0
    """Reflector layer (0-255) read, written, mapped and navigated on."""
    read_layout: bool = True
    """Read the device's stored layout of :attr:`layer` into the log."""
    write_layout: str | None = None
    """A layout file (lgvtool TOML or SICK .imk) written as the device's layout of
    :attr:`layer`, erasing the stored one (said on stderr first); None: nothing is written to
    a device."""
    map_at: tuple[float, float, float] | None = None
    """Run the device's mapping once from the NAV head at (x m, y m, heading deg) in the
    layout frame; None: no mapping."""
    map_layout: str | None = None
    """With :attr:`map_at`: the layout file (created or merged into) that receives the
    landmarks found."""
    warning: str | None = None
    """A line for stderr before recording (e.g. an old option's new name)."""
    reply_timeout: float = 1.0
    """Reply timeout of the NAV200 and the NAV350, s."""
    split_size: float | None = None
    """Start a new file once the current one holds this many MB (10^6 bytes); None: never."""
    split_duration: float | None = None
    """Start a new file every this many s; None: never."""
    config_file: str | None = None
    """Vehicle and reflector configuration (TOML) stored in the log; None: the defaults."""
    status: bool = True
    """Live status line on stderr."""
    force: bool = False
    """Replace an existing :attr:`output`."""
    live: LiveAddress | None = None
    """Also serve the recording live (Foxglove WebSocket) on this address; None: not."""
    live_estimators: tuple[str, ...] = ()
    """Online estimators shown live (needs :attr:`live`)."""
    command: str = ""
    """The command line that recorded the log, stored in its metadata."""


def record_devices(options: RecordOptions) -> JobOutput:
    """Record the devices of the ``options`` into their output until their duration has
    passed, Ctrl-C or SIGTERM (see :class:`RecordOptions`).

    The device families' options (``device_options``) are each taken by its family's
    registration (:mod:`lgvtool.devices.device_registry`); the layout options are shared by
    the laser devices (:mod:`lgvtool.devices.layout_plan`).

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

    o = options
    output, layer, write_layout, map_layout = o.output, o.layer, o.write_layout, o.map_layout
    config_file, device_options = o.config_file, o.device_options
    # the recording is written where it is (crash-safe, no rename), so /dev/null may take it
    guard_output(output, [config_file, write_layout, map_layout], force=o.force, in_place=True)
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
    if o.speed_input and all(device_options.get(r.RECORD_URL_PARAM) is None
                             for r in regs if r.ODOMETRY):
        raise InputError("record: --speed-input needs the MCU's odometry (--mcu URL)")
    _check_live(o.live, o.live_estimators)
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
    map_at = o.map_at
    plan = LayoutPlan(layer=layer, read=o.read_layout, write=written, write_source=write_layout,
                      map_at=None if map_at is None else MapPose(
                          map_at[0], map_at[1], math.radians(map_at[2])))
    untaken = dict(device_options)  # each family takes its own options out
    devices = {}
    for reg in regs:
        device = reg.recorder_settings(untaken, layout=plan, speed_input=o.speed_input,
                                       reply_timeout=o.reply_timeout, config=config)
        if device is not None:
            devices[reg.DEVICE] = device
    if untaken:
        raise TypeError(f"record_devices: no device family has the option(s) "
                        f"{', '.join(sorted(untaken))}")
    settings = RecorderSettings(
        output=Path(output), devices=devices, duration=o.duration,
        split_bytes=None if o.split_size is None else int(o.split_size * 1e6),
        split_seconds=o.split_duration, config=config, status=o.status,
        overwrite=o.force, command=o.command,
        live=o.live, live_estimators=tuple(o.live_estimators),
    )
    if o.warning is not None:
        print(f"lgvtool: warning: {o.warning}", file=sys.stderr)
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


def _check_live(live: LiveAddress | None, estimators: Sequence[str]) -> None:
    """Check the online estimators: their names, and that they have a live server."""
    from lgvtool.errors import InputError

    if live is None:
        if estimators:
            raise InputError("record: --live-estimator needs --live [HOST:]PORT")
        return
    from lgvtool.localize.registry import check_names

    check_names(list(estimators))
