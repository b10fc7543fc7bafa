"""Calibrating a vehicle's installation from logs into a configuration (``lgvtool
calibrate``)."""

from __future__ import annotations

from collections.abc import Sequence

from lgvtool.app.job_output import JobOutput


def calibrate_logs(logs: Sequence[str], output: str, *, config_path: str | None = None,
                   estimate: Sequence[str] | None = None, fix: Sequence[str] = (),
                   observations: str = "auto", allow_unobservable: bool = False,
                   compare_with: Sequence[str] = ("laser", "ekf"), seed: int = 0,
                   start_at_truth: bool = False, force: bool = False,
                   show_progress: bool = True) -> JobOutput:
    """Estimate the installation (NAV mounting nav_x, nav_y mm and nav_yaw deg, wheel radii
    and track mm, gyro scale and bias deg/s, NAV time offset and pose age ms, or the generic
    odometry's two scales and its drift deg/m) from ``logs`` by a batch least squares over the
    whole drives, and write the starting configuration (``config_path``, default: the first
    log's) with the calibrated vehicle into ``output`` (TOML; an existing file is replaced only
    with ``force``, an input never). ``estimate``: the quantities to estimate (default: all the
    data has), ``fix``: those held at their starting values, ``observations``: auto, scans or
    poses, ``allow_unobservable``: hold what the drives cannot observe (a warning) instead of
    refusing. ``compare_with`` estimators are replayed (``seed``, ``start_at_truth``) with
    the starting and the calibrated configuration for the before/after table (empty: none).

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

    out = guard_output(output, [*logs, config_path], force=force)
    cfg = load_config(config_path) if config_path else None
    with Progress(0, "calibrate", enabled=show_progress, delay_s=1.0) as bar:
        result = calibrate(list(logs), config=cfg, estimate=list(estimate) if estimate else None,
                           fix=list(fix), observations=observations,
                           allow_unobservable=allow_unobservable, compare_with=list(compare_with),
                           seed=seed, start_at_truth=start_at_truth, progress=bar)
    with atomic_output(out) as tmp:
        tmp.write_text(toml(result), encoding="utf-8")
    return JobOutput(dict(result.to_dict(), output=str(out)), printable(text(result, str(out))),
                     warnings=list(result.warnings))
