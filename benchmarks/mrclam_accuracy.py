"""Position accuracy of lgvtool's estimators on a UTIAS MRCLAM dataset, as Markdown tables.

For each robot: import the robot's files into a log (``lgvtool import mrclam``, which delays the
odometry by what the camera shows and stores the camera and odometry noise profile of every
estimator in the log's configuration), run the estimators over it with
:func:`lgvtool.localize.run_replay` exactly as ``lgvtool replay`` and ``lgvtool evaluate`` do,
and compute the position RMSE (m) against the Vicon ground truth:

- *at every odometry step*, the dataset reference's metric: each estimate is carried forward
  through the logged odometry to every odometry time until the next estimate (dead reckoning
  from the posterior mean, :func:`mrclam_metrics.estimates_at_odometry`; an estimator with
  odometry scales in its state, the EKF with ``odometry_scales``, carries it with the scales it
  holds, as its own prediction does: :func:`calibrated_trajectory`), from the first estimate
  on;
- *at the estimate times* (one per camera frame with a landmark), what ``lgvtool evaluate``
  reports.

Only times where the ground truth exists count (Robot1's ends 128 s early; ground-truth gaps
longer than 0.5 s are skipped). Two starts: ``truth`` (every estimator starts at the ground
truth at its first observation, like the reference EKF at the first ground-truth pose) and
``auto`` (each estimator's own initialisation: global localisation for the particle filters, a
landmark fix for the EKF). ``deadreckoning`` started at the truth is run beside them.

The reference figures are the dataset's plain EKF (known data association, chi-square gate,
initialised at the first ground-truth pose, RMSE at every odometry step), from the dataset's
README.

Usage::

    python benchmarks/mrclam_accuracy.py DIR                  # every table, any MRCLAM dataset
    python benchmarks/mrclam_accuracy.py DIR --quick          # robots 1-5, both starts, no
                                                              # cross-validation or global runs
    python benchmarks/mrclam_accuracy.py --robots 1,3 --estimators ekf --init truth --json
    python benchmarks/mrclam_accuracy.py --set pf.particles=1000 --seed 3
    python benchmarks/mrclam_accuracy.py --no-profile         # the NAV200 defaults instead
    python benchmarks/mrclam_accuracy.py --odometry-delay 0 --set ekf.odometry_scales=false
                                                              # without the two corrections

The dataset folder is ``DIR``, else ``--dataset``, else ``$LGVTOOL_MRCLAM``, else
``../shared/data/mrclam/MRCLAM_Dataset6`` beside the repository. Without ``--quick`` the
cross-validation grid (:mod:`mrclam_cv`) and the global localisation of ``pf``
(:mod:`mrclam_global`) follow the accuracy tables.

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
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mrclam_metrics import estimates_at_odometry, odometry_vs_truth, position_rmse, truth_at

if TYPE_CHECKING:
    from lgvtool.trajectory import Trajectory

REFERENCE_EKF_M = {1: 0.214, 2: 0.233, 3: 0.193, 4: 0.322, 5: 0.185}
"""The dataset's reference EKF position RMSE per robot, m."""
REFERENCE_DEAD_RECKONING_M = {1: 2.62, 2: 2.96, 3: 4.16, 4: 1.82, 5: 1.77}
"""Dead reckoning on the same runs according to the dataset's README, m."""
REFERENCES = {6: (REFERENCE_EKF_M, REFERENCE_DEAD_RECKONING_M)}
"""Dataset number -> (reference EKF, reference dead reckoning) per robot, m; the figures are
known for Dataset 6 only, other datasets are scored without ratios."""
TARGET_RATIO = 0.8
"""Target: the best estimator's RMSE at most this times the reference EKF's."""
DEFAULT_ESTIMATORS = ("ekf", "pf", "pf-paper")
INITS = ("truth", "auto")
DEAD_RECKONING = "deadreckoning"
FLOOR = "truth at the observations"
"""Row of the perfect estimator: the ground truth at every observation time, carried through the
odometry in between; the least any estimator that follows the odometry can reach."""


