"""The MRCLAM `ekf` on odometry calibrated from the other half of the run (docs/mrclam.md,
"Calibrated on one half, scored on the other").

For each robot and each half X of its scored span (:func:`mrclam_halves.span_of`), the robot's
files are cut to half X (the odometry by its log time, the stamp plus the odometry delay the
importer measured on the whole run), imported with that delay, and calibrated as a user would,
from the camera alone: ``lgvtool calibrate --estimate odom_scale_v,odom_scale_w,odom_yaw_per_m
--compare none`` (no ground truth is read). The stored profile's `ekf` then runs on the other
half with that file (the odometry corrected as the file says, the odometry scales' prior the
file sets), from the ground truth at the half's start as :mod:`mrclam_halves` runs a half, and
is scored as there: position RMSE (m) at every odometry step, the estimate carried between its
rows by the corrected odometry, as its own prediction does.

Printed per robot and half: the RMSE with and without the file, its ratio to the plain EKF on
the half (:func:`mrclam_halves.plain_scores`) and, for Dataset 6, to the apportioned reference
EKF; and the fit score (worst + 0.25 x mean) over the halves.

Usage::

    python benchmarks/mrclam_calibrated_halves.py DIR   # any MRCLAM dataset folder, ~20 s
    python benchmarks/mrclam_calibrated_halves.py MRCLAM_Dataset6 --calibrate-on MRCLAM_Dataset7

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from mrclam_accuracy import TARGET_RATIO, references
from mrclam_cv import cached_log
from mrclam_halves import RobotLog, Span, replay, rmse_between, robot_with_plain, span_of

ESTIMATED = ("odom_scale_v", "odom_scale_w", "odom_yaw_per_m")
"""What the calibration estimates: the odometry's two scales and its drift per metre."""


def cut_dataset(dataset: Path, robot: int, start_s: float, end_s: float, delay_s: float,
                folder: Path) -> Path:
    """A dataset folder in ``folder`` holding ``robot``'s rows between ``start_s`` and
    ``end_s`` (s since the epoch, the log's time: a measurement's and a ground-truth row's
    stamp, an odometry row's stamp plus ``delay_s``) and the shared files; returns it (named
    as ``dataset``, so that it reads as the same dataset)."""
    out = folder / dataset.name
    out.mkdir(parents=True, exist_ok=True)
    for name in ("Barcodes.dat", "Landmark_Groundtruth.dat"):
        shutil.copyfile(dataset / name, out / name)
    for kind, shift in (("Odometry", delay_s), ("Measurement", 0.0), ("Groundtruth", 0.0)):
        name = f"Robot{robot}_{kind}.dat"
        keep = []
        for line in (dataset / name).read_text().splitlines():
            head = line.split(None, 1)[0] if line.strip() else ""
            try:
                t = float(head) + shift
            except ValueError:
                keep.append(line)  # comments and headers
                continue
            if start_s <= t < end_s:
                keep.append(line)
        (out / name).write_text("\n".join(keep) + "\n")
    return out


def calibrated_from(dataset: Path, robot: int, log: RobotLog, start: float, end: float,
                    work: Path) -> tuple[Any, dict[str, Any]]:
    """The configuration ``lgvtool calibrate`` writes from ``robot``'s data between ``start``
    and ``end`` (s after the log's ``t0_ns``), and the estimates (value and 1-sigma)."""
    from lgvtool.calibrate.calibration_run import calibrate
    from lgvtool.importers.mrclam_log import import_robot
    from lgvtool.importers.mrclam_quirks import ImportSettings

    delay = float(log.timing["odometry_delay_s"])
    cut = cut_dataset(dataset, robot, log.t0_s + start, log.t0_s + end, delay, work)
    path = work / f"robot{robot}-cut.mcap"
    import_robot(cut, robot, path, settings=ImportSettings(odometry_delay_s=delay))
    result = calibrate([str(path)], estimate=ESTIMATED, compare_with=())
    estimates = {n: {"value": e.value, "sigma": e.sigma} for n, e in result.estimates.items()
                 if n in ESTIMATED}
    return result.config, estimates


