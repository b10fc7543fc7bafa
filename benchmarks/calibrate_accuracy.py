"""Accuracy and speed of ``lgvtool calibrate`` on simulated drives with known installation
errors (docs/calibration.md, "Accuracy").

Simulates a paper-circle and a warehouse drive (200 s each by default) of a vehicle with the
installation errors below, runs ``lgvtool calibrate`` on both as a subprocess (timed, with and
without the before/after table), and prints every estimate against the true value, its error,
its 1-sigma and the error in sigmas, then the before/after table of the estimators.

The true gyro bias is the mean over both drives of the simulated bias (constant plus random
walk), read back from the MCU frames: the reported rate minus the scaled true rate.

    python benchmarks/calibrate_accuracy.py --seeds 2026 2027 --duration 200
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

ERRORS = {"install.nav_dx_mm": 20.0, "install.nav_dy_mm": -10.0, "install.nav_yaw_deg": 0.5,
          "install.track_error_mm": 5.0, "install.nav_time_offset_ms": 30.0,
          "mcu.wheel_radius_error_left": 0.004, "mcu.wheel_radius_error_right": -0.003,
          "mcu.gyro_scale_error": 0.005}
TOLERANCE = {"nav_x": (3.0, "mm"), "nav_y": (3.0, "mm"), "nav_yaw": (0.05, "deg"),
             "wheel_radius_left": (0.05, "%"), "wheel_radius_right": (0.05, "%"),
             "track": (2.0, "mm"), "gyro_scale": (0.05, "%"), "nav_time_offset": (3.0, "ms")}


def true_values(sims: list) -> dict[str, float]:  # type: ignore[type-arg]
    v = sims[0].vehicle
    mcu = sims[0].settings.mcu
    out = {"nav_x": v.nav_x, "nav_y": v.nav_y, "nav_yaw": v.nav_yaw, "track": v.track,
           "wheel_radius_left": 0.075 * (1 + mcu.wheel_radius_error_left),
           "wheel_radius_right": 0.075 * (1 + mcu.wheel_radius_error_right),
           "gyro_scale": 1 + mcu.gyro_scale_error,
           "nav_time_offset": sims[0].settings.install.nav_time_offset_ms * 1e-3}
    biases = []
    for sim in sims:
        t = sim.mcu.t
        period = sim.settings.mcu.period_s / (1 + sim.settings.mcu.clock_drift_ppm * 1e-6)
        _, _, h1 = sim.truth.pose_at(t)
        _, _, h0 = sim.truth.pose_at(np.maximum(t - period, 0.0))
        rate = (h1 - h0) / np.maximum(t - np.maximum(t - period, 0.0), 1e-9)
        gyro = np.array([f.gyro_rate for f in sim.mcu.frames])
        biases.append(gyro - rate * out["gyro_scale"])
    out["gyro_bias"] = float(np.mean(np.concatenate(biases)))
    return out


def run(cmd: list[str]) -> tuple[float, float, str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    r0 = os.times()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    r1 = os.times()
    if p.returncode != 0:
        raise SystemExit(p.stderr)
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    return time.perf_counter() - t0, cpu, p.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs=2, default=(2026, 2027))
    ap.add_argument("--duration", type=float, default=200.0)
    ap.add_argument("--compare", default="laser,deadreckoning,ekf,pf-paper,pf")
    args = ap.parse_args()

    from lgvtool.calibrate.quantities import QUANTITIES
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.run import simulate

    with tempfile.TemporaryDirectory() as tmp:
        sims, logs = [], []
        for scenario, seed in zip(("paper-circle", "warehouse"), args.seeds, strict=True):
            sim = simulate(scenario, seed=seed, duration=args.duration, overrides=ERRORS)
            path = Path(tmp) / f"{scenario}-{seed}.mcap"
            write_log(sim, path)
            sims.append(sim)
            logs.append(str(path))
        truth = true_values(sims)
        base = [sys.executable, "-m", "lgvtool", "calibrate", *logs, "--json", "--force"]
        wall, cpu, _ = run([*base, "-o", str(Path(tmp) / "a.toml"), "--compare", "none"])
        print(f"calibrate on {2 * args.duration:g} s of logs, no table: {wall:.2f} s wall, "
              f"{cpu:.2f} s CPU")
        wall2, cpu2, out = run([*base, "-o", str(Path(tmp) / "b.toml"), "--compare",
                                args.compare])
        print(f"calibrate with the table ({args.compare}): {wall2:.2f} s wall, "
              f"{cpu2:.2f} s CPU")
    doc = json.loads(out)
    print(f"\n{'quantity':20s} {'true':>11s} {'estimate':>11s} {'error':>9s} {'1-sigma':>8s} "
          f"{'z':>6s}  tolerance")
    for name, true in truth.items():
        e = doc["estimates"][name]
        q = QUANTITIES[name]
        err = (e["value_si"] - true) * q.display
        sig = e["sigma"]
        tol, unit = TOLERANCE.get(name, (math.nan, ""))
        shown = err / (true * q.display) * 100 if unit == "%" else err
        within = "" if math.isnan(tol) else (
            f"{'ok ' if abs(shown) <= tol else 'MISSED'} |{shown:.4f}| <= {tol} {unit}")
        print(f"{name:20s} {true * q.display:11.5f} {e['value']:11.5f} {err:+9.5f} "
              f"{sig:8.5f} {err / sig:+6.2f}  {within}")
    age = doc["estimates"].get("nav_pose_age")
    if age:
        print(f"{'nav_pose_age':20s} {'':>11s} {age['value']:11.3f} {'':>9s} {age['sigma']:8.3f}")
    print(f"\n{'log':24s} {'estimator':14s} {'nominal mm':>11s} {'calibrated mm':>14s} change")
    for r in doc["comparison"]:
        name = Path(r["log"]).name if r["log"] != "all" else "all"
        print(f"{name:24s} {r['estimator']:14s} {r['before_m'] * 1e3:11.1f} "
              f"{r['after_m'] * 1e3:14.1f} {r['change_percent']:+6.1f} % ({r['metric']})")


if __name__ == "__main__":
    main()