def default_dataset() -> Path:
    """``$LGVTOOL_MRCLAM``, else the shared data folder beside the repository."""
    env = os.environ.get("LGVTOOL_MRCLAM")
    if env:
        return Path(env)
    repo = Path(__file__).resolve().parent.parent
    return repo.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6"


def references(dataset: Path) -> tuple[dict[int, float], dict[int, float]]:
    """The reference EKF's and dead reckoning's RMSE per robot (m) of the dataset in folder
    ``dataset`` (empty where unknown)."""
    from lgvtool.importers.mrclam import MrclamDataset

    return REFERENCES.get(MrclamDataset.open(dataset).number or 0, ({}, {}))


def score(trajectory: Any, odometry: Any, truth: Any) -> dict[str, float | int]:
    """Both metrics of one trajectory [t s, x m, y m, heading rad]: position RMSE (m) at every
    odometry step and at the estimate times, and how many of each were compared."""
    odo_m, odo_n = position_rmse(estimates_at_odometry(trajectory, odometry), truth)
    est_m, est_n = position_rmse(trajectory, truth)
    return {"odometry_steps_m": odo_m, "estimate_times_m": est_m, "odometry_steps": odo_n,
            "estimates": est_n}


CALIBRATION_COLUMNS = {"s_v": "scale_v", "s_w": "scale_w"}
"""Odometry calibration state of an estimator -> column of the estimate table that
:func:`mrclam_metrics.estimates_at_odometry` applies."""


def scan_drive(reader: Any, config: Any, params: Any, *, truth: bool,
               data: Any = None) -> tuple[Any, Any, list[Any]]:
    """What the replay feeds an estimator with ``params`` on a scan-only log (MRCLAM): the
    log's data (with the ground truth when ``truth``; ``data``, when given, is that log's
    :class:`lgvtool.localize.logdata.LogData` already read), the odometry track its motion
    settings ask for, and its scan observations in time order (times in s after the data's
    ``t0_ns``)."""
    from lgvtool.localize.logdata import load_log, scan_batch
    from lgvtool.localize.motion import MotionTrack
    from lgvtool.localize.observations import scan_observations

    if data is None:
        data = load_log(reader, config.reflectors or None, truth=truth)
    if data.has_poses:
        raise ValueError("this driver replays scan-only logs (MRCLAM), this one has NAV poses")
    ms = params.motion_settings()
    track = MotionTrack(data.increments(ms, config.vehicle), ms.step_form)
    vehicle = config.vehicle
    obs = scan_observations(scan_batch(data.scans), vehicle.nav_x, vehicle.nav_y, track=track,
                            deskew=params.deskew, min_range=params.min_range_m,
                            max_range=params.max_range_m)
    obs.sort(key=lambda o: o.t)
    return data, track, obs


def calibrated_trajectory(reader: Any, name: str, trajectory: Trajectory, *, config: Any,
                          seed: int, settings: dict[str, Any],
                          initial_pose: str | None) -> pd.DataFrame:
    """``trajectory`` (what ``run_replay`` gave for estimator ``name``) as a table (t s since
    the epoch, x, y m, heading rad) with the odometry calibration the estimator held at each
    row (``scale_v``, ``scale_w``), so that the estimate is carried between rows the way the
    estimator itself predicts.

    ``run_replay`` returns poses only. For an estimator with odometry calibration states (the
    EKF with ``odometry_scales``) this runs it again over the same observations and motion, as
    ``replay`` does for a log without NAV poses (an MRCLAM log), recording its calibration after
    each observation; the replayed poses must equal ``trajectory``'s, else the driver and the
    replay disagree and this raises. Any other estimator's ``trajectory`` is returned as its
    poses alone.
    """
    from lgvtool.localize.registry import resolve_params, split_settings
    from lgvtool.localize.replay_driver import truth_pose_at

    params = resolve_params(name, config.estimators, split_settings(settings).get(name))
    if not getattr(params, "odometry_scales", False):
        return trajectory.to_frame()
    data, track, obs = scan_drive(reader, config, params, truth=initial_pose == "truth")
    start = truth_pose_at(data, obs[0].t) if initial_pose == "truth" else None
    times = np.array([o.t for o in obs], dtype=np.float64)
    rows = traced_run(name, params, data, config, track, times, obs, seed=seed, start=start)
    same = (len(rows) == len(trajectory)
            and np.allclose(rows["x"], trajectory.x, rtol=0.0, atol=1e-9)
            and np.allclose(rows["y"], trajectory.y, rtol=0.0, atol=1e-9)
            and np.allclose(rows["heading"], trajectory.heading, rtol=0.0, atol=1e-9))
    if not same:
        raise RuntimeError(f"{name}: the calibration driver does not reproduce run_replay's "
                           "trajectory")
    out = trajectory.to_frame()
    for column in CALIBRATION_COLUMNS.values():
        if column in rows:
            out[column] = rows[column].to_numpy()
    return out


