"""Position accuracy of lgvtool's estimators on the UTIAS MRCLAM Dataset 6, as a Markdown table.

For each robot: import the robot's files into a log (``lgvtool import mrclam``), run the
estimators over it with :func:`lgvtool.localize.run_replay`, interpolate the ground truth at
every estimate time and compute the position RMSE (m). The table sets each estimator beside the
dataset's reference EKF figures (a plain EKF with known data association, a chi-square gate,
initialised at the first ground-truth pose, RMSE at every odometry step). Replay records an
estimate at every observation time, so the RMSE here is taken at those times.

The estimators' defaults describe a NAV200 laser (range noise 2 cm) and encoder odometry. The
MRCLAM robots have a camera (range noise about 0.1-0.2 m, bearing about 0.01 rad, measured by
the importer against ground truth) and commanded velocities that drift metres over a run, so
the benchmark applies :data:`MRCLAM_PROFILE` first (``--no-profile`` leaves the defaults) and
starts every estimator at the first ground-truth pose, like the reference (``--init auto`` lets
them initialise themselves). ``--set`` overrides both.

Usage::

    python benchmarks/mrclam_accuracy.py                      # robots 1-5, ekf pf pf-paper
    python benchmarks/mrclam_accuracy.py --robots 1,3 --estimators ekf --json
    python benchmarks/mrclam_accuracy.py --set pf.particles=1000 --seed 3

The dataset folder is ``$LGVTOOL_MRCLAM``, else ``../shared/data/mrclam/MRCLAM_Dataset6`` beside
the repository, else ``--dataset``.

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

REFERENCE_EKF_M = {1: 0.214, 2: 0.233, 3: 0.193, 4: 0.322, 5: 0.185}
"""The dataset's reference EKF position RMSE per robot, m."""
REFERENCE_DEAD_RECKONING_M = {1: 2.62, 2: 2.96, 3: 4.16, 4: 1.82, 5: 1.77}
"""Dead reckoning on the same runs, m (for orientation)."""
DEFAULT_ESTIMATORS = ("ekf", "pf", "pf-paper")
_CAMERA_AND_COMMANDS = {
    "sigma_range_m": 0.2, "sigma_bearing_rad": 0.03,
    "noise_dist": 0.1, "noise_lat": 0.05, "noise_rot": 0.1, "noise_rot_per_m": 0.1,
}
MRCLAM_PROFILE: dict[str, dict[str, Any]] = {
    "ekf": dict(_CAMERA_AND_COMMANDS),
    "pf": dict(_CAMERA_AND_COMMANDS),
}
"""Estimator settings for the MRCLAM camera and commanded-velocity odometry (units in the
names); estimators not listed keep their defaults."""
TRUTH_MAX_GAP_S = 0.5
"""Ground truth is interpolated only between samples at most this far apart, s."""


def default_dataset() -> Path:
    """``$LGVTOOL_MRCLAM``, else the shared data folder beside the repository."""
    env = os.environ.get("LGVTOOL_MRCLAM")
    if env:
        return Path(env)
    repo = Path(__file__).resolve().parent.parent
    return repo.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6"


def position_rmse(estimate: pd.DataFrame, truth: pd.DataFrame,
                  max_gap_s: float = TRUTH_MAX_GAP_S) -> tuple[float, int]:
    """Position RMSE (m) of ``estimate`` [t s, x m, y m] against ``truth`` [t, x, y] linearly
    interpolated at the estimate times, and the number of estimates compared. Estimates outside
    the ground truth's span, or inside a ground-truth gap longer than ``max_gap_s``, are left
    out."""
    tt = truth["t"].to_numpy()
    te = estimate["t"].to_numpy()
    if len(tt) < 2 or len(te) == 0:
        return math.nan, 0
    j = np.clip(np.searchsorted(tt, te, side="right"), 1, len(tt) - 1)
    use = (te >= tt[0]) & (te <= tt[-1]) & ((tt[j] - tt[j - 1]) <= max_gap_s)
    if not use.any():
        return math.nan, 0
    # interpolate relative to the first stamp: Unix seconds lose precision when squared
    t0 = tt[0]
    x = np.interp(te[use] - t0, tt - t0, truth["x"].to_numpy())
    y = np.interp(te[use] - t0, tt - t0, truth["y"].to_numpy())
    dx = estimate["x"].to_numpy()[use] - x
    dy = estimate["y"].to_numpy()[use] - y
    return float(np.sqrt(np.mean(dx * dx + dy * dy))), int(use.sum())


def effective_settings(estimators: list[str], overrides: dict[str, Any], *,
                       profile: bool) -> dict[str, Any]:
    """``{"<estimator>.<param>": value}``: :data:`MRCLAM_PROFILE` (if ``profile``) for the
    estimators run, then ``overrides``."""
    out: dict[str, Any] = {}
    if profile:
        for name in estimators:
            for key, value in MRCLAM_PROFILE.get(name, {}).items():
                out[f"{name}.{key}"] = value
    out.update(overrides)
    return out


