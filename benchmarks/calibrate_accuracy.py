"""Accuracy and speed of ``lgvtool calibrate`` on simulated drives with known installation
errors (docs/calibration.md, "Accuracy").

Simulates a paper-circle and a warehouse drive (200 s each by default) of a vehicle with the
installation errors below, in the paper's setup (the NAV200's reflector scans logged beside its
poses, ``sim.paper_scans``; with ``--observations poses`` without them, as a NAV200 recording
is), runs ``lgvtool calibrate`` on both as a subprocess (timed, with and
without the before/after table), and prints every estimate against the true value, its error,
its 1-sigma and the error in sigmas, then the before/after table of the estimators.

The true wheel radii are the wheels' own times the load's compression of them (``drive.*``,
on by default: what a calibration can find). The true gyro bias is the mean over both drives
of the simulated bias (constant plus random walk), read back from the MCU frames: the
reported rate minus the scaled true rate. The true
NAV pose age is the mean over both drives of each logged pose's receive time minus the middle
of the revolution the device reported in it, minus the time offset.

    python benchmarks/calibrate_accuracy.py --seeds 2026 2027 --duration 200
    python benchmarks/calibrate_accuracy.py --seeds 2026 2027 --observations poses

With ``--observations poses`` (what a NAV200 recording has) the time offset's true value is the
whole age of a pose: no pose age is estimated beside it.
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
          "mcu.gyro_scale_error": 0.005, "sim.paper_scans": True}
TOLERANCE = {"nav_x": (3.0, "mm"), "nav_y": (3.0, "mm"), "nav_yaw": (0.05, "deg"),
             "wheel_radius_left": (0.05, "%"), "wheel_radius_right": (0.05, "%"),
             "track": (2.0, "mm"), "gyro_scale": (0.05, "%"), "nav_time_offset": (3.0, "ms")}


def pose_ages(sim, log: str) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Age of every logged NAV pose beyond the time offset: receive time minus the middle of
    the revolution its reply reported, s."""
    from lgvtool.log import LogReader

    t = LogReader(log).dataframe("/nav/pose")["t"].to_numpy() - sim.start_ns * 1e-9
    polls = np.asarray(sim.nav_traffic.poll_times)
    solution = np.asarray(sim.nav_traffic.solution)
    k = np.searchsorted(polls, t, side="right") - 1
    t, k = t[k >= 0], k[k >= 0]
    s = solution[k]
    mid = sim.scans.start + sim.scans.period / 2
    return np.asarray(t[s >= 0] - mid[s[s >= 0]] - sim.settings.install.nav_time_offset_ms * 1e-3)