def traced_run(name: str, params: Any, data: Any, config: Any, track: Any, times: Any,
               observations: list[Any], *, seed: int,
               start: tuple[float, float, float] | None, cls: Any = None) -> pd.DataFrame:
    """Run estimator ``name`` with ``params`` over ``observations`` at ``times`` (s after the
    data's ``t0_ns``; an observation None only moves the estimator to its time), moved by
    ``track``, from ``start`` (x, y m, heading rad; None: its own start), the way ``replay``
    runs it on a scan-only log. Returns one row per estimate: ``t`` (s after ``t0_ns``),
    ``x``, ``y`` (m), ``heading`` (rad, wrapped), and the odometry calibration it held then
    (``scale_v``, ``scale_w``, when it has odometry scales). ``cls``: an estimator class
    to run instead of the registered one of ``name`` (a prototype taking ``name``'s
    parameters)."""
    from lgvtool.localize.registry import ESTIMATORS
    from lgvtool.localize.replay_driver import estimator_rng

    cls = cls if cls is not None else ESTIMATORS[name]
    trace: list[dict[str, float]] = []
    scales = bool(getattr(params, "odometry_scales", False))

    class Traced(cls):  # type: ignore[misc]
        def estimate(self) -> Any:
            e = super().estimate()
            if e is not None and scales:
                trace.append(self.odometry_calibration)
            return e

    est = Traced(params, vehicle=config.vehicle, reflectors=data.reflectors, area=config.area,
                 rng=estimator_rng(seed, name), initial_pose=start)
    rows = est.run(times, observations, track.deltas(times[:-1], times[1:]),
                   cloud_size=0).poses
    out = pd.DataFrame({"t": rows.t, "x": rows.x, "y": rows.y,
                        "heading": np.remainder(rows.heading + math.pi, 2.0 * math.pi) - math.pi})
    for state, column in CALIBRATION_COLUMNS.items():
        if trace and state in trace[0]:
            out[column] = [c[state] for c in trace]
    return out


