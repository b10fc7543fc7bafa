"""Global localisation of ``pf`` on MRCLAM logs: from a uniform start over the arena.

For each robot and seed, ``pf`` with the log's profile and ``init = uniform`` (particles spread
uniformly over the work area, the landmarks' bounding box grown by the importer's margin, every
heading) runs over the first ``--window`` seconds after the first camera frame. At every
estimate (one per camera frame with a landmark) the position error against the ground truth is
taken. Reported per run:

- *time to localise*: the time after the first camera frame from which the estimates stay
  within 0.5 m of the truth for 30 s (a later excursion beyond 0.5 m, in a long stretch
  without landmarks, is tracking error, which the accuracy tables measure, not a failure to
  localise);
- *wrong lock*: the particles gathered (position standard deviation of the cloud at most
  0.25 m) while the estimate was more than 1 m from the truth, at some estimate of the window.

Usage::

    python benchmarks/mrclam_global.py DIR [--robots 1,2,3,4,5] [--seeds 10] [--window 180]

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

WITHIN_M = 0.5
"""Localised: every later estimate within this distance of the truth, m."""
WRONG_M = 1.0
"""A gathered cloud this far from the truth is a wrong lock, m."""
GATHERED_M = 0.25
"""The cloud counts as gathered when its position standard deviation is at most this, m."""
HOLD_S = 30.0
"""Localised: the error stays within :data:`WITHIN_M` for this long, s."""
TARGET_S = 60.0
"""Target: localised within this many seconds."""


def localised_after(t: np.ndarray, err: np.ndarray) -> float | None:
    """The first estimate time ``t`` (s) from which the error ``err`` (m) stays within
    :data:`WITHIN_M` for :data:`HOLD_S` s (to the end of the window, if it ends sooner than
    that, as long as it holds at least :data:`HOLD_S` / 2); None if there is none."""
    bad = np.flatnonzero(err > WITHIN_M)
    for i in range(len(t)):
        if err[i] > WITHIN_M:
            continue
        nxt = bad[np.searchsorted(bad, i)] if np.searchsorted(bad, i) < len(bad) else None
        until = t[nxt] if nxt is not None else t[-1]
        if until - t[i] >= HOLD_S or (nxt is None and until - t[i] >= 0.5 * HOLD_S):
            return float(t[i])
    return None


def global_run(log: Path, seed: int, window_s: float,
               settings: dict[str, Any] | None = None) -> dict[str, Any]:
    """One run of ``pf`` from a uniform start over the first ``window_s`` s (after the first
    camera frame) of ``log``: ``localised_s`` (s, or None), ``wrong_lock`` (bool),
    ``final_error_m``."""
    from mrclam_accuracy import scan_drive

    from lgvtool.localize.registry import ESTIMATORS, resolve_params, split_settings
    from lgvtool.localize.replay_driver import estimator_rng, truth_pose_at
    from lgvtool.log import LogReader

    reader = LogReader(log)
    config = reader.config()
    own = {"pf.init": "uniform", **(settings or {})}
    params = resolve_params("pf", config.estimators, split_settings(own).get("pf"))
    data, track, obs = scan_drive(reader, config, params, truth=True)
    vehicle = config.vehicle
    obs = [o for o in obs if o.t <= obs[0].t + window_s]
    est = ESTIMATORS["pf"](params, vehicle=vehicle, reflectors=data.reflectors,
                           area=config.area, rng=estimator_rng(seed, "pf"))
    times = np.array([o.t for o in obs], dtype=np.float64)
    rows = est.run(times, obs, track.deltas(times[:-1], times[1:]), cloud_size=0).poses
    truth = np.array([truth_pose_at(data, float(t)) for t in rows.t])
    err = np.hypot(rows.x - truth[:, 0], rows.y - truth[:, 1])
    cov = rows.covariance.reshape(-1, 3, 3)
    spread = np.sqrt(np.maximum(cov[:, 0, 0] + cov[:, 1, 1], 0.0))
    localised = localised_after(rows.t - obs[0].t, err)
    wrong = bool(np.any((spread <= GATHERED_M) & (err > WRONG_M)))
    return {"localised_s": localised, "wrong_lock": wrong, "final_error_m": float(err[-1]),
            "trace": [(float(t - obs[0].t), float(e), float(sp))
                      for t, e, sp in zip(rows.t, err, spread, strict=True)]}


def global_table(dataset: Path, robots: list[int], seeds: int, window_s: float,
                 cache: Path, settings: dict[str, Any] | None = None) -> str:
    """Markdown: per robot, the time to localise of each seed, how many within the target,
    and the wrong locks."""
    from mrclam_cv import cached_log

    lines = [f"| robot | time to stay within {WITHIN_M} m, s (seeds 0-{seeds - 1}) | within "
             f"{TARGET_S:.0f} s | wrong locks |", "|---|---|---:|---:|"]
    total = ok = locks = 0
    for r in robots:
        log = cached_log(dataset, r, cache)
        runs = [global_run(log, s, window_s, settings) for s in range(seeds)]
        times = [x["localised_s"] for x in runs]
        good = sum(1 for t in times if t is not None and t <= TARGET_S)
        bad = sum(1 for x in runs if x["wrong_lock"])
        total, ok, locks = total + len(runs), ok + good, locks + bad
        cells = ", ".join("-" if t is None else f"{t:.1f}" for t in times)
        lines.append(f"| Robot{r} | {cells} | {good} of {len(runs)} | {bad} |")
    lines += ["", f"Localised within {TARGET_S:.0f} s (then within {WITHIN_M} m for "
              f"{HOLD_S:.0f} s; {window_s:.0f} s of data per run) on {ok} of {total} runs; "
              f"wrong locks "
              f"(cloud gathered within {GATHERED_M} m, more than {WRONG_M} m from the truth) "
              f"on {locks} runs. '-': not localised by the end of the window."]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the global-localisation table."""
    from mrclam_accuracy import default_dataset

    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("dataset", nargs="?", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--seeds", type=int, default=10, help="seeds per robot (0..N-1)")
    ap.add_argument("--window", type=float, default=180.0, help="seconds of data per run")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs, reused between runs")
    ap.add_argument("--set", dest="settings", action="append", default=[],
                    help="pf setting over the log's profile, e.g. pf.particles=4000")
    args = ap.parse_args(argv)
    from lgvtool.config import parse_set_options
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    dataset = args.dataset or default_dataset()
    try:
        available = MrclamDataset.open(dataset).robots
    except InputError as exc:
        print(f"mrclam_global: {exc}", file=sys.stderr)
        return 2
    robots = [int(r) for r in args.robots.split(",") if r.strip() and int(r) in available]
    try:
        print(global_table(dataset, robots, args.seeds, args.window, args.cache,
                           parse_set_options(args.settings)))
    except InputError as exc:
        print(f"mrclam_global: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