def run_robot(dataset: Path, robot: int, estimators: list[str], *, seed: int,
              settings: dict[str, Any], workdir: Path, init: str = "truth") -> dict[str, Any]:
    """Import one robot, replay the estimators, and return the RMSE per estimator."""
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    log = workdir / f"robot{robot}.mcap"
    summary = import_robot(dataset, robot, log)
    reader = LogReader(log)
    truth = reader.dataframe(topics.TRUTH)
    t0 = time.perf_counter()
    extra: dict[str, Any] = {"initial_pose": "truth"} if init == "truth" else {}
    result = run_replay(reader, estimators, config=reader.config(), seed=seed,
                        settings=settings, **extra)
    elapsed = time.perf_counter() - t0
    row: dict[str, Any] = {"robot": robot, "reference_ekf_m": REFERENCE_EKF_M.get(robot),
                           "import_s": round(summary.elapsed_s, 3), "replay_s": round(elapsed, 3),
                           "rmse_m": {}, "compared": {}}
    for name in estimators:
        rmse, n = position_rmse(result.trajectories[name], truth)
        row["rmse_m"][name] = rmse
        row["compared"][name] = n
    return row


def markdown_table(rows: list[dict[str, Any]], estimators: list[str]) -> str:
    """The results as a Markdown table: RMSE per estimator, the reference EKF, ratios."""
    head = ["robot", *[f"{e} RMSE (m)" for e in estimators], "reference EKF (m)",
            *[f"{e} / ref" for e in estimators]]
    lines = ["| " + " | ".join(head) + " |", "|" + "---:|" * len(head)]
    for r in rows:
        ref = r["reference_ekf_m"]
        cells = [f"Robot{r['robot']}"]
        cells += [f"{r['rmse_m'][e]:.3f}" for e in estimators]
        cells.append(f"{ref:.3f}" if ref else "-")
        cells += [f"{r['rmse_m'][e] / ref:.2f}" if ref else "-" for e in estimators]
        lines.append("| " + " | ".join(cells) + " |")
    if rows:
        means = [float(np.nanmean([r["rmse_m"][e] for r in rows])) for e in estimators]
        refs = [r["reference_ekf_m"] for r in rows if r["reference_ekf_m"]]
        ref_mean = float(np.mean(refs)) if refs else math.nan
        cells = ["mean", *[f"{m:.3f}" for m in means], f"{ref_mean:.3f}",
                 *[f"{m / ref_mean:.2f}" for m in means]]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the Markdown table (or JSON)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--estimators", default=",".join(DEFAULT_ESTIMATORS),
                    help="comma-separated estimator names")
    ap.add_argument("--seed", type=int, default=0, help="seed of the estimators' random draws")
    ap.add_argument("--set", dest="settings", action="append", default=[],
                    help="estimator setting, e.g. pf.particles=1000 (repeatable)")
    ap.add_argument("--no-profile", action="store_true",
                    help="use the estimators' defaults instead of MRCLAM_PROFILE")
    ap.add_argument("--init", choices=("truth", "auto"), default="truth",
                    help="start at the first ground-truth pose (truth) or let each estimator "
                         "initialise itself (auto)")
    ap.add_argument("--keep", type=Path, default=None,
                    help="folder to keep the imported logs in (default: a temporary folder)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    args = ap.parse_args(argv)

    dataset = args.dataset or default_dataset()
    if not dataset.is_dir():
        print(f"mrclam_accuracy: dataset folder not found: {dataset} "
              "(set LGVTOOL_MRCLAM or pass --dataset)", file=sys.stderr)
        return 2
    robots = [int(r) for r in args.robots.split(",") if r.strip()]
    estimators = [e.strip() for e in args.estimators.split(",") if e.strip()]
    from lgvtool.config import parse_set_options

    settings = effective_settings(estimators, parse_set_options(args.settings),
                                  profile=not args.no_profile)

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        workdir = args.keep or Path(tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        for robot in robots:
            rows.append(run_robot(dataset, robot, estimators, seed=args.seed,
                                  settings=settings, workdir=workdir, init=args.init))
            print(f"robot {robot}: " + ", ".join(
                f"{e} {rows[-1]['rmse_m'][e]:.3f} m" for e in estimators)
                + f" (replay {rows[-1]['replay_s']:.1f} s)", file=sys.stderr)
    if args.json:
        print(json.dumps({"seed": args.seed, "init": args.init, "settings": settings,
                          "rows": rows}, indent=2))
    else:
        print(markdown_table(rows, estimators))
        print()
        shown = ", ".join(f"{k}={v}" for k, v in settings.items()) or "estimator defaults"
        print(f"Position RMSE against ground truth interpolated at the estimate times (one per "
              f"observation); seed {args.seed}; start: {args.init}; settings: {shown}. "
              "Reference: the dataset's plain EKF (known data association, chi-square gate, "
              "RMSE at every odometry step). Data: UTIAS MRCLAM Dataset 6, K. Y. K. Leung et "
              "al., IJRR 30(8):969-974, 2011.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
