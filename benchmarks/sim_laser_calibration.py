"""The simulated laser navigation against the laser columns of the paper's Table 1, over seeds.

For each seed the script simulates a circle scenario (default ``paper-circle``) and scores the
NAV200 poses the host received exactly as ``lgvtool evaluate`` scores its ``laser`` estimator
(:func:`lgvtool.sim.calibration.laser_evaluation`; no log is written). It prints per seed the
average per-rotation RMSE (mm) and variance (mm^2), the smallest and largest variance of a
rotation and the mean error (mm), then the figures over all seeds against the calibration's
targets: average RMSE 51-63 mm, average variance 355-590 mm^2 (the paper's 56.9 mm and 473 mm^2
within +-10 % and +-25 %), every rotation 250-800 mm^2, mostly bias.

Usage::

    python benchmarks/sim_laser_calibration.py [--scenario paper-circle] [--seeds 100-139]
                                               [--set section.key=value ...]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pf_paper_convergence import seeds_of, settings_of


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    from lgvtool.sim.calibration import laser_evaluation
    from lgvtool.sim.simulation import simulate

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="paper-circle")
    ap.add_argument("--seeds", default="100-139")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="simulator setting, as for lgvtool simulate --set")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    overrides = settings_of(args.set)
    started = time.perf_counter()
    rows = []
    for seed in seeds_of(args.seeds):
        laser = laser_evaluation(simulate(args.scenario, seed=seed, overrides=overrides))
        assert laser.average is not None
        var = [r.stats.variance * 1e6 for r in laser.rotations]
        rows.append({"seed": seed, "rotations": len(var), "rmse_mm": laser.average.rmse * 1e3,
                     "variance_mm2": laser.average.variance * 1e6, "min_mm2": min(var),
                     "max_mm2": max(var), "mean_mm": laser.average.mean * 1e3})
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print("| seed | rotations | RMSE mm | σ² mm² | smallest σ² mm² | largest σ² mm² | mean mm |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['seed']} | {r['rotations']} | {r['rmse_mm']:.1f} | {r['variance_mm2']:.0f} "
              f"| {r['min_mm2']:.0f} | {r['max_mm2']:.0f} | {r['mean_mm']:.1f} |")
    rmse = np.array([r["rmse_mm"] for r in rows])
    var = np.array([r["variance_mm2"] for r in rows])
    lo, hi = min(r["min_mm2"] for r in rows), max(r["max_mm2"] for r in rows)
    bias = float(np.mean([r["mean_mm"] for r in rows]))
    print(f"\n{len(rows)} seeds: RMSE {rmse.mean():.1f} mm ({rmse.min():.1f} to {rmse.max():.1f}; "
          f"target 51-63), variance {var.mean():.0f} mm² ({var.min():.0f} to {var.max():.0f}; "
          f"target 355-590), every rotation {lo:.0f} to {hi:.0f} mm² (target 250-800), "
          f"mean error {bias:.1f} mm")
    print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
