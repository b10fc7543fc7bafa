"""``lgvtool replay``: run estimators over a log and write a new log with their estimates
(:func:`lgvtool.app.replay_job.replay_log`)."""

from __future__ import annotations

import click

from lgvtool.options import (
    Number,
    compression_option,
    estimator_option,
    force_option,
    progress_option,
    seed_option,
    set_option,
    split_names,
    threads_option,
    warn,
)
from lgvtool.values import MAX_COUNT, MAX_WALL_S


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="Output log (MCAP): the input's messages plus the estimates.")
@estimator_option("Estimator to run: laser, deadreckoning, ekf, pf-paper, pf; default: all five")
@click.option("--particles", type=Number(int, 1, MAX_COUNT), default=None,
              help="Particle count of the particle filters run (pf-paper, pf).")
@seed_option("Seed of every random draw; the same seed gives identical output.")
@set_option()
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              default=None, help="Configuration file (TOML): vehicle, area, reflectors, "
                                 "[estimators.*]. Default: the one stored in the log.")
@click.option("--start-at-truth", is_flag=True,
              help="Start every estimator at the log's ground truth (/truth/pose).")
@click.option("--cloud-period", type=Number(float, 0.0, MAX_WALL_S), default=2.0,
              show_default=True, help="Keep one particle cloud per this many seconds, s.")
@click.option("--cloud-size", type=Number(int, 0, MAX_COUNT), default=50, show_default=True,
              help="At most this many particles per kept cloud (0: no clouds).")
@compression_option("Chunk compression of the output (the input's messages and the estimates, "
                    "merged in time order).")
@click.option("--view/--no-view", default=True, show_default=True,
              help="Also write the channels Foxglove draws: frames, NAV head and scans, "
                   "covariance ellipses, reference circle (docs/log-format.md).")
@threads_option("one per estimator, at most one per CPU, with the compiled kernels of the fast extra; else 1")
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@progress_option("Progress on stderr once the replay takes over a second.")
def replay(log: str, output: str, estimators: tuple[str, ...], particles: int | None,
           seed: int, sets: tuple[str, ...], config_path: str | None, start_at_truth: bool,
           cloud_period: float, cloud_size: int, compression: str, view: bool,
           threads: int | None, as_json: bool, force: bool, show_progress: bool = True
           ) -> None:
    """Replay LOG through the localisation estimators and write the log FILE (-o).

    FILE is a complete log: every message of LOG, plus per estimator NAME the pose of the
    target rotation centre O on /estimate/NAME/pose (foxglove.PoseInFrame), the pose with its
    covariance on /estimate/NAME/state (lgvtool.PoseEstimate) and, for particle filters,
    decimated particle clouds on /estimate/NAME/particles (foxglove.PosesInFrame); with
    --view (the default) also what Foxglove's 3D panel draws: the frames map -> NAME/O ->
    NAME/head, covariance ellipses, the NAV head, its scans and the reference circle. The
    effective estimator settings and the seed are stored in the metadata record 'replay'.
    Positions in m, headings in rad, times in the log's own clock.
    """
    from lgvtool.app.option_values import parse_settings
    from lgvtool.app.replay_job import ReplayOptions, replay_log

    summary = replay_log(ReplayOptions(
        log, output, estimators=tuple(split_names(estimators)), particles=particles, seed=seed,
        settings=parse_settings(sets), config_path=config_path, start_at_truth=start_at_truth,
        cloud_period=cloud_period, cloud_size=cloud_size, compression=compression, view=view,
        force=force, threads=threads, show_progress=show_progress), warn=warn)
    if as_json:
        import json

        click.echo(json.dumps(summary, indent=2))
    else:
        parts = ", ".join(f"{n} {v['estimates']}" for n, v in summary["estimators"].items())
        click.echo(f"wrote {output}: estimates per estimator: {parts}")