def with_calibration(log: RobotLog, config: Any) -> RobotLog:
    """``log`` as the calibrated ``config`` replays it: its odometry corrected by the file's
    generic odometry (:func:`lgvtool.localize.installation.apply_installation`, in the data and
    in the table the estimate is carried by), its estimator settings the file's."""
    from lgvtool.localize.installation import apply_installation

    v = config.vehicle
    data = apply_installation(log.data, v)
    assert data.twist is not None and len(data.twist["v"]) == len(log.odometry)
    # the table holds the same odometry rows as the data, in the same order
    odometry = log.odometry.assign(v=np.asarray(data.twist["v"]),
                                   omega=np.asarray(data.twist["omega"]))
    return replace(log, config=replace(log.config, vehicle=v, estimators=config.estimators),
                   data=data, odometry=odometry)


def half_rmse(log: RobotLog, span: Span, half: str, seed: int) -> float:
    """The stored profile's `ekf` (the log's own settings) on ``half`` of ``span``, replayed
    from the ground truth at its start; RMSE (m) at every odometry step of the half."""
    if half == "A":
        est = replay(log, "ekf", {}, span.start, span.mid, seed=seed)
        return rmse_between(est, log, span.start, span.mid - 1e-6)
    est = replay(log, "ekf", {}, span.mid, span.end + 1.0, seed=seed)
    return rmse_between(est, log, span.mid, span.end)


def run(dataset: Path, robots: list[int], cache: Path, seed: int,
        calibrate_on: Path | None = None) -> dict[str, Any]:
    """Every robot's halves with and without the other half's calibration, or (given
    ``calibrate_on``, another recording of the same robots) with the calibration from the
    robot's whole scored span there."""
    ref_run = references(dataset)[0]
    rows: list[dict[str, Any]] = []
    for robot in robots:
        t0 = time.perf_counter()
        log, span, plain = robot_with_plain(dataset, robot, cache, seed)
        bounds = {"A": (span.start, span.mid), "B": (span.mid, span.end + 1.0)}
        elsewhere = None
        if calibrate_on is not None:
            other_log = RobotLog.read(cached_log(calibrate_on, robot, cache))
            other_span = span_of(other_log.data)
            with tempfile.TemporaryDirectory() as tmp:
                elsewhere = calibrated_from(calibrate_on, robot, other_log, other_span.start,
                                            other_span.end + 1.0, Path(tmp))
        for half, other in (("A", "B"), ("B", "A")):
            if elsewhere is not None and calibrate_on is not None:
                config, estimates = elsewhere
                other = calibrate_on.name
            else:
                with tempfile.TemporaryDirectory() as tmp:
                    config, estimates = calibrated_from(dataset, robot, log, *bounds[other],
                                                        Path(tmp))
            row: dict[str, Any] = {
                "robot": robot, "half": half, "calibrated_on": other,
                "estimates": estimates,
                "profile_m": half_rmse(log, span, half, seed),
                "calibrated_m": half_rmse(with_calibration(log, config), span, half, seed),
                "plain_m": plain[half]}
            if robot in ref_run:
                row["reference_m"] = ref_run[robot] * plain[half] / plain["run"]
            rows.append(row)
        print(f"robot {robot}: " + ", ".join(
            f"{r['half']} {r['profile_m']:.3f} -> {r['calibrated_m']:.3f} m"
            for r in rows[-2:]) + f" ({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    return {"dataset": dataset.name, "seed": seed, "rows": rows,
            "calibrated_on": None if calibrate_on is None else calibrate_on.name}


def fit(ratios: list[float]) -> float:
    """The rule's fit score: the worst ratio plus a quarter of the mean."""
    return float(max(ratios) + 0.25 * np.mean(ratios))


