"""Where the simulated laser navigation's error comes from: switch each mechanism off in turn.

For each case the script simulates a scenario (default ``paper-circle``), writes the log, reads
the NAV200 poses back from it exactly as a consumer would, converts each head pose to the point
O (the paper's eq. 5, corrected: x_O = x_N - d_x cos(theta) + d_y sin(theta), and
likewise for y) and measures, while the vehicle drives:

- the radial error against the circle of radius h / tan(delta) whose centre is fitted by least
  squares (the paper's Table 1 error): mean, standard deviation and RMSE in mm, plus the
  paper's per-rotation averages of RMSE and variance;
- the 2-D error of O against the ground truth at the host's receive time, mm (this one also
  sees the latency, which moves O along the circle and so cannot show in the radial error);
- the radial RMSE of the true path of O itself about the circle of radius h / tan(delta) whose
  centre is fitted to it, mm: how far the vehicle departs from the kinematic model
  (``drive.*``), which every radial figure of an estimator includes.

Usage::

    python benchmarks/sim_error_budget.py [--scenario paper-circle] [--seed 1]
                                          [--sweep mechanisms|start|weights|fit] [--json]

Prints a Markdown table (the one in docs/simulator.md) or JSON.
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

from lgvtool.log import LogReader, topics
from lgvtool.log.messages import yaw_from_quaternion
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate
from lgvtool.timestamps import from_stamp

IDEAL_HEAD: dict[str, Any] = {"nav.angle_step_deg": 0.0, "site.survey_sigma_mm": 0.0,
                              "site.range_bias_sigma_mm": 0.0, "site.floor_tilt_deg": 0.0}
"""Bearings and ranges to the reflectors' centres, an exact map, no reflector's own range
offset and a level floor (systematic, not noise)."""

DRIVE_OFF: dict[str, Any] = {"drive.steering_offset_deg": 0.0, "drive.wobble_deg": 0.0,
                             "drive.understeer_deg_per_g": 0.0, "drive.load_fraction": 0.0}
"""The vehicle drives exactly the kinematic path of its commands."""

CASES: list[tuple[str, dict[str, Any]]] = [
    ("all mechanisms (defaults)", {}),
    ("no head-rotation skew", {"nav.skew": False}),
    ("no latency", {"nav.latency_s": 0.0, "nav.reply_delay_s": 0.0}),
    ("no lever arm (head above O)", {"vehicle.nav_x": 0.0}),
    ("all reflectors in the fit", {"nav.max_reflectors": 0}),
    ("every reflector detected", {"nav.detection_probability": 1.0, "nav.detection_range_m": 0.0}),
    ("no range growth of the noise", {"nav.sigma_range_per_m_mm": 0.0}),
    ("centres, no pulse grid", {"nav.angle_step_deg": 0.0}),
    ("exact map", {"site.survey_sigma_mm": 0.0}),
    ("no reflector range bias", {"site.range_bias_sigma_mm": 0.0}),
    ("level floor (no head tilt)", {"site.floor_tilt_deg": 0.0}),
    ("matched from the true pose", {"nav.identification": "truth"}),
    ("no measurement noise", {"nav.noise": False}),
    ("no steering offset", {"drive.steering_offset_deg": 0.0}),
    ("no steering wobble", {"drive.wobble_deg": 0.0}),
    ("no slip while turning", {"drive.understeer_deg_per_g": 0.0}),
    ("no load on the encoder wheels", {"drive.load_fraction": 0.0}),
    ("kinematic path (no drive mechanism)", DRIVE_OFF),
    ("skew only", {"nav.noise": False, "nav.latency_s": 0.0, "nav.reply_delay_s": 0.0,
                   **IDEAL_HEAD, **DRIVE_OFF}),
    ("noise only", {"nav.skew": False, "nav.latency_s": 0.0, "nav.reply_delay_s": 0.0,
                    **DRIVE_OFF}),
    ("none", {"nav.skew": False, "nav.noise": False, "nav.latency_s": 0.0,
              "nav.reply_delay_s": 0.0, **IDEAL_HEAD, **DRIVE_OFF}),
]
"""(label, --set overrides) of each row."""

START_CASES: list[tuple[str, dict[str, Any]]] = [
    (f"revolution starts at {a} deg", {"nav.scan_start_deg": float(a)}) for a in (0, 90, 180, 270)
]
"""Where the device closes a revolution decides the direction of the skew error."""

WEIGHT_CASES: list[tuple[str, dict[str, Any]]] = [
    (f"device weights bearings as {b} deg", {"nav.solver_sigma_bearing_deg": b})
    for b in (0.025, 0.04, 0.05, 0.1, 0.2)
]
"""How much the device trusts its bearings decides how far the skew pulls the fit sideways."""

FIT_CASES: list[tuple[str, dict[str, Any]]] = [
    (f"device fits its {n} nearest reflectors" if n else "device fits every reflector it sees",
     {"nav.max_reflectors": n})
    for n in (4, 6, 8, 0)
]
"""The fewer reflectors the device fits, the more the fit changes with the set it sees."""


def fit_centre(x: np.ndarray, y: np.ndarray, radius: float) -> tuple[float, float]:
    """Centre (m) of the circle of fixed ``radius`` (m) nearest to the points, least squares."""
    cx, cy = float(np.mean(x)), float(np.mean(y))
    for _ in range(50):
        dx, dy = x - cx, y - cy
        r = np.hypot(dx, dy)
        res = r - radius
        jac = np.column_stack([-dx / r, -dy / r])
        step, *_ = np.linalg.lstsq(jac, -res, rcond=None)
        cx, cy = cx + float(step[0]), cy + float(step[1])
        if math.hypot(*step) < 1e-10:
            break
    return cx, cy


def measure(log: Path) -> dict[str, float]:
    """Error figures of the NAV poses in ``log`` (see the module docstring)."""
    reader = LogReader(log)
    meta = reader.metadata["simulator"]
    cfg = reader.config()
    ref = meta["reference"]
    start_ns = int(meta["start_epoch_s"]) * 1_000_000_000
    t0, t1 = float(ref["moving_from_s"]), float(ref["moving_until_s"])
    truth = [(m.log_time_ns, m.data["pose"]) for m in reader.messages([topics.TRUTH])]
    tt = np.array([(n - start_ns) / 1e9 for n, _ in truth])
    tx = np.array([p["position"]["x"] for _, p in truth])
    ty = np.array([p["position"]["y"] for _, p in truth])
    tth = np.unwrap([yaw_from_quaternion(p["orientation"]) for _, p in truth])
    rows = [m.data for m in reader.messages([topics.NAV_POSE]) if m.data["valid"]]
    t = np.array([(from_stamp(d["timestamp"]) - start_ns) / 1e9 for d in rows])
    keep = (t >= t0) & (t <= t1)
    hx = np.array([d["x"] for d in rows])[keep]
    hy = np.array([d["y"] for d in rows])[keep]
    th = np.array([d["heading"] for d in rows])[keep]
    t = t[keep]
    v = cfg.vehicle
    ox = hx - v.nav_x * np.cos(th) + v.nav_y * np.sin(th)
    oy = hy - v.nav_x * np.sin(th) - v.nav_y * np.cos(th)
    radius = v.circle_radius(float(ref["steering_angle"]))
    cx, cy = fit_centre(ox, oy, radius)
    err = (np.hypot(ox - cx, oy - cy) - radius) * 1000.0
    lap = np.floor((np.interp(t, tt, tth) - tth[0]) / (2 * math.pi)).astype(int)
    per_lap = [(float(np.sqrt(np.mean(err[lap == k] ** 2))), float(np.var(err[lap == k])))
               for k in np.unique(lap) if np.sum(lap == k) > 5]
    truth_err = np.hypot(ox - np.interp(t, tt, tx), oy - np.interp(t, tt, ty)) * 1000.0
    driving = (tt >= t0) & (tt <= t1)
    px, py = tx[driving], ty[driving]
    pcx, pcy = fit_centre(px, py, radius)
    path_err = (np.hypot(px - pcx, py - pcy) - radius) * 1000.0
    return {
        "poses": len(err),
        "mean_mm": float(np.mean(err)),
        "std_mm": float(np.std(err)),
        "rmse_mm": float(np.sqrt(np.mean(err ** 2))),
        "lap_rmse_mm": float(np.mean([p[0] for p in per_lap])),
        "lap_var_mm2": float(np.mean([p[1] for p in per_lap])),
        "truth_rmse_mm": float(np.sqrt(np.mean(truth_err ** 2))),
        "path_rmse_mm": float(np.sqrt(np.mean(path_err ** 2))),
    }


def run(scenario: str, seed: int, cases: list[tuple[str, dict[str, Any]]]
        ) -> list[dict[str, Any]]:
    """Simulate and measure every case; one dict of figures per case."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for label, overrides in cases:
            path = Path(tmp) / "run.mcap"
            write_log(simulate(scenario, seed=seed, overrides=overrides), path)
            out.append({"case": label, "set": overrides, **measure(path)})
    return out


