"""Leave-one-robot-out cross-validation of the MRCLAM estimator profile, and its sensitivity.

A grid of candidate profiles x robots is run ONCE (each cell: one replay of the estimator from
its own start over one robot's whole log, scored as :mod:`mrclam_accuracy` scores it, position
RMSE at every odometry step from the estimator's first estimate). Every fold is derived from
that matrix: for each robot, a candidate is chosen on the *other* robots and scored on the
held-out robot (out of sample); the in-sample figure is the candidate chosen on all robots. The
choice is the one-standard-error rule: the candidate of the best fit score (the worst ratio to
the reference EKF plus a quarter of the mean ratio) replaces the stored profile only if its fit
beats the profile's by more than the standard error of their per-robot ratio differences; the
plain best fit is shown beside it.
The candidates are the recommended profile, each of its noise values moved by -25 % and +25 %
in turn (so the same matrix gives the sensitivity table), and two other ways of learning the
odometry scales (:data:`SCALE_VARIANTS`).

Usage::

    python benchmarks/mrclam_cv.py DIR                 # any MRCLAM dataset folder
    python benchmarks/mrclam_cv.py DIR --robots 1,2,3 --cache /tmp/mrclam-logs

Imported logs are kept in ``--cache`` (default: a folder in the system's temporary directory)
and reused while they are newer than the dataset's files.

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

ESTIMATOR = "ekf"
"""The recommended estimator."""
NOISE_VALUES = ("noise_rot", "noise_dist", "noise_lat", "noise_rot_per_m", "sigma_bearing_rad",
                "sigma_range_per_m")
"""The noise values of the profile that the grid moves."""
FACTORS = (0.75, 1.25)
"""Each noise value is moved by these factors in turn."""
SCALE_VARIANTS: tuple[tuple[str, dict[str, float]], ...] = (
    ("scales: narrow prior, slow walk", {"scale_sigma_w": 0.075, "scale_walk_v": 0.003,
                                         "scale_walk_w": 0.003}),
    ("scales: wide prior, fast walk", {"scale_sigma_v": 0.15, "scale_walk_v": 0.02,
                                       "scale_walk_w": 0.02}),
)
"""Candidates that change how the odometry scales are learnt (prior, random walk)."""


def cached_log(dataset: Path, robot: int, cache: Path,
               odometry_delay_s: float | None = None) -> Path:
    """The imported log of ``robot`` in ``cache``, imported when missing or older than the
    dataset's files (the importer's defaults: odometry delay measured from the camera, unless
    ``odometry_delay_s`` (s) gives it)."""
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.importers.mrclam_profile import estimator_profile
    from lgvtool.importers.mrclam_quirks import ImportSettings

    cache.mkdir(parents=True, exist_ok=True)
    # the log stores the profile: a changed profile is a new log
    digest = hashlib.sha1(json.dumps(estimator_profile(), sort_keys=True).encode()).hexdigest()
    delay = "" if odometry_delay_s is None else f"-delay{odometry_delay_s:g}"
    tag = f"{dataset.resolve().name}-robot{robot}{delay}-{digest[:10]}.mcap"
    log = cache / tag
    newest = max(f.stat().st_mtime for f in dataset.glob(f"Robot{robot}_*.dat"))
    if not log.exists() or log.stat().st_mtime < newest:
        import_robot(dataset, robot, log,
                     settings=ImportSettings(odometry_delay_s=odometry_delay_s))
    return log


def candidates(base: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
    """(label, ``--set`` overrides of the estimator) of every candidate profile: the profile
    itself, then each noise value times each factor."""
    out: list[tuple[str, dict[str, Any]]] = [("profile", {})]
    for name in NOISE_VALUES:
        for f in FACTORS:
            out.append((f"{name} {f - 1.0:+.0%}", {f"{ESTIMATOR}.{name}": base[name] * f}))
    for label, values in SCALE_VARIANTS:
        out.append((label, {f"{ESTIMATOR}.{k}": v for k, v in values.items()}))
    return out


def own_start_score(log: Path, settings: dict[str, Any]) -> dict[str, float]:
    """Run the estimator from its own start over ``log``; position RMSE (m) at every odometry
    step from its first estimate, the time of that estimate after the first observation (s)."""
    from mrclam_accuracy import calibrated_trajectory, score

    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    reader = LogReader(log)
    cfg = reader.config()
    truth = reader.dataframe(topics.TRUTH)[["t", "x", "y", "heading"]]
    odometry = reader.dataframe(topics.ODOM)[["t", "v", "omega"]]
    result = run_replay(reader, [ESTIMATOR], config=cfg, seed=0, settings=settings,
                        cloud_size=0)
    traj = calibrated_trajectory(reader, ESTIMATOR, result.trajectories[ESTIMATOR], config=cfg,
                                 seed=0, settings=settings, initial_pose=None)
    s = score(traj, odometry, truth)
    first_obs = first_observation_time(reader)
    return {"rmse_m": float(s["odometry_steps_m"]),
            "first_estimate_s": float(traj["t"].iloc[0] - first_obs)}


def first_observation_time(reader: Any) -> float:
    """Log time (s) of the first camera frame with a landmark."""
    from lgvtool.log import topics

    return float(reader.dataframe(topics.NAV_REFLECTORS)["t"].iloc[0])


def fit_score(ratios: list[float]) -> float:
    """What the fit minimises: the worst ratio plus a quarter of the mean."""
    return max(ratios) + 0.25 * float(np.mean(ratios))


def best_fit(ratio: np.ndarray) -> int:
    """The candidate (row of the candidates x robots ``ratio`` matrix) of the best fit."""
    return min(range(ratio.shape[0]), key=lambda c: fit_score(list(ratio[c])))


def one_standard_error(ratio: np.ndarray) -> int:
    """The one-standard-error rule: the best fit (:func:`best_fit`) only if its fit score
    beats the stored profile's (row 0) by more than the standard error of their per-robot
    ratio differences (sample standard deviation / sqrt(robots)); else the stored profile."""
    best = best_fit(ratio)
    diff = ratio[0] - ratio[best]
    if best == 0 or len(diff) < 2:
        return best
    se = float(np.std(diff, ddof=1)) / float(np.sqrt(len(diff)))
    gain = fit_score(list(ratio[0])) - fit_score(list(ratio[best]))
    return best if gain > se else 0


RULES = {"best fit": best_fit, "one standard error": one_standard_error}
"""How a fold chooses its candidate from the training robots' ratios."""


