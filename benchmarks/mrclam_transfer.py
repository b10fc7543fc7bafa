"""The MRCLAM recommendation chosen on one dataset and scored on another (docs/mrclam.md, "A
recording not used: Dataset 7, chosen there and scored on Dataset 6").

Every candidate (:data:`CANDIDATES`: the five of :mod:`mrclam_halves`'s rule, then the two
variants named there as the ones to test on a recording not used) is replayed over each robot's
whole scored span of the choice dataset from the ground truth at its start, and its position
RMSE (m) is divided by the plain EKF's (:data:`mrclam_halves.PLAIN_EKF`, the odometry as
stamped) on the same span: the choice dataset needs no published reference. The candidate with
the least fit score (worst ratio + a quarter of the mean, ties to the earlier) is the
recommendation; it is then scored on both halves of every robot of the scoring dataset against
the apportioned reference EKF, as :mod:`mrclam_halves` scores a half (that dataset must be
Dataset 6, whose reference figures are published).

Usage::

    python benchmarks/mrclam_transfer.py CHOICE_DIR [SCORING_DIR]   # SCORING_DIR: Dataset 6
    python benchmarks/mrclam_transfer.py CHOICE_DIR --set ekf.update_iterations=10

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mrclam_accuracy import TARGET_RATIO, default_dataset
from mrclam_halves import (
    CANDIDATES as RULE_CANDIDATES,
)
from mrclam_halves import (
    PROTOTYPES,
    Candidate,
    candidate_settings,
    choose,
    replay,
    rmse_between,
    robot_with_plain,
    with_change,
)
from mrclam_halves import (
    run as run_halves,
)

CANDIDATES: tuple[Candidate, ...] = (
    *RULE_CANDIDATES,
    *[p for label in ("bearing noise x1.5", "bearing noise from the camera")
      for p in PROTOTYPES if p.label == label],
)
"""The rule's seven candidates, in the order that breaks ties (fixed before scoring)."""


def whole_run_ratios(dataset: Path, robots: list[int], cache: Path, seed: int,
                     cands: tuple[Candidate, ...] = CANDIDATES
                     ) -> tuple[np.ndarray, np.ndarray, dict[int, float]]:
    """Every candidate's RMSE (m) over each robot's whole span of ``dataset`` from the ground
    truth, the ratios to the plain EKF's there (candidates x robots), and the plain EKF's RMSE
    per robot (m)."""
    rmse = np.full((len(cands), len(robots)), np.nan)
    plain: dict[int, float] = {}
    for k, robot in enumerate(robots):
        t0 = time.perf_counter()
        log, span, scores = robot_with_plain(dataset, robot, cache, seed)
        plain[robot] = scores["run"]
        for c, cand in enumerate(cands):
            est = replay(log, cand.estimator, candidate_settings(log, cand), span.start,
                         span.end + 1.0, seed=seed)
            rmse[c, k] = rmse_between(est, log, span.start, span.end)
        print(f"robot {robot}: plain EKF {plain[robot]:.3f} m; " + ", ".join(
            f"{cand.label} {rmse[c, k]:.3f}" for c, cand in enumerate(cands))
            + f" m ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    return rmse, rmse / np.array([plain[r] for r in robots])[None, :], plain


def main(argv: list[str] | None = None) -> int:
    """Choose on the first dataset, score on Dataset 6; print the tables (or JSON)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("choice", type=Path, help="MRCLAM dataset folder the choice is made on")
    ap.add_argument("scoring", nargs="?", type=Path, default=None,
                    help="MRCLAM Dataset 6 folder, scored on its halves (default: the bundled "
                         "path of mrclam_accuracy)")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs, reused between runs")
    ap.add_argument("--seed", type=int, default=0, help="seed of the estimators' draws")
    ap.add_argument("--json-out", type=Path, default=None, help="also write the JSON result")
    ap.add_argument("--set", dest="change", action="append", default=[],
                    help="EST.KEY=V: a setting over every candidate of EST (a change of the "
                         "estimator under the rule, e.g. ekf.update_iterations=10; "
                         "repeatable)")
    args = ap.parse_args(argv)
    from lgvtool.config import parse_set_options
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    scoring = args.scoring or default_dataset()
    try:
        change = parse_set_options(args.change)
        cands = tuple(with_change(list(CANDIDATES), change))
        robots = list(MrclamDataset.open(args.choice).robots)
        MrclamDataset.open(scoring)
        if args.choice.resolve() == scoring.resolve():
            raise InputError("the choice and the scoring dataset are the same folder")
    except (InputError, ValueError) as exc:
        print(f"mrclam_transfer: {exc}", file=sys.stderr)
        return 2
    # a cache per dataset: the imported logs are named by robot
    rmse, ratio, plain = whole_run_ratios(args.choice, robots, args.cache / args.choice.name,
                                          args.seed, cands)
    chosen = choose(ratio)
    fits = [float(ratio[c].max() + 0.25 * ratio[c].mean()) for c in range(len(cands))]
    print(f"\nChoice on {args.choice.name} (ratio to the plain EKF over each whole run):\n")
    print("| candidate | " + " | ".join(f"Robot{r}" for r in robots)
          + " | fit (worst + 0.25 x mean) |")
    print("|---|" + "---:|" * (len(robots) + 1))
    for c, cand in enumerate(cands):
        mark = " (chosen)" if c == chosen else ""
        print(f"| `{cand.label}`{mark} | " + " | ".join(
            f"{ratio[c, k]:.3f} ({rmse[c, k]:.3f} m)" for k in range(len(robots)))
            + f" | {fits[c]:.3f} |")
    print("| plain EKF, m | " + " | ".join(f"{plain[r]:.3f}" for r in robots) + " | |")
    try:
        res = run_halves(scoring, [1, 2, 3, 4, 5], args.cache / scoring.name,
                         [cands[chosen]], 1, args.seed)
    except InputError as exc:
        print(f"mrclam_transfer: {exc}", file=sys.stderr)
        return 2
    held = np.array(res["ratio"])[0]
    met = int((held <= TARGET_RATIO).sum())
    print(f"\n`{cands[chosen].label}` on {scoring.name}'s halves (ratio to the "
          "apportioned reference EKF, A / B):\n")
    print("| " + " | ".join(f"Robot{r}" for r in res["robots"]) + " |")
    print("|" + "---:|" * len(res["robots"]))
    print("| " + " | ".join(f"{a:.3f} / {b:.3f}" for a, b in held) + " |")
    print(f"\nAt or below {TARGET_RATIO}: {met} of {held.size} halves.")
    out: dict[str, Any] = {
        "choice_dataset": str(args.choice.name), "robots": robots, "seed": args.seed,
        "candidates": [c.label for c in cands], "change": change,
        "rmse_m": rmse.tolist(),
        "ratio_to_plain": ratio.tolist(), "plain_ekf_m": plain, "fit": fits,
        "chosen": cands[chosen].label, "scored": res, "met": met}
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
