"""``lgvtool calibrate``: estimate the vehicle's installation from logs into a configuration."""

from __future__ import annotations

import click

from lgvtool.options import force_option, progress_option, seed_option, split_names


def _names(value: str | None) -> list[str]:
    return split_names([value or ""])


@click.command()
@click.argument("logs", nargs=-1, required=True, type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              metavar="VEHICLE.toml", help="Calibrated configuration to write.")
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
              metavar="LIST", help="Estimators replayed with the starting and the calibrated "
              "configuration for the before/after table; 'none': no table.")
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
    (ms), or, with generic odometry, its two scales, from one or more LOGS by a batch least
    squares over the whole drives, each with its 1-sigma; write them into VEHICLE.toml (the
    starting configuration with the calibrated vehicle).

    Prints the estimates and a before/after table of the estimators' errors. Exit 2 for bad
    input, a drive that cannot observe what is asked (unless --allow-unobservable), or an
    output that is an input.
    """
    import json

    from lgvtool.calibrate.calibration_run import calibrate as run_calibration
    from lgvtool.calibrate.calibration_tables import text, toml
    from lgvtool.config import load_config
    from lgvtool.outputs import atomic_output, guard_output, printable

    out = guard_output(output, [*logs, config_path], force=force)
    cfg = load_config(config_path) if config_path else None
    chosen = [] if compare_with.strip().lower() == "none" else _names(compare_with)
    from lgvtool.progress import Progress

    with Progress(0, "calibrate", enabled=show_progress, delay_s=1.0) as bar:
        result = run_calibration(list(logs), config=cfg, estimate=_names(estimate) or None,
                                 fix=_names(fix), observations=observations,
                                 allow_unobservable=allow_unobservable, compare_with=chosen,
                                 seed=seed, start_at_truth=start_at_truth, progress=bar)
    with atomic_output(out) as tmp:
        tmp.write_text(toml(result), encoding="utf-8")
    if as_json:
        click.echo(json.dumps(dict(result.to_dict(), output=str(out)), indent=2))
        return
    click.echo(printable(text(result, str(out))))
