"""Calibrating a vehicle's installation from logs into a configuration (``lgvtool
calibrate``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from lgvtool.app.job_output import JobOutput
from lgvtool.errors import InputError
from lgvtool.json_types import JSONObject


class UnobservableRefusal(InputError):
    """The refusal of drives that cannot observe what is asked: one short line, with the
    1-sigma and the needs of each quantity as ``details`` (``--json``) and ``detail_lines``
    (``LGVTOOL_DEBUG=1``), which :func:`lgvtool.cli.main` prints."""

    def __init__(self, message: str, details: JSONObject, detail_lines: list[str]) -> None:
        super().__init__(message)
        self.details = details
        self.detail_lines = detail_lines


#: what each quantity needs the drives to contain, in a word or two (the full reason,
#: ``lgvtool.calibrate.quantities.QUANTITIES[name].needs``, comes with --json)
_NEEDS: dict[str, tuple[str, ...]] = {
    "nav_x": ("turns", "speed changes"),
    "nav_y": ("turns", "speed changes"),
    "nav_yaw": ("turns", "straights"),
    "wheel_radius_left": ("turns", "straights"),
    "wheel_radius_right": ("turns", "straights"),
    "track": ("turns", "straights"),
    "gyro_scale": ("turns",),
    "gyro_bias": ("standstill or straights",),
    "nav_time_offset": ("speed changes",),
    "nav_pose_age": ("turns", "NAV poses beside scans"),
    "odom_scale_v": ("travel",),
    "odom_scale_w": ("turns",),
    "odom_yaw_per_m": ("turns", "straights"),
}
_NEEDS_ORDER = ("turns", "straights", "speed changes", "standstill or straights", "travel",
                "NAV poses beside scans")
"""The order the needs are said in."""

_MAX_LINE = 200
"""Characters of the refusal's line at most (names past it are counted, not listed)."""


def _unobservable_refusal(exc: InputError) -> UnobservableRefusal | None:
    """The short refusal for the error of quantities the drives cannot observe (raised by
    :func:`lgvtool.calibrate.calibration_run.calibrate` from an ``UnobservableError``), else
    None."""
    import sys

    from lgvtool.calibrate.quantities import QUANTITIES

    solve = sys.modules.get("lgvtool.calibrate.solve")  # imported if it raised
    cause = exc.__context__
    if (solve is None or not isinstance(cause, solve.UnobservableError) or not cause.sigma
            or not set(cause.sigma) <= set(QUANTITIES)):
        return None
    details: dict[str, Any] = {}
    lines: list[str] = []
    for name, sigma in cause.sigma.items():
        q = QUANTITIES[name]
        finite = math.isfinite(sigma)
        # sigma in the unit shown (None: unbounded), sigma_si in SI units
        details[name] = {"sigma": sigma * q.display if finite else None, "unit": q.unit,
                         "sigma_si": sigma if finite else None, "needs": q.needs}
        shown = f"{sigma * q.display:.3g} {q.unit}".strip() if finite else "unbounded"
        lines.append(f"{name}: 1-sigma {shown}; needs {q.needs}")
    wanted = {w for n in cause.sigma for w in _NEEDS.get(n, ("travel",))}
    needs = [w for w in _NEEDS_ORDER if w in wanted]
    said = needs[0] if len(needs) == 1 else f"{', '.join(needs[:-1])} and {needs[-1]}"
    names = list(cause.sigma)
    for shown_names in range(len(names), 0, -1):
        listed = ", ".join(names[:shown_names])
        if shown_names < len(names):
            listed += f" and {len(names) - shown_names} more"
        line = (f"the drives cannot observe {listed}: drive with {said}, or use --fix or "
                f"--allow-unobservable (--json: details)")
        if len(line) <= _MAX_LINE:
            break
    return UnobservableRefusal(line, {"unobservable": details}, lines)


@dataclass(frozen=True, slots=True)
class CalibrateOptions:
    """What :func:`calibrate_logs` calibrates from, and how (``lgvtool calibrate``)."""

    logs: tuple[str, ...]
    """The logs (MCAP) whose whole drives are solved together, in order."""
    output: str
    """The calibrated configuration (TOML) to write; an existing file is replaced only with
    :attr:`force`, an input never."""
    config_path: str | None = None
    """The starting configuration (TOML); None: the first log's stored one."""
    estimate: tuple[str, ...] | None = None
    """The quantities to estimate (names as in docs/calibration.md); None: all the data has."""
    fix: tuple[str, ...] = ()
    """The quantities held at their starting values."""
    observations: str = "auto"
    """What the solve observes: auto, scans (reflector scans, with the poses beside them for
    their age) or poses (NAV poses)."""
    allow_unobservable: bool = False
    """Hold what the drives cannot observe at its starting value (a warning) instead of
    refusing."""
    compare_with: tuple[str, ...] = ("laser", "ekf")
    """Estimators replayed with the starting and the calibrated configuration for the
    before/after table; empty: no table."""
    seed: int = 0
    """Seed of the before/after table's estimators."""
    start_at_truth: bool = False
    """Start the before/after table's estimators at the logs' ground truth."""
    force: bool = False
    """Replace an existing :attr:`output`."""
    show_progress: bool = True
    """Progress on stderr once the calibration takes over a second."""


def calibrate_logs(options: CalibrateOptions) -> JobOutput:
    """Estimate the installation (NAV mounting nav_x, nav_y mm and nav_yaw deg, wheel radii
    and track mm, gyro scale and bias deg/s, NAV time offset and pose age ms, or the generic
    odometry's two scales and its drift deg/m) from the ``options``' logs by a batch least
    squares over the whole drives, and the NAV poses' observation model (age s, skew lever m,
    noise at standstill m and rad; :mod:`lgvtool.calibrate.pose_calibration`), and write the
    starting configuration with the calibrated vehicle and the pose model's estimator settings
    into its output (TOML); see :class:`CalibrateOptions`.

    The document is the calibration (each estimate with its 1-sigma, the table, the warnings)
    with the output's path; the text the estimates and the before/after table; the warnings
    (what is held unobservable, drives that disagree) are printed apart, on stderr.

    :raises InputError: (exit 2) a bad input, a drive that cannot observe what is asked, or a
        refused output.
    """
    from lgvtool.calibrate.calibration_run import calibrate
    from lgvtool.calibrate.calibration_tables import text, toml
    from lgvtool.config import load_config
    from lgvtool.outputs import atomic_output, guard_output, printable
    from lgvtool.progress import Progress

    o = options
    out = guard_output(o.output, [*o.logs, o.config_path], force=o.force)
    cfg = load_config(o.config_path) if o.config_path else None
    with Progress(0, "calibrate", enabled=o.show_progress, delay_s=1.0) as bar:
        try:
            result = calibrate(list(o.logs), config=cfg,
                               estimate=list(o.estimate) if o.estimate else None,
                               fix=list(o.fix), observations=o.observations,
                               allow_unobservable=o.allow_unobservable,
                               compare_with=list(o.compare_with), seed=o.seed,
                               start_at_truth=o.start_at_truth, progress=bar)
        except InputError as exc:
            short = _unobservable_refusal(exc)
            if short is None:
                raise
            raise short from None
    with atomic_output(out) as tmp:
        tmp.write_text(toml(result), encoding="utf-8")
    return JobOutput(dict(result.to_dict(), output=str(out)), printable(text(result, str(out))),
                     warnings=list(result.warnings))