def _set_text(overrides: dict[str, Any]) -> str:
    if not overrides:
        return "-"
    return " ".join(f"`{k}={str(v).lower() if isinstance(v, bool) else v}`"
                    for k, v in overrides.items())


def markdown(results: list[dict[str, Any]]) -> str:
    """The results as a Markdown table."""
    lines = [
        "| case | --set | radial mean mm | radial std mm | radial RMSE mm "
        "| per-rotation RMSE mm | per-rotation σ² mm² | vs truth RMSE mm | true path RMSE mm |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in results:
        lines.append(
            f"| {r['case']} | {_set_text(r['set'])} | {r['mean_mm']:.1f} | {r['std_mm']:.1f} "
            f"| {r['rmse_mm']:.1f} | {r['lap_rmse_mm']:.1f} | {r['lap_var_mm2']:.0f} "
            f"| {r['truth_rmse_mm']:.1f} | {r['path_rmse_mm']:.1f} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="paper-circle")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--sweep", choices=["mechanisms", "start", "weights", "fit"],
                    default="mechanisms",
                    help="switch mechanisms off in turn, move the revolution start, change "
                         "the device's bearing weight or how many reflectors it fits")
    ap.add_argument("--json", action="store_true", help="print JSON instead of Markdown")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    cases = {"mechanisms": CASES, "start": START_CASES, "weights": WEIGHT_CASES,
             "fit": FIT_CASES}[args.sweep]
    results = run(args.scenario, args.seed, cases)
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        print(f"scenario {args.scenario}, seed {args.seed}\n")
        print(markdown(results))
        print(f"\n({time.perf_counter() - started:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
