"""``ekf`` and ``pf`` from their own start, with the device's reflector ids or none.

For each scenario, observation mode and seed the script simulates a whole run and replays it
through ``ekf`` and ``pf`` with their default settings, each from its own start (``pf``
uniform over the work area, ``ekf`` at the first NAV pose or scan fix, whichever comes first:
:data:`START_PRIOR`), once per id setting (``--ids``):

- ``ids``: the ids the navigation device gave its reflectors;
- ``none``: the ids ignored (``use_ids = false``: every reflector associated against the layout
  by nearest neighbour inside the gate, the start and recovery fixes from the scan's geometry);
- ``wrong``: a fifth of the device's ids replaced by another layout reflector's, half of them
  the nearest one's (``tests/localize/device_ids.py``).

It measures the position error of O against the ground truth at every estimate: the time (s
after the log's first message) at which it first comes within ``--within`` (10 cm), whether
that is by ``--by`` (20 s), and the largest error after it (m); a run *meets* the target when
it comes within 10 cm by 20 s and is never farther than ``--bound`` (0.5 m) after that.

Observation modes (the log's reflector observations): ``nav350`` (a NAV350: its landmarks with
the ids it matched, and its pose every revolution; ``sim.nav_device = nav350``) and ``paper``
(the NAV200's per-revolution scans as the paper's experiment logged them, with the ids the
simulated device matched, and its polled poses; ``sim.paper_scans = true``). The seeds,
9000-9009 by default, were chosen before any estimator setting was; tune on others (100-109).

``--lost M`` starts each estimator instead where it has lost the vehicle: M m to the left of
the truth's first pose and 0.2 rad off, sure of it (``init_sigma_xy_m`` 0.02 m,
``init_sigma_heading_rad`` 0.01 rad), so that its gate rejects every reflector; it must find
the vehicle again (``ekf``: ``scan_recover_s``; ``pf``: its sensor resetting).

Usage::

    python benchmarks/own_start_convergence.py [--scenarios paper-circle,warehouse,fast,degraded]
        [--modes nav350,paper] [--ids ids,none,wrong] [--seeds 9000-9009]
        [--estimators ekf,pf]
        [--set estimator.key=value ...] [--within 0.1] [--by 20] [--bound 0.5] [--lost 1.0]
        [--json FILE]
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
sys.path.insert(1, str(Path(__file__).resolve().parents[1] / "tests" / "localize"))

from device_ids import with_ids
from pf_paper_convergence import seeds_of, settings_of
from world_headline import MODES

VARIANTS: dict[str, tuple[str, dict[str, Any]]] = {
    "ekf": ("ekf", {}),
    "pf": ("pf", {}),
}
"""Label -> estimator and its settings."""
START_PRIOR = {
    "ekf": "the first NAV pose converted to O, or the first scan's landmark fix (ids that agree, "
           "else the scan's geometry matched on the layout), whichever comes first; 5 cm and "
           "0.02 rad standard deviation around it (init = auto)",
    "pf": "uniform over the work area and every heading (init = uniform, 2000 particles; the "
          "first scan's likelihood resets them around its landmark fix)",
}
"""What each estimator's own start is (its default settings)."""
ID_MODES = ("ids", "none", "wrong")
"""``ids``: the device's; ``none``: ignored (``use_ids = false``); ``wrong``: the device's with
a fifth of them replaced by another layout reflector's (half the nearest one, half any)."""
WRONG_FRACTION = 0.2
LOST_HEADING_RAD = 0.2
"""With ``--lost``: how far off the start's heading is, rad."""
ID_LABEL = {"ids": "device", "none": "none", "wrong": "20 % wrong"}


def first_within(t: np.ndarray, err: np.ndarray, within: float) -> float | None:
    """Time (s) of the first error below ``within`` (m); None if never."""
    hit = np.nonzero(err < within)[0]
    return float(t[hit[0]]) if len(hit) else None


def judge(t: np.ndarray, err: np.ndarray, within: float, by: float, bound: float
          ) -> dict[str, Any]:
    """The figures of one run: first time within ``within`` (s), whether by ``by`` (s), the
    largest error after it (mm), whether the run meets the target (never beyond ``bound``,
    m, after), the largest error from ``by`` on (mm) and the RMSE after the first time within
    (mm)."""
    first = first_within(t, err, within)
    after = err[t >= first] if first is not None else np.zeros(0)
    worst = float(after.max()) if len(after) else math.nan
    in_time = first is not None and first <= by
    late = err[t >= by]
    return {"first_s": first, "by": in_time, "max_after_mm": worst * 1000.0,
            "max_late_mm": float(late.max()) * 1000.0 if len(late) else math.nan,
            "met": bool(in_time and worst <= bound), "rows": len(t),
            "rmse_after_mm": float(np.sqrt(np.mean(after * after))) * 1000.0
            if len(after) else math.nan}