def run_robot(dataset: Path, robot: int, estimators: list[str], *, seed: int,
              settings: dict[str, Any], workdir: Path, inits: tuple[str, ...] = INITS,
              profile: bool = True, odometry_delay_s: float | None = None) -> dict[str, Any]:
    """Import one robot, replay the estimators from each start in ``inits``, score them.

    :param profile: keep the estimator settings the importer stored in the log; ``False``
        replaces them by the estimators' defaults (the NAV200 settings).
    :param odometry_delay_s: the importer's odometry delay, s (None: measured from the camera,
        the importer's default).
    :returns: ``robot``, the reference figures (m), ``import_s``, ``replay_s`` per start (s),
        ``results[init][estimator]`` as :func:`score` gives.
    """
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.importers.mrclam_quirks import ImportSettings
    from lgvtool.localize import run_replay
    from lgvtool.log import LogReader, topics

    log = workdir / f"robot{robot}.mcap"
    summary = import_robot(dataset, robot, log,
                           settings=ImportSettings(odometry_delay_s=odometry_delay_s))
    reader = LogReader(log)
    cfg = reader.config()
    if not profile:
        cfg = replace(cfg, estimators={})
    truth = reader.dataframe(topics.TRUTH)[["t", "x", "y", "heading"]]
    odometry = reader.dataframe(topics.ODOM)[["t", "v", "omega"]]
    ref_ekf, ref_dr = references(dataset)
    row: dict[str, Any] = {
        "robot": robot, "reference_ekf_m": ref_ekf.get(robot),
        "reference_dead_reckoning_m": ref_dr.get(robot),
        "import_s": round(summary.elapsed_s, 3), "replay_s": {}, "results": {},
        "calibration": {},
    }
    row["odometry_vs_truth"] = odometry_vs_truth(odometry, truth)
    row["timing"] = summary.timing
    for init in inits:
        names = [*estimators, DEAD_RECKONING] if init == "truth" else list(estimators)
        names = list(dict.fromkeys(names))
        own = {k: v for k, v in settings.items() if k.rpartition(".")[0] in names}
        t0 = time.perf_counter()
        result = run_replay(reader, names, config=cfg, seed=seed, settings=own,
                            initial_pose="truth" if init == "truth" else None, cloud_size=0)
        row["replay_s"][init] = round(time.perf_counter() - t0, 3)
        start = "truth" if init == "truth" else None
        trajectories = {
            name: calibrated_trajectory(reader, name, traj, config=cfg, seed=seed,
                                        settings=own, initial_pose=start)
            for name, traj in result.trajectories.items()
        }
        row["results"][init] = {
            name: score(trajectories[name], odometry, truth) if name in trajectories else None
            for name in names
        }
        row["calibration"][init] = {
            name: {col: round(float(traj[col].iloc[-1]), 4)
                   for col in CALIBRATION_COLUMNS.values() if col in traj}
            for name, traj in trajectories.items()
            if any(col in traj for col in CALIBRATION_COLUMNS.values())
        }
        if init == "truth" and DEAD_RECKONING in result.trajectories:
            # the perfect estimator: the ground truth at every observation time, carried
            # through the odometry in between like every estimate
            when = result.trajectories[DEAD_RECKONING].t
            row["results"][init][FLOOR] = score(truth_at(truth, when), odometry, truth)
    return row


def _fmt(value: float | None) -> str:
    return "-" if value is None or not math.isfinite(value) else f"{value:.3f}"


def best_of(row: dict[str, Any], init: str, estimators: list[str]) -> tuple[str, float]:
    """The estimator with the least RMSE at odometry steps for start ``init``, and its RMSE."""
    res = row["results"][init]
    scored = [(res[e]["odometry_steps_m"], e) for e in estimators
              if res.get(e) and math.isfinite(res[e]["odometry_steps_m"])]
    if not scored:
        return "-", math.nan
    value, name = min(scored)
    return name, value


