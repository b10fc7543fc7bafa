"""Why ``pf-paper`` de-skews: weighed at one instant per revolution it is no better than the laser.

Run by hand::

    python benchmarks/pf_paper_sensitivity.py [--scenario paper-circle] [--seed 1]

The script simulates the scenario twice, with the NAV200's head-rotation skew (the default) and
without it (``nav.skew = false``), and replays each log through ``laser``, ``ekf`` and
``pf-paper`` started at the first NAV pose and without de-skew (every reflector of a revolution
weighed at one instant), varying in turn every constant of the paper's filter (each well above
and below its default), its particle count, which revolutions it uses and how it associates
reflectors; the last row is the default, de-skewed filter. For each run it
prints the radial RMSE against the circle of the kinematic radius (centre fitted to the run's
own trajectory, moving part only, as in bench_localize_accuracy.py) in mm, and its ratio to
``laser`` on the same log.

What it shows (docs/filter.md, "Why pf-paper de-skews"): every variant of the filter weighed at
one instant lands at about the laser's radial error when the reflector measurements carry the
skew, and well inside it when they do not; weighing each reflector at its own measurement time
(the default) removes the skew, as the EKF, which de-skews too, does.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_localize_accuracy import radial_rmse

from lgvtool.localize.replay_driver import load_log, replay_data
from lgvtool.log import LogReader
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate

START = {"pf-paper.init": "laser", "pf-paper.deskew": False}
VARIANTS: tuple[tuple[str, str, dict[str, Any]], ...] = (
    ("laser", "laser", {}),
    ("ekf", "ekf", {}),
    ("pf-paper at one instant, paper's constants", "pf-paper", {}),
    ("sigma_m 0.3 m", "pf-paper", {"pf-paper.sigma_m": 0.3}),
    ("sigma_m 3 m", "pf-paper", {"pf-paper.sigma_m": 3.0}),
    ("spread_m 0.10 m", "pf-paper", {"pf-paper.spread_m": 0.10}),
    ("spread_m 0.50 m", "pf-paper", {"pf-paper.spread_m": 0.50}),
    ("heading_spread_rad 0.003", "pf-paper", {"pf-paper.heading_spread_rad": 0.003}),
    ("heading_spread_rad 0.03", "pf-paper", {"pf-paper.heading_spread_rad": 0.03}),
    ("top_fraction 0.10", "pf-paper", {"pf-paper.top_fraction": 0.10}),
    ("top_fraction 0.50", "pf-paper", {"pf-paper.top_fraction": 0.50}),
    ("local_fraction 1.0", "pf-paper", {"pf-paper.local_fraction": 1.0}),
    ("particles 1000", "pf-paper", {"pf-paper.particles": 1000}),
    ("scans all (every revolution)", "pf-paper", {"pf-paper.scans": "all"}),
    ("use_ids (known association)", "pf-paper", {"pf-paper.use_ids": True}),
    ("de-skewed (the default)", "pf-paper", {"pf-paper.deskew": True}),
)
"""(label, estimator, --set overrides) of each row; pf-paper rows also start at the NAV pose,
without de-skew unless the row sets it."""

LOGS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("with skew (default)", {}),
    ("without skew", {"nav.skew": False}),
)


def radial_errors(log: Path, seed: int) -> list[float]:
    """Radial RMSE (m) of every row of :data:`VARIANTS` on ``log``."""
    reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors, truth=True)  # t0 = the log start, as the reference times
    ref = reader.metadata["simulator"]["reference"]
    t0, t1 = float(ref.get("moving_from_s", 0.0)), float(ref.get("moving_until_s", math.inf))
    out = []
    for _, name, settings in VARIANTS:
        if name == "pf-paper":
            settings = {**START, **settings}
        res = replay_data(data, [name], config=cfg, seed=seed, settings=settings, cloud_size=0)
        tab = res.estimates[name]
        t = (tab.t_ns - data.t0_ns) * 1e-9
        mv = (t >= t0) & (t <= t1)
        out.append(radial_rmse(tab.x[mv], tab.y[mv], float(ref["radius"])))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="paper-circle")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    columns = []
    with tempfile.TemporaryDirectory() as tmp:
        for _, overrides in LOGS:
            path = Path(tmp) / "run.mcap"
            write_log(simulate(args.scenario, seed=args.seed, overrides=overrides), path)
            columns.append(np.array(radial_errors(path, args.seed)))
    print(f"{args.scenario}, seed {args.seed}: radial RMSE mm (x laser on the same log)\n")
    print("| run | " + " | ".join(label for label, _ in LOGS) + " |")
    print("|---|" + "---:|" * len(LOGS))
    for i, (label, _, _) in enumerate(VARIANTS):
        cells = [f"{1000 * col[i]:.1f} ({col[i] / col[0]:.2f} x)" for col in columns]
        print(f"| {label} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
