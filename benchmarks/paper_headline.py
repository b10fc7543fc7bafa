"""The paper's headline on the calibrated simulator: ``pf-paper`` against the laser, per seed.

For each seed the script simulates ``paper-circle`` (the paper's eight rotations), runs
``lgvtool evaluate``'s estimators on it with the default settings and prints, per seed and on
average, Table 1's Average row of every estimator (per-rotation radial RMSE and variance, mm
and mm^2), the ratios ``pf-paper / laser`` and ``pf / laser``, and the true RMSE of O against
the ground truth, per rotation and averaged as Table 1 does (mm; the uniform start of the
particle filters, before the first rotation, is not in it). Three tables:

- ``reflectors``: the defaults, i.e. the filters weigh the reflector scans (``/nav/reflectors``);
- ``poses``: ``--set <estimator>.observations=poses`` for ekf, pf-paper and pf, i.e. what a
  user gets from a NAV200 recording (its host protocol carries the pose, not the reflectors);
- ``no-deskew``: ``pf-paper.deskew=false``, all reflectors of a revolution at one instant.

Usage::

    python benchmarks/paper_headline.py [--seeds 200-209] [--tables reflectors,poses,no-deskew]
                                        [--json]

The seeds default to ones the simulator and the filters were not tuned on (those were 1-10).
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

from pf_paper_convergence import seeds_of

ESTIMATORS = ("laser", "deadreckoning", "ekf", "pf-paper", "pf")
TABLES: dict[str, dict[str, Any]] = {
    "reflectors": {},
    "poses": {"ekf.observations": "poses", "pf-paper.observations": "poses",
              "pf.observations": "poses"},
    "no-deskew": {"pf-paper.deskew": False},
}
"""Table name -> estimator settings."""


def measure(log: Path, settings: dict[str, Any]) -> dict[str, dict[str, float]]:
    """Per estimator: per-rotation radial RMSE (mm) and variance (mm^2), and the RMSE of the
    true position error per rotation (mm), each averaged over the rotations (Table 1's
    Average row)."""
    from lgvtool.app.evaluate_job import evaluate_log

    res = evaluate_log(log, settings=settings)
    out = {}
    for name in ESTIMATORS:
        ev = res.estimators.get(name)
        if ev is None or ev.average is None:
            continue
        inside = [r.truth_rmse for r in ev.rotations if r.truth_rmse is not None]
        out[name] = {"rmse_mm": ev.average.rmse * 1000.0,
                     "variance_mm2": ev.average.variance * 1e6,
                     "truth_rmse_mm": float(np.mean(inside)) * 1000.0 if inside else math.nan}
    return out


def markdown(title: str, runs: list[tuple[int, dict[str, dict[str, float]]]]) -> str:
    """One table: a row per seed and the mean over the seeds."""
    head = ["seed"]
    for n in ESTIMATORS:
        head += [f"{n} RMSE mm", f"{n} σ² mm²"]
    head += ["pf-paper/laser RMSE", "pf-paper/laser σ²", "pf/laser RMSE"]
    head += [f"{n} true RMSE in rotations mm" for n in ESTIMATORS]
    lines = [f"**{title}**", "", "| " + " | ".join(head) + " |",
             "|" + "---:|" * len(head)]

    def row(label: str, figs: dict[str, dict[str, float]]) -> str:
        cells = [label]
        for n in ESTIMATORS:
            f = figs.get(n, {})
            cells += [f"{f.get('rmse_mm', math.nan):.1f}", f"{f.get('variance_mm2', math.nan):.0f}"]
        lz, pp, pf = figs["laser"], figs["pf-paper"], figs["pf"]
        cells += [f"{pp['rmse_mm'] / lz['rmse_mm']:.2f}",
                  f"{pp['variance_mm2'] / lz['variance_mm2']:.2f}",
                  f"{pf['rmse_mm'] / lz['rmse_mm']:.2f}"]
        cells += [f"{figs.get(n, {}).get('truth_rmse_mm', math.nan):.1f}" for n in ESTIMATORS]
        return "| " + " | ".join(cells) + " |"

    for seed, figs in runs:
        lines.append(row(str(seed), figs))
    mean = {n: {k: float(np.mean([f[n][k] for _, f in runs])) for k in runs[0][1][n]}
            for n in ESTIMATORS if all(n in f for _, f in runs)}
    lines.append(row("mean", mean))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="200-209")
    ap.add_argument("--tables", default="reflectors,poses,no-deskew")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    tables = args.tables.split(",")
    results: dict[str, list[tuple[int, dict[str, dict[str, float]]]]] = {t: [] for t in tables}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds_of(args.seeds):
            log = Path(tmp) / f"paper-circle-{seed}.mcap"
            write_log(simulate("paper-circle", seed=seed), log)
            for t in tables:
                results[t].append((seed, measure(log, TABLES[t])))
            log.unlink()
            print(f"seed {seed} done", file=sys.stderr, flush=True)
    if args.json:
        print(json.dumps({t: [{"seed": s, **f} for s, f in r] for t, r in results.items()},
                         indent=2))
    else:
        for t in tables:
            print(markdown(f"{t}: {TABLES[t] or 'defaults'}", results[t]) + "\n")
    print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