def errors(data: Any, table: Any) -> tuple[np.ndarray, np.ndarray]:
    """Per estimate row: time after the log's start (s) and position error of O (m)."""
    t = (table.t_ns - data.t0_ns) * 1e-9
    tt = (data.truth.t_ns - data.t0_ns) * 1e-9
    err = np.hypot(table.x - np.interp(t, tt, data.truth.x),
                   table.y - np.interp(t, tt, data.truth.y))
    return t, err


def run_log(scenario: str, mode: str, seed: int, id_modes: list[str], estimators: list[str],
            extra: dict[str, Any], sim_extra: dict[str, Any], args: argparse.Namespace,
            tmp: Path) -> dict[str, dict[str, dict[str, Any]]]:
    """Simulate one log and replay it per id mode; ``{ids: {estimator: figures}}``."""
    from lgvtool.localize.replay_driver import load_log, replay_data
    from lgvtool.log import LogReader
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    path = tmp / f"{scenario}-{mode}-{seed}.mcap"
    write_log(simulate(scenario, seed=seed, overrides={**MODES[mode], **sim_extra}), path)
    reader = LogReader(path)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors, truth=True, decode_scans=True)
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for ids in id_modes:
        logged = with_ids(data, "wrong", fraction=WRONG_FRACTION, seed=seed) \
            if ids == "wrong" else data
        out[ids] = {}
        for label in estimators:
            name, own = VARIANTS[label]
            settings = {**own, **{k: v for k, v in extra.items()
                                  if k.startswith(name + ".")}}
            if ids == "none":
                settings[f"{name}.use_ids"] = False
            start = None
            if args.lost > 0.0:
                x, y, h = (float(data.truth.x[0]), float(data.truth.y[0]),
                           float(data.truth.heading[0]))
                start = (x - args.lost * math.sin(h), y + args.lost * math.cos(h),
                         h + LOST_HEADING_RAD)
                settings = {f"{name}.init_sigma_xy_m": 0.02,
                            f"{name}.init_sigma_heading_rad": 0.01, **settings}
            res = replay_data(logged, [name], config=cfg, seed=seed, settings=settings,
                              cloud_size=0, initial_pose=start)
            t, err = errors(data, res.estimates[name])
            out[ids][label] = judge(t, err, args.within, args.by, args.bound)
    path.unlink()
    return out


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Seeds that meet the target, median time to within, worst error after, failing seeds."""
    met = [r for r in runs if r["met"]]
    times = [r["first_s"] for r in runs if r["first_s"] is not None]
    after = [r["max_after_mm"] for r in runs if math.isfinite(r["max_after_mm"])]
    late = [r["max_late_mm"] for r in runs if math.isfinite(r["max_late_mm"])]
    return {"seeds": len(runs), "met": len(met),
            "by": sum(r["by"] for r in runs),
            "median_first_s": float(np.median(times)) if times else math.nan,
            "worst_first_s": float(max(times)) if times else math.nan,
            "max_after_mm": float(max(after)) if after else math.nan,
            "max_late_mm": float(max(late)) if late else math.nan,
            "median_rmse_after_mm": float(np.median([r["rmse_after_mm"] for r in runs])),
            "failed": [r["seed"] for r in runs if not r["met"]]}


def markdown(results: dict[str, dict[str, Any]], estimators: list[str], within: float,
             by: float, bound: float) -> str:
    """The table: one row per scenario, observation mode and ids; per estimator the seeds
    that meet the target, the median time to within (s) and the worst error after it (mm)."""
    head = "| scenario | mode | ids |" + "".join(f" `{n}` |" for n in estimators)
    rule = "|---|---|---|" + "---:|" * len(estimators)
    lines = [head, rule]
    for key, per in results.items():
        scenario, mode, ids = key.split("/")
        row = f"| {scenario} | {mode} | {ID_LABEL[ids]} |"
        for name in estimators:
            s = per[name]
            row += (f" {s['met']} of {s['seeds']}; {s['median_first_s']:.2f} s; "
                    f"{s['max_after_mm']:.0f} mm; {s['max_late_mm']:.0f} mm |")
        lines.append(row)
    lines.append("")
    lines.append(f"Each cell: seeds that meet the target; median time to within "
                 f"{within * 100:.0f} cm; the largest error after first coming within it, and "
                 f"from {by:g} s on, worst seed.")
    lines.append(f"Target: within {within * 100:.0f} cm by {by:g} s on at least 9 of 10 seeds, "
                 f"and never farther than {bound:g} m after first coming within "
                 f"{within * 100:.0f} cm.")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenarios", default="paper-circle,warehouse,fast,degraded")
    ap.add_argument("--modes", default="nav350,paper")
    ap.add_argument("--ids", default="ids,none,wrong",
                    help="ids (the device's), none (ignored), wrong (a fifth replaced)")
    ap.add_argument("--seeds", default="9000-9009")
    ap.add_argument("--estimators", default="ekf,pf")
    ap.add_argument("--set", action="append", default=[], dest="sets",
                    help="estimator (ekf.KEY=VALUE) or simulator (sim.KEY=VALUE) setting")
    ap.add_argument("--within", type=float, default=0.1, help="error bound to reach, m")
    ap.add_argument("--by", type=float, default=20.0, help="time limit, s")
    ap.add_argument("--bound", type=float, default=0.5, help="largest error after, m")
    ap.add_argument("--lost", type=float, default=0.0,
                    help="start this far (m) to the left of the truth, 0.2 rad off and sure "
                         "of it, instead of the estimator's own start (0: its own start)")
    ap.add_argument("--json", dest="json_out", default=None)
    args = ap.parse_args(argv)
    started = time.perf_counter()
    estimators = args.estimators.split(",")
    id_modes = args.ids.split(",")
    for value, known in ((estimators, VARIANTS), (id_modes, ID_MODES),
                         (args.modes.split(","), MODES)):
        bad = [v for v in value if v not in known]
        if bad:
            ap.error(f"unknown {bad[0]!r} (known: {', '.join(known)})")
    sets = settings_of(args.sets)
    sim_extra = {k: v for k, v in sets.items() if k.split(".")[0] in
                 ("sim", "nav", "drive", "site", "mcu", "faults")}
    extra = {k: v for k, v in sets.items() if k not in sim_extra}
    for name in estimators:
        start = (f"{args.lost:g} m to the left of the truth's first pose, 0.2 rad off, sure of "
                 "it (0.02 m, 0.01 rad)" if args.lost > 0.0
                 else START_PRIOR.get(name, "its default start"))
        print(f"{name} starts from {start}", flush=True)
    results: dict[str, dict[str, Any]] = {}
    raw: dict[str, list[dict[str, Any]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios.split(","):
            for mode in args.modes.split(","):
                per_ids: dict[str, dict[str, list[dict[str, Any]]]] = {
                    i: {n: [] for n in estimators} for i in id_modes}
                for seed in seeds_of(args.seeds):
                    got = run_log(scenario, mode, seed, id_modes, estimators, extra, sim_extra,
                                  args, Path(tmp))
                    for ids, per in got.items():
                        for name, figs in per.items():
                            per_ids[ids][name].append({"seed": seed, **figs})
                            if not figs["met"]:
                                first = figs["first_s"]
                                print(f"  {scenario} {mode} ids={ids} {name} seed {seed}: "
                                      f"first within at {first if first is None else round(first, 2)}"
                                      f" s, at most {figs['max_after_mm']:.0f} mm after",
                                      flush=True)
                    print(f"{scenario} {mode} seed {seed} done "
                          f"({time.perf_counter() - started:.0f} s)", file=sys.stderr,
                          flush=True)
                for ids in id_modes:
                    key = f"{scenario}/{mode}/{ids}"
                    raw[key] = [{"estimator": n, **r} for n in estimators
                                for r in per_ids[ids][n]]
                    results[key] = {n: summarise(per_ids[ids][n]) for n in estimators}
    print(markdown(results, estimators, args.within, args.by, args.bound))
    for key, per in results.items():
        for name, s in per.items():
            if s["failed"]:
                print(f"{key} {name}: not met on seeds {s['failed']}")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps({"start_prior": START_PRIOR,
                                                   "summary": results, "runs": raw},
                                                  indent=1), encoding="utf-8")
    print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
