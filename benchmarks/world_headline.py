"""The headline on the honest world: every estimator against the laser, per scenario and
observation mode, over seeds chosen before tuning.

For each scenario, observation mode and seed the script simulates a log, runs the estimators as
``lgvtool evaluate`` does (default settings, each from its own start) and records per estimator
the truth RMSE, p95 and max of the position of O (mm), and on circle scenarios Table 1's
Average row (per-rotation radial RMSE, mm, and variance, mm^2), plus the true path's radial
RMSE about the planned circle (mm). It prints per scenario and mode the mean over the seeds and
each estimator's truth RMSE as a ratio to the laser's (mean of the per-seed ratios, and the
worst seed).

Observation modes (what the log carries besides the MCU):

- ``nav200``: a NAV200 recording, NAV poses only (the default of ``lgvtool simulate``);
- ``paper``: the NAV200 with its per-revolution reflector scans logged as the paper's
  experiment had them (``sim.paper_scans = true``; no NAV200 host protocol delivers them);
- ``nav350``: a NAV350 recording, its pose and its landmarks with the device's own ids.

Usage::

    python benchmarks/world_headline.py [--scenarios paper-circle,warehouse,fast,degraded]
        [--modes nav200,paper,nav350] [--seeds 9000-9009] [--set section.key=value ...]
        [--estimators laser,deadreckoning,ekf,pf-paper,pf] [--json FILE] [--markdown]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pf_paper_convergence import seeds_of, settings_of

MODES: dict[str, dict[str, Any]] = {
    "nav200": {},
    "paper": {"sim.paper_scans": True},
    "nav350": {"sim.nav_device": "nav350"},
}
"""Observation mode -> simulator settings."""
ESTIMATORS = ("laser", "deadreckoning", "ekf", "pf-paper", "pf")


def measure(log: Path, estimators: tuple[str, ...],
            settings: dict[str, Any] | None = None) -> dict[str, Any]:
    """Figures of one log: per estimator truth RMSE/p95/max (mm) and, on circle scenarios,
    Table 1's Average row (mm, mm^2); the true path's radial RMSE about the circle (mm).
    ``settings``: estimator settings (``pf.particles``) over the defaults."""
    from lgvtool.evaluate.log_evaluation import evaluate_log

    res = evaluate_log(log, estimators=list(estimators), settings=settings or None)
    out: dict[str, Any] = {"estimators": {}}
    if res.truth_path is not None:
        out["truth_path_rmse_mm"] = res.truth_path.rmse * 1000.0
        out["truth_path_bias_mm"] = res.truth_path.mean * 1000.0
    for name, ev in res.estimators.items():
        figs: dict[str, float] = {}
        if ev.truth is not None:
            figs.update(truth_rmse_mm=ev.truth.position_rmse * 1000.0,
                        truth_p95_mm=ev.truth.position_p95 * 1000.0,
                        truth_max_mm=ev.truth.position_max * 1000.0)
        if ev.average is not None:
            figs.update(rotation_rmse_mm=ev.average.rmse * 1000.0,
                        rotation_variance_mm2=ev.average.variance * 1e6)
        out["estimators"][name] = figs
    return out


def _ratios(runs: list[dict[str, Any]], name: str, key: str) -> list[float]:
    """Per seed, ``name``'s figure ``key`` divided by the laser's (seeds with both)."""
    out = []
    for r in runs:
        mine, laser = r["estimators"].get(name, {}), r["estimators"].get("laser", {})
        if key in mine and key in laser:
            out.append(mine[key] / laser[key])
    return out


def summarise(runs: list[dict[str, Any]], estimators: tuple[str, ...]) -> dict[str, Any]:
    """Means over the seeds, and each estimator's truth-RMSE ratio to the laser (mean, worst)
    and p95 ratio (mean)."""
    out: dict[str, Any] = {"seeds": len(runs)}
    for key in ("truth_path_rmse_mm", "truth_path_bias_mm"):
        vals = [r[key] for r in runs if key in r]
        if vals:
            out[key] = float(np.mean(vals))
    for name in estimators:
        figs = [r["estimators"].get(name, {}) for r in runs]
        row: dict[str, float] = {}
        for key in ("truth_rmse_mm", "truth_p95_mm", "truth_max_mm", "rotation_rmse_mm",
                    "rotation_variance_mm2"):
            vals = [f[key] for f in figs if key in f and math.isfinite(f[key])]
            if vals:
                row[key] = float(np.mean(vals))
        ratios = _ratios(runs, name, "truth_rmse_mm")
        if ratios:
            row["truth_ratio_mean"] = float(np.mean(ratios))
            row["truth_ratio_worst"] = float(np.max(ratios))
        for key, label in (("truth_p95_mm", "p95_ratio_mean"),
                           ("rotation_rmse_mm", "rotation_ratio_mean")):
            ratios = _ratios(runs, name, key)
            if ratios:
                row[label] = float(np.mean(ratios))
        out[name] = row
    return out


def markdown(scenario: str, mode: str, summary: dict[str, Any],
             estimators: tuple[str, ...]) -> str:
    """One table per scenario and mode."""
    title = f"#### {scenario}, {mode} ({summary['seeds']} seeds)"
    if "truth_path_rmse_mm" in summary:
        title += (f"; true path about the circle {summary['truth_path_rmse_mm']:.1f} mm RMS, "
                  f"bias {summary['truth_path_bias_mm']:+.1f} mm")
    lines = [title, "", "| estimator | truth RMSE mm | p95 mm | max mm | / laser (mean, worst) "
             "| p95 / laser | rotation RMSE mm | rotation σ² mm² | rotation / laser |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]

    def cell(row: dict[str, float], key: str, fmt: str) -> str:
        return format(row[key], fmt) if key in row else "-"

    for name in estimators:
        row = summary.get(name, {})
        if not row:
            continue
        ratio = (f"{row['truth_ratio_mean']:.2f}, {row['truth_ratio_worst']:.2f}"
                 if "truth_ratio_mean" in row else "-")
        lines.append(f"| `{name}` | {cell(row, 'truth_rmse_mm', '.1f')} | "
                     f"{cell(row, 'truth_p95_mm', '.1f')} | {cell(row, 'truth_max_mm', '.0f')} | "
                     f"{ratio} | {cell(row, 'p95_ratio_mean', '.2f')} | "
                     f"{cell(row, 'rotation_rmse_mm', '.1f')} | "
                     f"{cell(row, 'rotation_variance_mm2', '.0f')} | "
                     f"{cell(row, 'rotation_ratio_mean', '.2f')} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenarios", default="paper-circle,warehouse,fast,degraded")
    ap.add_argument("--modes", default="nav200,paper,nav350")
    ap.add_argument("--seeds", default="9000-9009")
    ap.add_argument("--estimators", default=",".join(ESTIMATORS))
    ap.add_argument("--set", action="append", default=[], dest="sets",
                    help="a simulator setting, KEY=VALUE (sim.nav_device=nav350)")
    ap.add_argument("--estimator-set", action="append", default=[], dest="estimator_sets",
                    help="an estimator setting, KEY=VALUE (pf.jitter_m=0.001)")
    ap.add_argument("--json", dest="json_out", default=None)
    args = ap.parse_args(argv)
    started = time.perf_counter()
    estimators = tuple(args.estimators.split(","))
    extra = settings_of(args.sets)
    estimator_settings = settings_of(args.estimator_sets)
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios.split(","):
            for mode in args.modes.split(","):
                runs = []
                for seed in seeds_of(args.seeds):
                    log = Path(tmp) / f"{scenario}-{mode}-{seed}.mcap"
                    write_log(simulate(scenario, seed=seed,
                                       overrides={**MODES[mode], **extra}), log)
                    runs.append({"seed": seed, **measure(log, estimators, estimator_settings)})
                    log.unlink()
                    print(f"{scenario} {mode} seed {seed} done "
                          f"({time.perf_counter() - started:.0f} s)", file=sys.stderr, flush=True)
                summary = summarise(runs, estimators)
                results[f"{scenario}/{mode}"] = {"runs": runs, "summary": summary}
                print(markdown(scenario, mode, summary, estimators) + "\n", flush=True)
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(results, indent=1), encoding="utf-8")
    print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
