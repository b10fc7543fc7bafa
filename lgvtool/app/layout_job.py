"""Reflector layout files (``lgvtool layout``): lgvtool's ``[[reflectors]]`` TOML and SICK's
``.imk`` (:mod:`lgvtool.layout_file`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from lgvtool.app.job_output import JobOutput
from lgvtool.app.option_values import SettingValue


@dataclass(frozen=True, slots=True)
class LayoutConvertOptions:
    """What :func:`convert_layout` converts, and into what (``lgvtool layout convert``)."""

    source: str
    """The layout file to read: SICK's ``.imk`` by its suffix, else lgvtool's TOML
    ``[[reflectors]]`` (x, y, radius m)."""
    output: str
    """The layout file to write, in the format its suffix names (``.imk``: SICK's, sizes in
    mm; anything else: lgvtool's TOML, m); an existing one is replaced only with
    :attr:`force`, the source never."""
    layer: int | None = None
    """Only the reflectors of this layer (0-255); None: all."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def convert_layout(options: LayoutConvertOptions) -> JobOutput:
    """Read the ``options``' source layout file and write its reflectors (those of its
    layer, or all) to its output, each in the format its suffix names (see
    :class:`LayoutConvertOptions`). The document holds the counts and paths; the text is one
    line.

    :raises InputError: (exit 2) an unreadable or malformed source, no reflector in ``layer``,
        or a refused output (the source itself, an existing file without ``force``).
    """
    from pathlib import Path

    from lgvtool.errors import InputError
    from lgvtool.layout_file import read_layout, write_layout
    from lgvtool.outputs import guard_output

    source, output, layer = options.source, options.output, options.layer
    guard_output(output, [source], force=options.force)
    reflectors = read_layout(source)
    if layer is not None:
        reflectors = tuple(r for r in reflectors if r.layer == layer)
        if not reflectors:
            raise InputError(f"layout convert: {source} has no reflector in layer {layer}")
    write_layout(output, reflectors, comment=f"reflector layout converted from "
                                             f"{Path(source).name}")
    fmt = "SICK .imk" if Path(output).suffix.lower() == ".imk" else "lgvtool TOML"
    document = {"input": source, "output": output, "reflectors": len(reflectors),
                "format": fmt}
    return JobOutput(document, f"{len(reflectors)} reflectors -> {output} ({fmt})")


@dataclass(frozen=True, slots=True)
class LayoutRefineOptions:
    """What :func:`refine_layout` adjusts, from what, and where it writes it (``lgvtool layout
    refine``)."""

    logs: tuple[str, ...]
    """The logs (MCAP, NAV350 recordings with their landmarks) solved together."""
    output: str
    """The refined layout file to write (lgvtool's ``[[reflectors]]`` TOML; ``.imk``: SICK's);
    an existing one is replaced only with :attr:`force`, an input never."""
    fix: tuple[int, ...] = ()
    """Layout ids of the reflectors held at their surveyed positions."""
    config_path: str | None = None
    """The configuration (TOML) whose layout, vehicle and ``[estimators.ekf]`` motion noise are
    used; None: each log's stored one (the layout: the first log's)."""
    settings: Mapping[str, SettingValue] = field(default_factory=dict)
    """Settings of the adjustment by key (:class:`lgvtool.audit.layout_refine.
    RefineSettings`: ``survey_sigma_m`` -> 0.01 m, ...)."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def _fixed_ids(fix: tuple[int, ...], known: list[int]) -> list[int]:
    """The ``--fix`` ids, each checked to be in the layout.

    :raises InputError: (exit 2) an id not in the layout.
    """
    from lgvtool.errors import InputError

    out: list[int] = []
    for rid in fix:
        if rid not in known:
            shown = ", ".join(str(k) for k in sorted(known)[:12])
            more = f" and {len(known) - 12} more" if len(known) > 12 else ""
            raise InputError(f"layout refine: --fix {rid}: no reflector {rid} in the layout "
                             f"(ids {shown}{more})")
        out.append(rid)
    return out


def refine_layout(options: LayoutRefineOptions) -> JobOutput:
    """Adjust the reflector layout to the ``options``' logs (odometry and every landmark
    observation, the surveyed layout as a prior: :mod:`lgvtool.audit.layout_refine`) and
    write the refined layout to its output. The document holds each reflector's refined
    position, shift and 1-sigma (m), the noise found and the counts; the text is a table.

    :raises InputError: (exit 2) scipy not installed (the ``calibrate`` extra), a log without
        landmark observations (a NAV200 recording), an unknown ``--fix`` id, a bad setting,
        or a refused output.
    """
    import time
    from pathlib import Path

    from lgvtool.config import load_config
    from lgvtool.errors import MissingDataError
    from lgvtool.extras import require
    from lgvtool.layout_file import write_layout
    from lgvtool.outputs import guard_output, printable

    require("layout refine", "calibrate", "scipy")
    from lgvtool.audit.layout_refine import prepare_drive, refine, refine_settings
    from lgvtool.declared import as_dict
    from lgvtool.localize.installation import apply_installation
    from lgvtool.localize.logdata import load_log
    from lgvtool.localize.registry import motion_params, resolve_params
    from lgvtool.log import LogReader

    o = options
    out = guard_output(o.output, [*o.logs, o.config_path], force=o.force)
    settings = refine_settings(o.settings)
    given = load_config(o.config_path) if o.config_path else None
    readers = [LogReader(p) for p in o.logs]
    base = given if given is not None else readers[0].config()
    layout = base.reflectors
    if not layout:
        raise MissingDataError("layout refine: no reflector layout: neither the configuration "
                               "nor the log has one")
    fixed = _fixed_ids(o.fix, [r.id for r in layout])
    drives = []
    for path, reader in zip(o.logs, readers, strict=True):
        cfg = given if given is not None else reader.config()
        motion = motion_params("ekf", resolve_params("ekf", cfg.estimators, None))
        data = apply_installation(load_log(reader, layout, decode_scans=True), cfg.vehicle)
        drives.append(prepare_drive(path, data, cfg.vehicle, layout, motion, settings))
    started = time.perf_counter()
    result = refine(drives, layout, fixed, settings)
    solve_s = time.perf_counter() - started
    names = ", ".join(Path(p).name for p in o.logs)
    write_layout(out, result.layout, comment=f"reflector layout refined by lgvtool layout "
                                             f"refine from {names}")
    rows = [{"id": r.reflector.id, "x": r.reflector.x, "y": r.reflector.y,
             "surveyed": [r.surveyed.x, r.surveyed.y], "shift_m": list(r.shift),
             "sigma_m": [r.sigma_x, r.sigma_y], "correlation": r.correlation,
             "observations": r.observations, "fixed": r.fixed,
             "range_offset_m": r.range_offset} for r in result.reflectors]
    document = {"logs": list(o.logs), "output": str(out), "reflectors": rows,
                "observations": dict(result.counts), "noise": dict(result.noise),
                "rms": dict(result.rms), "range_offset_common_m": result.common_range_offset,
                "iterations": result.iterations,
                "solve_s": solve_s, "settings": as_dict(settings)}
    c = result.counts
    lines = [f"layout refine: {len(o.logs)} log{'s' if len(o.logs) != 1 else ''}, "
             f"{c['used']} of {c['total']} landmark observations ({c['without_id']} without "
             f"an id, {c['not_associated']} outside the gate: left out), {c['nodes']} poses; "
             f"{result.iterations} steps, {solve_s:.2f} s",
             f"noise found: range {result.noise['range_m'] * 1e3:.1f} mm, bearing "
             f"{result.noise['bearing_rad'] * 1e3:.2f} mrad; survey prior "
             f"{settings.survey_sigma_m * 1e3:g} mm per axis",
             "",
             f"{'id':>6} {'x m':>9} {'y m':>9} {'dx mm':>7} {'dy mm':>7} {'sx mm':>6} "
             f"{'sy mm':>6} {'seen':>6}"]
    for r in result.reflectors:
        dx, dy = r.shift
        mark = "  fixed" if r.fixed else ("  not seen" if not r.observations else "")
        lines.append(f"{r.reflector.id:>6} {r.reflector.x:>9.4f} {r.reflector.y:>9.4f} "
                     f"{dx * 1e3:>7.1f} {dy * 1e3:>7.1f} {r.sigma_x * 1e3:>6.1f} "
                     f"{r.sigma_y * 1e3:>6.1f} {r.observations:>6}{mark}")
    lines += ["", f"-> {out} ({len(result.reflectors)} reflectors)"]
    return JobOutput(document, printable("\n".join(lines)))