def true_values(sims: list, logs: list[str]) -> dict[str, float]:  # type: ignore[type-arg]
    v = sims[0].vehicle
    mcu = sims[0].settings.mcu
    drive = sims[0].settings.drive
    # the load compresses the encoder wheels: the radius a calibration can find is this much
    # smaller than the wheel's own
    load = 1.0 + drive.load_fraction * drive.radius_change_at_rated_load
    out = {"nav_x": v.nav_x, "nav_y": v.nav_y, "nav_yaw": v.nav_yaw, "track": v.track,
           "wheel_radius_left": 0.075 * (1 + mcu.wheel_radius_error_left) * load,
           "wheel_radius_right": 0.075 * (1 + mcu.wheel_radius_error_right) * load,
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
    out["nav_pose_age"] = float(np.mean(np.concatenate(
        [pose_ages(sim, log) for sim, log in zip(sims, logs, strict=True)])))
    return out


def true_geometry_laser(logs: list[str], truth: dict[str, float]) -> dict[str, float]:
    """The laser baseline's truth RMSE (m) per log and over both with the true NAV mounting,
    time offset and mean pose age in the configuration."""
    from dataclasses import replace

    from lgvtool.app.evaluate_job import evaluate_log
    from lgvtool.log import LogReader

    out: dict[str, float] = {}
    sq = n = 0.0
    for log in logs:
        cfg = LogReader(log).config()
        vehicle = replace(cfg.vehicle, **{k: truth[k] for k in (
            "nav_x", "nav_y", "nav_yaw", "nav_time_offset", "nav_pose_age")})
        ev = evaluate_log(log, estimators=["laser"], config=replace(cfg, vehicle=vehicle),
                          replay=True).estimators["laser"]
        out[Path(log).name] = ev.truth.position_rmse
        sq += ev.truth.position_rmse ** 2 * ev.truth.samples
        n += ev.truth.samples
    out["all"] = math.sqrt(sq / n)
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
    ap.add_argument("--observations", default="auto", choices=("auto", "scans", "poses"),
                    help="what calibrate reads: poses alone is what a NAV200 recording has")
    args = ap.parse_args()

    from lgvtool.calibrate.quantities import QUANTITIES
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    with tempfile.TemporaryDirectory() as tmp:
        sims, logs = [], []
        for scenario, seed in zip(("paper-circle", "warehouse"), args.seeds, strict=True):
            # a NAV200 recording has no reflector scans: with --observations poses none are
            # logged, so that the before/after table replays what such a recording holds
            overrides = {**ERRORS, "sim.paper_scans": args.observations != "poses"}
            sim = simulate(scenario, seed=seed, duration=args.duration, overrides=overrides)
            path = Path(tmp) / f"{scenario}-{seed}.mcap"
            write_log(sim, path)
            sims.append(sim)
            logs.append(str(path))
        truth = true_values(sims, logs)
        if args.observations == "poses":
            # from poses alone the time offset is the whole age of a pose (no pose age beside)
            truth["nav_time_offset"] += truth.pop("nav_pose_age")
        base = [sys.executable, "-m", "lgvtool", "calibrate", *logs, "--json", "--force",
                "--observations", args.observations]
        wall, cpu, _ = run([*base, "-o", str(Path(tmp) / "a.toml"), "--compare", "none"])
        print(f"calibrate on {2 * args.duration:g} s of logs, no table: {wall:.2f} s wall, "
              f"{cpu:.2f} s CPU")
        wall2, cpu2, out = run([*base, "-o", str(Path(tmp) / "b.toml"), "--compare",
                                args.compare])
        print(f"calibrate with the table ({args.compare}): {wall2:.2f} s wall, "
              f"{cpu2:.2f} s CPU")
        reference = true_geometry_laser(logs, {"nav_pose_age": 0.0, **truth})
    doc = json.loads(out)
    print(f"\n{'quantity':20s} {'true':>11s} {'estimate':>11s} {'error':>9s} {'1-sigma':>8s} "
          f"{'z':>6s}  tolerance")
    for name, true in truth.items():
        e = doc["estimates"][name]
        q = QUANTITIES[name]
        if e["sigma"] is None:
            print(f"{name:20s} {true * q.display:11.5f} {e['value']:11.5f}  ({e['status']})")
            continue
        err = (e["value_si"] - true) * q.display
        sig = e["sigma"]
        tol, unit = TOLERANCE.get(name, (math.nan, ""))
        shown = err / (true * q.display) * 100 if unit == "%" else err
        within = "" if math.isnan(tol) else (
            f"{'ok ' if abs(shown) <= tol else 'MISSED'} |{shown:.4f}| <= {tol} {unit}")
        print(f"{name:20s} {true * q.display:11.5f} {e['value']:11.5f} {err:+9.5f} "
              f"{sig:8.5f} {err / sig:+6.2f}  {within}")
    print(f"\n{'log':24s} {'estimator':14s} {'nominal mm':>11s} {'calibrated mm':>14s} change")
    for r in doc["comparison"]:
        name = Path(r["log"]).name if r["log"] != "all" else "all"
        print(f"{name:24s} {r['estimator']:14s} {r['before_m'] * 1e3:11.1f} "
              f"{r['after_m'] * 1e3:14.1f} {r['change_percent']:+6.1f} % ({r['metric']})")
    print("\nlaser with the simulator's true mounting, time offset and pose age (the best a "
          "calibration can give it):")
    for name, rmse in reference.items():
        print(f"{name:24s} {'laser':14s} {rmse * 1e3:11.1f} mm (truth_rmse_m)")


if __name__ == "__main__":
    main()