def markdown(res: dict[str, Any]) -> str:
    """The table of docs/mrclam.md."""
    rows = res["rows"]
    has_ref = all("reference_m" in r for r in rows)
    head = ["robot", "half", "calibrated on", "odom_scale_v", "odom_scale_w",
            "odom_yaw_per_m, deg/m", "profile, m", "calibrated, m", "ratio to plain EKF"]
    if has_ref:
        head.append("ratio to reference EKF")
    lines = ["| " + " | ".join(head) + " |", "|---|---|---|" + "---:|" * (len(head) - 3)]
    for r in rows:
        e = r["estimates"]
        cells = [f"Robot{r['robot']}", r["half"], r["calibrated_on"],
                 f"{e['odom_scale_v']['value']:.3f}", f"{e['odom_scale_w']['value']:.3f}",
                 f"{np.degrees(e['odom_yaw_per_m']['value']):+.2f}",
                 f"{r['profile_m']:.3f}", f"{r['calibrated_m']:.3f}",
                 f"{r['profile_m'] / r['plain_m']:.3f} -> {r['calibrated_m'] / r['plain_m']:.3f}"]
        if has_ref:
            ratio = r["calibrated_m"] / r["reference_m"]
            text = f"{r['profile_m'] / r['reference_m']:.3f} -> {ratio:.3f}"
            cells.append(f"**{text}**" if ratio > TARGET_RATIO else text)
        lines.append("| " + " | ".join(cells) + " |")
    prof = [r["profile_m"] / r["plain_m"] for r in rows]
    cal = [r["calibrated_m"] / r["plain_m"] for r in rows]
    where = ("the other half" if res.get("calibrated_on") is None
             else f"{res['calibrated_on']}'s whole runs")
    lines += ["", f"Fit score over the {len(rows)} halves (ratio to the plain EKF): profile "
              f"{fit(prof):.3f}, calibrated on {where} {fit(cal):.3f}."]
    if has_ref:
        met = [r["calibrated_m"] / r["reference_m"] <= TARGET_RATIO for r in rows]
        was = [r["profile_m"] / r["reference_m"] <= TARGET_RATIO for r in rows]
        lines.append(f"At or below {TARGET_RATIO} x the reference EKF: {sum(met)} of "
                     f"{len(rows)} halves calibrated on {where} ({sum(was)} of "
                     f"{len(rows)} without a calibration).")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Run; print the Markdown table (or JSON)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("dataset", type=Path, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1,2,3,4,5", help="comma-separated robot numbers")
    ap.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "mrclam-logs",
                    help="folder of the imported logs, reused between runs")
    ap.add_argument("--seed", type=int, default=0, help="seed of the estimators' draws")
    ap.add_argument("--calibrate-on", type=Path, default=None,
                    help="another MRCLAM recording of the same robots: calibrate each robot "
                         "on its whole run there instead of on the other half")
    ap.add_argument("--json-out", type=Path, default=None, help="also write the JSON result")
    args = ap.parse_args(argv)
    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import MrclamDataset

    try:
        available = MrclamDataset.open(args.dataset).robots
        if args.calibrate_on is not None:
            MrclamDataset.open(args.calibrate_on)
            if args.calibrate_on.resolve() == args.dataset.resolve():
                raise InputError("--calibrate-on is the scored dataset; give another recording")
        robots = [int(r) for r in args.robots.split(",") if r.strip()]
        if not robots or any(r not in available for r in robots):
            raise InputError(f"--robots {args.robots}: the dataset has robots "
                             f"{', '.join(map(str, available))}")
        res = run(args.dataset, robots, args.cache, args.seed, args.calibrate_on)
    except (InputError, ValueError) as exc:
        print(f"mrclam_calibrated_halves: {exc}", file=sys.stderr)
        return 2
    if args.json_out is not None:
        args.json_out.write_text(json.dumps(res, indent=2))
    print(markdown(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())

