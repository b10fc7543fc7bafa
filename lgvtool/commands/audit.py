"""``lgvtool audit``: which reflectors of a site are missing, moved, weak or ambiguous, which
recurring detections match none, and the coverage along the drive
(:func:`lgvtool.app.audit_job.audit_logs`)."""

from __future__ import annotations

import inspect

import click

from lgvtool.options import (
    complete_estimators,
    force_option,
    progress_option,
    scheduler_options,
    seed_option,
    set_option,
    workers_type,
)

_HELP = """Audit a site's reflector layout from ordinary drives: replay LOG... with one
    estimator (default: the best each log allows, pf on reflector scans), then judge each
    layout reflector from its expected sightings (in range, in view, not hidden) against its
    actual ones: ok, missing, moved (with its shift and 1-sigma), weak or ambiguous; list the
    recurring detections that match no reflector (unmapped); the coverage along the drive; the
    NAV's own health (time in navigation, dropouts, pose jumps); and the error along and across
    the path by speed, curvature and direction (against the truth where the log has one);
    the stations: standstills grouped into stations (or assigned to the named stations of
    --stations FILE) and each pose source's repeatability there.

    Writes audit.json and report.html into DIR and prints a one-screen summary (--json: the
    document). A log without landmark observations (a NAV200 recording of poses) gets the
    coverage only, and a line saying so. Several logs of one site are pooled per reflector;
    they run on a local Dask cluster (--workers) or a scheduler (--scheduler) when the fleet
    extra is installed. One row per vehicle and day goes to kpis.csv (and kpis.parquet with
    pyarrow); each log's evidence is kept under DIR/logs/, and --resume re-runs only the logs
    not kept there. Thresholds: --set GROUP.<key>=<value>, GROUP one of audit, view,
    coverage, navigation, segments, stations (docs/audit.md).

    Exit 0 success, 2 bad input.
    """


@click.command(help=inspect.cleandoc(_HELP))
@click.argument("logs", nargs=-1, required=True, metavar="LOG...",
                type=click.Path(dir_okay=False, path_type=str))
@click.option("-o", "--output", "outdir", required=True, type=click.Path(path_type=str),
              metavar="DIR", help="Write audit.json and report.html into the folder DIR.")
@click.option("--json", "as_json", is_flag=True, help="Print the audit.json document instead "
              "of the summary.")
@click.option("-e", "--estimator", "estimator", metavar="NAME",
              shell_complete=complete_estimators,
              help="Estimator whose replayed pose the audit uses: laser, deadreckoning, ekf, "
                   "pf-paper, pf; default: the best each log allows (pf with reflector scans, "
                   "else ekf, else laser).")
@seed_option("Seed of the estimator's random draws.")
@set_option("A threshold (audit.moved_min_shift_m=0.03), the device's view "
            "(view.range_max_m=30), the coverage's (coverage.gdop_max=3), the navigation "
            "health's (navigation.jump_m=0.3), the stations' (stations.min_standstill_s=3) or an "
            "estimator parameter (pf.particles=500); repeatable; docs/audit.md.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              help="Configuration TOML (vehicle, layout) instead of the one stored in each "
                   "log.")
@click.option("--stations", "stations_path", type=click.Path(dir_okay=False, path_type=str),
              metavar="FILE", help="Stations file (TOML: [[stations]] with name, x, y, "
              "heading deg, tolerance_xy_m, tolerance_deg): standstills are assigned to these "
              "and judged against their tolerance; default: stations found automatically.")
@click.option("--workers", type=workers_type(), default=None,
              help="Audit several logs on a local Dask cluster of this many processes "
                   "(default with several logs: one per CPU).")
@scheduler_options
@force_option
@click.option("--resume", is_flag=True, help="Take each log's evidence kept in DIR/logs/ by "
              "an earlier audit into DIR (same log path, size, mtime and options) instead of "
              "re-running it; the outputs are replaced.")
@progress_option()
def audit(logs: tuple[str, ...], outdir: str, as_json: bool, estimator: str | None,
          seed: int, sets: tuple[str, ...], config_path: str | None,
          stations_path: str | None, workers: int | None,
          scheduler: str | None, tls_ca_file: str | None, tls_cert: str | None,
          tls_key: str | None, force: bool, resume: bool = False,
          show_progress: bool = True) -> None:
    import json

    from lgvtool.app.audit_job import AuditOptions, audit_logs
    from lgvtool.app.option_values import parse_settings
    from lgvtool.outputs import printable

    run = audit_logs(AuditOptions(
        tuple(logs), outdir, estimator=estimator, seed=seed,
        settings=parse_settings(sets), config_path=config_path,
        stations_path=stations_path, workers=workers,
        scheduler=scheduler, tls_ca_file=tls_ca_file, tls_cert=tls_cert, tls_key=tls_key,
        force=force, resume=resume, show_progress=show_progress))
    if as_json:
        click.echo(json.dumps(run.document, indent=2))
    else:
        click.echo("\n".join(printable(line) for line in run.lines))
