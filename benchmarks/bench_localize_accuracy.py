"""Accuracy of every estimator on the simulated scenarios (the table of docs/filter.md).

Run by hand::

    python benchmarks/bench_localize_accuracy.py [--seed 1] [--keep DIR] [--markdown]

For each scenario it simulates a log with ``lgvtool simulate``, replays it through every
estimator (plus documented variants of the paper's filter), and prints per estimator:

- truth RMSE: position error of O against the simulator's ground truth, after the first 5 s, mm;
- max: the largest such error after 5 s, mm;
- radial RMSE: distance from a circle of the kinematic radius ``h / tan(60 deg)`` whose centre is
  fitted to the estimator's own trajectory (least squares), moving part only, mm (circle
  scenarios only);
- 10 cm at: time after which the error stays below 10 cm, s.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

SCENARIOS = ("paper-circle", "warehouse", "fast", "degraded")
RUNS: tuple[tuple[str, str, dict[str, object]], ...] = (
    ("laser", "laser", {}),
    ("deadreckoning", "deadreckoning", {}),
    ("ekf", "ekf", {}),
    ("pf-paper", "pf-paper", {}),
    ("pf-paper (one instant per revolution)", "pf-paper", {"pf-paper.deskew": False}),
    ("pf-paper (the paper's literal start and reading)", "pf-paper",
     {"pf-paper.start_updates": 0, "pf-paper.deskew": False}),
    ("pf", "pf", {}),
)


def simulate(scenario: str, seed: int, path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario", scenario,
                          "--seed", str(seed), "-o", str(path)], capture_output=True, text=True,
                         check=False)
    if res.returncode != 0:
        raise SystemExit(f"simulate {scenario} failed: {res.stderr.strip()}")


def radial_rmse(x: np.ndarray, y: np.ndarray, radius: float) -> float:
    """RMS distance of the points from the best circle of the given radius, m."""
    c = np.array([x.mean(), y.mean()])
    for _ in range(30):
        d = np.maximum(np.hypot(x - c[0], y - c[1]), 1e-9)
        jac = -np.c_[(x - c[0]) / d, (y - c[1]) / d]
        step = np.linalg.lstsq(jac, d - radius, rcond=None)[0]
        c = c - step
        if np.hypot(*step) < 1e-10:
            break
    return float(np.sqrt(np.mean((np.hypot(x - c[0], y - c[1]) - radius) ** 2)))


def evaluate(log: Path, seed: int) -> list[tuple[str, float, float, float, float | None]]:
    from lgvtool.localize.replay_driver import load_log, replay_data
    from lgvtool.log import LogReader

    reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors, truth=True)
    truth = data.truth
    assert truth is not None
    sim = reader.metadata.get("simulator", {})
    ref = sim.get("reference", {})
    moving = (ref.get("moving_from_s", 0.0), ref.get("moving_until_s", math.inf))
    circle = "radius" in ref
    rows = []
    for label, name, settings in RUNS:
        res = replay_data(data, [name], config=cfg, seed=seed, settings=settings, cloud_size=0)
        tab = res.estimates[name]
        t = (tab.t_ns - data.t0_ns) * 1e-9
        tx = np.interp(t, truth["t"], truth["x"])
        ty = np.interp(t, truth["t"], truth["y"])
        err = np.hypot(tab.x - tx, tab.y - ty)
        late = t > 5.0
        rmse = float(np.sqrt(np.mean(err[late] ** 2)))
        worst = float(err[late].max())
        rad = math.nan
        if circle:
            mv = (t >= moving[0]) & (t <= moving[1])
            rad = radial_rmse(tab.x[mv], tab.y[mv], float(ref["radius"]))
        bad = np.nonzero(err >= 0.1)[0]
        settle = float(t[0]) if len(bad) == 0 else (
            float(t[bad[-1] + 1]) if bad[-1] + 1 < len(t) else None)
        rows.append((label, rmse, worst, rad, settle))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--keep", type=Path, help="folder for the simulated logs")
    ap.add_argument("--scenario", action="append", choices=SCENARIOS)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.keep or Path(tmp)
        folder.mkdir(parents=True, exist_ok=True)
        for scenario in args.scenario or SCENARIOS:
            log = folder / f"{scenario}-seed{args.seed}.mcap"
            if not log.exists():
                simulate(scenario, args.seed, log)
            print(f"\n### {scenario} (seed {args.seed})\n")
            print("| estimator | truth RMSE mm | max mm | radial RMSE mm | 10 cm at s |")
            print("|---|---:|---:|---:|---:|")
            for label, rmse, worst, rad, settle in evaluate(log, args.seed):
                rad_s = "" if math.isnan(rad) else f"{1000 * rad:.1f}"
                settle_s = "never" if settle is None else f"{settle:.2f}"
                print(f"| {label} | {1000 * rmse:.1f} | {1000 * worst:.1f} | {rad_s} | "
                      f"{settle_s} |", flush=True)


if __name__ == "__main__":
    main()
