"""``lgvtool calibrate``: estimate the vehicle's installation from logs into a configuration
(:func:`lgvtool.app.calibrate_job.calibrate_logs`)."""

from __future__ import annotations

import click

from lgvtool.options import (
    complete_estimators,
    force_option,
    print_output,
    progress_option,
    seed_option,
    split_names,
)


def _names(value: str | None, option: str) -> list[str]:
    return [] if value is None else split_names([value], option)


@click.command()
@click.argument("logs", nargs=-1, required=True, metavar="LOG...",
                type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              metavar="FILE", help="Calibrated configuration (TOML) to write.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              metavar="FILE", help="Starting values, map and settings (default: the first "
              "log's stored configuration).")
@click.option("--estimate", metavar="LIST", help="Quantities to estimate, comma-separated "
              "(default: all the logs' data has; docs/calibration.md).")
@click.option("--fix", metavar="LIST", help="Quantities to hold at their starting values.")
@click.option("--observations", type=click.Choice(["auto", "scans", "poses"]), default="auto",
              show_default=True, help="Reflector scans (with the poses beside them for their "
              "age) or NAV poses.")
@click.option("--allow-unobservable", is_flag=True, help="Hold what the drives cannot observe "
              "at its starting value (a warning) instead of refusing.")
@click.option("--compare", "compare_with", default="laser,ekf", show_default=True,
              metavar="LIST", shell_complete=complete_estimators,
              help="Estimators replayed with the starting and the calibrated configuration "
              "for the before/after table; 'none': no table.")
@seed_option("Seed of the estimators of the before/after table.")
@click.option("--start-at-truth", is_flag=True, help="Start the estimators of the before/after "
              "table at the logs' ground truth (as evaluate --start-at-truth).")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
@force_option
@progress_option()
def calibrate(logs: tuple[str, ...], output: str, config_path: str | None,
              estimate: str | None, fix: str | None, observations: str,
              allow_unobservable: bool, compare_with: str, seed: int, start_at_truth: bool,
              as_json: bool, force: bool, show_progress: bool = True) -> None:
    """Estimate the NAV mounting (nav_x, nav_y mm; nav_yaw deg), the wheel radii and the track
    (mm), the gyro's scale and bias (deg/s), the NAV-to-host time offset and the NAV poses' age
    (ms), or, with generic odometry, its two scales and its drift (deg/m), from one or more
    LOG... by a batch least squares over the whole drives, each with its 1-sigma; write them
    into FILE (-o: the starting configuration with the calibrated vehicle, TOML). From NAV
    poses also their observation model (the age ms and the skew lever m, each with its 1-sigma,
    and the noise at standstill), written as the settings of ekf, pf and pf-paper.

    Prints the estimates, the pose model and a before/after table of the estimators' errors. Exit 2 for bad
    input, a drive that cannot observe what is asked (unless --allow-unobservable), or an
    output that is an input.
    """
    from lgvtool.app.calibrate_job import CalibrateOptions, calibrate_logs

    chosen = [] if compare_with.strip().lower() == "none" else _names(compare_with, "--compare")
    print_output(calibrate_logs(CalibrateOptions(
        tuple(logs), output, config_path=config_path,
        estimate=tuple(_names(estimate, "--estimate")) or None,
        fix=tuple(_names(fix, "--fix")), observations=observations,
        allow_unobservable=allow_unobservable, compare_with=tuple(chosen), seed=seed,
        start_at_truth=start_at_truth, force=force, show_progress=show_progress)), as_json)
