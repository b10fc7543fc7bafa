"""``lgvtool compare``: two results (``audit.json`` or ``table1.json``) KPI by KPI, with the
gate of ``evaluate --baseline --tolerance`` (:func:`lgvtool.app.compare_job.compare_results`).
Named ``compare_command`` because module names are unique across the package
(``calibrate/compare.py``)."""

from __future__ import annotations

import inspect

import click

from lgvtool.app.compare_job import SITE_TOLERANCE_M

_HELP = """Compare two results of one site, the first (A, the baseline) and the second
    (B): two audit.json
    (lgvtool audit LOG -o DIR) or two evaluation results (table1.json, lgvtool evaluate LOG -o
    DIR), each given as the file or the folder holding it. Prints every KPI side by side with
    its unit, which way is better, B - A, the change in percent and whether B is better or
    worse (WORSE: beyond the tolerance); then the gate, one line per check (on stderr).

    Two audits are of one site when their layouts hold the same reflector ids, each within
    --site-tolerance; other pairs are refused (--any-site compares them anyway). An
    evaluation result holds no layout: two are compared without that check, and a note says
    so. compare reads results only and never runs an estimator: given a log, it says which
    command makes a result of it.

    Exit 0 no KPI worse beyond the tolerance, 1 a KPI is (every check listed on stderr),
    2 bad input (a log, a file that is no result, two results of different kinds or sites).
    """


@click.command(help=inspect.cleandoc(_HELP))
@click.argument("a", metavar="FILE|DIR", type=click.Path(path_type=str))
@click.argument("b", metavar="FILE|DIR", type=click.Path(path_type=str))
@click.option("--tolerance", default=None, metavar="P",
              help="Allowed worsening of each KPI against A, percent (e.g. 10%; default 0%).")
@click.option("--site-tolerance", "site_tolerance_m", type=float, default=None, metavar="M",
              help="Largest distance between namesake reflectors of two layouts of one site, "
                   f"m (default {SITE_TOLERANCE_M:g}).")
@click.option("--any-site", is_flag=True,
              help="Compare two audits whose layouts differ instead of refusing them.")
@click.option("--json", "as_json", is_flag=True, help="Print the comparison as JSON.")
def compare(a: str, b: str, tolerance: str | None, site_tolerance_m: float | None,
            any_site: bool, as_json: bool) -> None:
    import json
    import sys

    from lgvtool.app.compare_job import CompareOptions, compare_results
    from lgvtool.app.option_values import parse_tolerance
    from lgvtool.options import warn
    from lgvtool.outputs import printable

    run = compare_results(CompareOptions(a, b, tolerance=parse_tolerance(tolerance),
                                         site_tolerance_m=site_tolerance_m, any_site=any_site))
    if as_json:
        click.echo(json.dumps(run.document, indent=2))
    else:
        click.echo("\n".join(printable(line) for line in run.lines))
        for note in run.notes:
            warn(note)
    for line in run.check_lines:
        click.echo(line, err=True)
    if run.failures:
        sys.exit(1)  # every check listed above; not an error (exit 2) but a failed check