def leave_one_out(ratio: np.ndarray, rule: str = "best fit") -> tuple[list[int], int]:
    """From the ratio matrix (candidates x robots): the candidate each fold chooses on the
    other robots with ``rule`` (a key of :data:`RULES`), and the one chosen on all robots
    (in-sample)."""
    choose = RULES[rule]
    n_r = ratio.shape[1]
    folds = []
    for k in range(n_r):
        others = [j for j in range(n_r) if j != k]
        folds.append(choose(ratio[:, others]))
    return folds, choose(ratio)


def main(argv: list[str] | None = None) -> int:
    """Run the grid once, print the cross-validation and sensitivity tables (Markdown)."""
    from mrclam_accuracy import TARGET_RATIO, default_dataset, references

    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("dataset", nargs="?", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs, reused between runs")
    args = ap.parse_args(argv)
    dataset = args.dataset or default_dataset()
    robots = [int(r) for r in args.robots.split(",") if r.strip()]
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    try:
        reference = references(dataset)[0]
        available = MrclamDataset.open(dataset).robots
    except InputError as exc:
        print(f"mrclam_cv: {exc}", file=sys.stderr)
        return 2
    robots = [r for r in robots if r in available]
    try:
        print(cross_validation(dataset, robots, args.cache, reference, TARGET_RATIO))
    except InputError as exc:
        print(f"mrclam_cv: {exc}", file=sys.stderr)
        return 2
    return 0


def cross_validation(dataset: Path, robots: list[int], cache: Path,
                     reference: dict[int, float], target: float) -> str:
    """The grid, the leave-one-out folds and the sensitivity table, as Markdown text.

    :param reference: the reference EKF's RMSE per robot, m (Dataset 6's); without a figure
        for every robot the RMSE itself (m) is fitted and shown in place of the ratios.
    """
    from lgvtool.importers.mrclam_profile import estimator_profile

    if len(robots) < 2:
        return "Cross-validation needs at least two robots (fit on all but one, score that one)."
    base = estimator_profile()[ESTIMATOR]
    cands = candidates(base)
    logs = {r: cached_log(dataset, r, cache) for r in robots}
    t0 = time.perf_counter()
    cells = [[own_start_score(logs[r], over) for r in robots] for _, over in cands]
    grid_s = time.perf_counter() - t0
    rmse = np.array([[c["rmse_m"] for c in row] for row in cells])
    known = all(r in reference for r in robots)
    ref = np.array([reference[r] if known else 1.0 for r in robots])
    ratio = rmse / ref[None, :]
    folds, chosen = leave_one_out(ratio, "one standard error")
    fits, _ = leave_one_out(ratio, "best fit")
    unit = ("ratio to the reference EKF" if known
            else "RMSE in m in place of ratios: no reference EKF figures for this dataset")
    lines = [f"Grid: {len(cands)} candidate profiles x {len(robots)} robots, one run each "
             f"({grid_s:.0f} s); `{ESTIMATOR}` from its own start, position RMSE at every "
             f"odometry step; {unit}.", ""]
    head = ["robot", "RMSE (m), in-sample", "in-sample", "out-of-sample (candidate chosen on "
            "the other robots, one-standard-error rule)", "out-of-sample, best fit",
            "first estimate after the first camera frame (s)"]
    lines += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    met = met_fit = 0
    for k, r in enumerate(robots):
        out = ratio[folds[k], k]
        met += out <= target
        met_fit += ratio[fits[k], k] <= target
        lines.append(f"| Robot{r} | {rmse[chosen, k]:.3f} | {ratio[chosen, k]:.2f} | "
                     f"{out:.2f} (`{cands[folds[k]][0]}`) | "
                     f"{ratio[fits[k], k]:.2f} (`{cands[fits[k]][0]}`) | "
                     f"{cells[chosen][k]['first_estimate_s']:.1f} |")
    lines += ["", f"In-sample choice (one-standard-error rule): `{cands[chosen][0]}`. Out of "
              f"sample <= {target}: {met} of {len(robots)} robots with the one-standard-error "
              f"rule, {met_fit} of {len(robots)} with the best fit.", "",
              "Sensitivity of the profile (each noise value -25 % / +25 % in turn) and the "
              "other candidates; the same grid:", ""]
    head = ["candidate", *[f"Robot{r}" for r in robots], "worst"]
    lines += ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for c, (label, over) in enumerate(cands):
        value = "" if not over else " (" + ", ".join(
            f"{k.partition('.')[2]} {v:.4g}" for k, v in over.items()) + ")"
        lines.append(f"| `{label}`{value} | " + " | ".join(f"{x:.2f}" for x in ratio[c])
                     + f" | {ratio[c].max():.2f} |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