def accuracy_table(rows: list[dict[str, Any]], estimators: list[str], init: str) -> str:
    """Markdown: RMSE at odometry steps per estimator, the best one against the reference EKF,
    and (start ``truth``) dead reckoning against the reference's."""
    dr = init == "truth"
    head = ["robot", *[f"`{e}`" for e in estimators], "reference EKF", "best / reference"]
    if dr:
        head += ["dead reckoning", "reference dead reckoning", "floor"]
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    ratios = []
    for r in rows:
        res, ref = r["results"][init], r["reference_ekf_m"]
        cells = [f"Robot{r['robot']}"]
        cells += [_fmt(res[e]["odometry_steps_m"] if res.get(e) else None) for e in estimators]
        name, value = best_of(r, init, estimators)
        ratio = value / ref if ref else math.nan
        ratios.append(ratio)
        cells += [_fmt(ref), f"{ratio:.2f} (`{name}`)" if math.isfinite(ratio) else "-"]
        if dr:
            d, f = res.get(DEAD_RECKONING), res.get(FLOOR)
            cells += [_fmt(d["odometry_steps_m"] if d else None),
                      _fmt(r["reference_dead_reckoning_m"]),
                      _fmt(f["odometry_steps_m"] if f else None)]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def estimate_time_table(rows: list[dict[str, Any]], estimators: list[str],
                        inits: tuple[str, ...]) -> str:
    """Markdown: RMSE at the estimate times, per start and estimator."""
    cols = [(init, e) for init in inits for e in estimators]
    if "truth" in inits:
        cols.append(("truth", DEAD_RECKONING))
    head = ["robot", *[f"`{e}` ({'from the truth' if i == 'truth' else 'own start'})"
                       for i, e in cols]]
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for r in rows:
        cells = [f"Robot{r['robot']}"]
        for i, e in cols:
            res = r["results"][i].get(e)
            cells.append(_fmt(res["estimate_times_m"] if res else None))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the Markdown tables (or JSON)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("dir", nargs="?", type=Path, default=None,
                    help="MRCLAM dataset folder (any of Datasets 1-9)")
    ap.add_argument("--dataset", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--estimators", default=",".join(DEFAULT_ESTIMATORS),
                    help="comma-separated estimator names")
    ap.add_argument("--init", default=",".join(INITS),
                    help="starts, comma-separated: truth (the ground truth at the first "
                         "observation), auto (each estimator's own initialisation)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the estimators' random draws")
    ap.add_argument("--set", dest="settings", action="append", default=[],
                    help="estimator setting over the log's profile, e.g. pf.particles=1000 "
                         "(repeatable)")
    ap.add_argument("--odometry-delay", default="auto",
                    help="odometry delay of the import, s, or auto (measured from the camera, "
                         "the importer's default)")
    ap.add_argument("--no-profile", action="store_true",
                    help="the estimators' defaults (NAV200) instead of the profile the "
                         "importer stores in the log")
    ap.add_argument("--keep", type=Path, default=None,
                    help="folder to keep the imported logs in (default: a temporary folder)")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    ap.add_argument("--quick", action="store_true",
                    help="the accuracy tables only: no cross-validation grid, no global "
                         "localisation")
    ap.add_argument("--seeds", type=int, default=10,
                    help="seeds per robot of the global localisation (0..N-1)")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs the grid and the global localisation "
                         "reuse")
    args = ap.parse_args(argv)

    dataset = args.dir or args.dataset or default_dataset()
    if not dataset.is_dir():
        print(f"mrclam_accuracy: dataset folder not found: {dataset} "
              "(set LGVTOOL_MRCLAM or pass DIR)", file=sys.stderr)
        return 2
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    try:
        available = MrclamDataset.open(dataset).robots
    except InputError as exc:
        print(f"mrclam_accuracy: {exc}", file=sys.stderr)
        return 2
    robots = [int(r) for r in args.robots.split(",") if r.strip() and int(r) in available]
    estimators = [e.strip() for e in args.estimators.split(",") if e.strip()]
    inits = tuple(i.strip() for i in args.init.split(",") if i.strip())
    delay = None if args.odometry_delay == "auto" else float(args.odometry_delay)
    if not set(inits) <= set(INITS):
        print(f"mrclam_accuracy: --init takes {', '.join(INITS)}", file=sys.stderr)
        return 2
    from lgvtool.config import parse_set_options

    settings = parse_set_options(args.settings)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        workdir = args.keep or Path(tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        for robot in robots:
            try:
                row = run_robot(dataset, robot, estimators, seed=args.seed, settings=settings,
                                workdir=workdir, inits=inits, profile=not args.no_profile,
                                odometry_delay_s=delay)
            except InputError as exc:
                print(f"mrclam_accuracy: {exc}", file=sys.stderr)
                return 2
            rows.append(row)
            for init in inits:
                res = row["results"][init]
                print(f"robot {robot} ({init}): " + ", ".join(
                    f"{e} {_fmt(v['odometry_steps_m'] if v else None)} m"
                    for e, v in res.items()) + f" (replay {row['replay_s'][init]:.1f} s)",
                    file=sys.stderr)
    if args.json:
        print(json.dumps({"seed": args.seed, "inits": list(inits), "settings": settings,
                          "odometry_delay_s": delay,
                          "profile": not args.no_profile, "rows": rows}, indent=2))
        return 0
    meta = (f"seed {args.seed}; odometry delay: "
            + ("measured from the camera" if delay is None else f"{delay} s")
            + "; estimator settings: "
            + ("the profile stored by the importer" if not args.no_profile
               else "the estimators' defaults")
            + ("; --set " + ", ".join(f"{k}={v}" for k, v in settings.items())
               if settings else ""))
    if "truth" in inits:
        print("Position RMSE (m) at every odometry step, every estimator started at the ground "
              "truth at its first observation:\n")
        print(accuracy_table(rows, estimators, "truth"))
        print()
    if "auto" in inits:
        print("Position RMSE (m) at every odometry step, each estimator's own initialisation:\n")
        print(accuracy_table(rows, estimators, "auto"))
        print()
    print("Position RMSE (m) at the estimate times (one per camera frame with a landmark):\n")
    print(estimate_time_table(rows, estimators, inits))
    print()
    print("Odometry against the ground truth (per 1 s window, after the import's delay; 1 = the "
          "commands are exact), beside what the estimators learnt without it: the delay the "
          "importer measured from the camera, and the odometry scales of the estimators that "
          "hold them at the end of the run from the truth:\n")
    learnt = sorted({e for r in rows for e in r["calibration"].get("truth", {})})
    head = ["robot", "distance travelled / commanded", "heading change / commanded",
            "odometry delay (s)", *[f"`{e}` s_v, s_w" for e in learnt]]
    print("| " + " | ".join(head) + " |")
    print("|---|" + "---:|" * (len(head) - 1))
    for r in rows:
        o, tm = r["odometry_vs_truth"], r["timing"]
        cells = [f"Robot{r['robot']}", f"{o['distance_ratio']:.3f}", f"{o['turn_ratio']:.3f}",
                 f"{tm['odometry_delay_s']:.3f}"]
        for e in learnt:
            c = r["calibration"].get("truth", {}).get(e, {})
            cells.append(f"{c['scale_v']:.3f}, {c['scale_w']:.3f}" if c else "-")
        print("| " + " | ".join(cells) + " |")
    print()
    ratios = [best_of(r, "truth", estimators)[1] / r["reference_ekf_m"]
              for r in rows if "truth" in inits and r["reference_ekf_m"]]
    if ratios:
        met = sum(1 for x in ratios if x <= TARGET_RATIO)
        print(f"Target best / reference <= {TARGET_RATIO}: met on {met} of {len(ratios)} "
              f"robots (worst ratio {max(ratios):.2f}, mean {float(np.mean(ratios)):.2f}).")
    own = [best_of(r, "auto", estimators)[1] / r["reference_ekf_m"]
           for r in rows if "auto" in inits and r["reference_ekf_m"]]
    if own:
        met = sum(1 for x in own if x <= TARGET_RATIO)
        print(f"Own start, best / reference <= {TARGET_RATIO}: met on {met} of {len(own)} "
              f"robots (worst ratio {max(own):.2f}).")
    if not args.quick:
        from mrclam_cv import cross_validation
        from mrclam_global import global_table

        ref_ekf = references(dataset)[0]
        done = [r["robot"] for r in rows]
        print()
        print("Leave-one-robot-out cross-validation of the `ekf` profile (own start):\n")
        print(cross_validation(dataset, done, args.cache, ref_ekf, TARGET_RATIO))
        print()
        print("Global localisation of `pf` from a uniform start over the arena:\n")
        print(global_table(dataset, done, args.seeds, 180.0, args.cache))
        print()
    print(f"{meta}. Reference: the dataset's plain EKF (known data association, chi-square "
          "gate, initialised at the first ground-truth pose, RMSE at every odometry step). "
          f"Data: UTIAS MRCLAM Dataset {MrclamDataset.open(dataset).number or dataset.name}, "
          "K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, IJRR 30(8):969-974, 2011.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
