"""Accuracy of the pose observation model ``lgvtool calibrate`` estimates from NAV poses
(docs/calibration.md, "The pose observation model").

Simulates NAV200 recordings (poses only) of the given scenarios and seeds, calibrates each
(in process, without the before/after table, holding what a drive cannot observe), and sets
the pose model's age and skew lever against the simulated device's:

- the true age of a pose is its receive time minus the middle of the revolution the device
  reported in it (the simulation's own record of polls and solutions,
  ``calibrate_accuracy.pose_ages``), averaged over the log;
- the effective age is what an estimator needs: the shift that best aligns the reported
  headings with the true heading (the device fits its nearest reflectors, whose instants are
  not spread evenly over the revolution), less the MCU frames' mean delay from sample to the
  host's read (their time on the wire, the send jitter, the host's latency and jitter, from
  the simulator's settings), by which the odometry's clock, the log's read times, is late;
- the true lever is the least-squares fit of the reported head positions' error against the
  true head at those middles, ``(omega T / pi) R(heading) s``, with the true turn rate over
  the revolution: what the device's skew is, by the model's own definition, on this drive.

Two calibrations per log: the default one (the mounting ``nav_x``, ``nav_y``, ``nav_yaw``
estimated from the poses, which folds part of the skew into it) and one with the mounting held
at its true value (the simulator's nominal one), which isolates the pose model's fits. Each
estimate is printed with its error in its own 1-sigma; the summary gives the mean and RMS
error and the coverage of the 1-sigma (share within 1 and 2 sigma; a Gaussian gives 68 % and
95 %).

    python benchmarks/calibrate_pose_model.py --scenarios warehouse fast --seeds 9000-9009

It also prints the mounting of the default calibration against the simulated one (the
configured vehicle: these drives have no installation error).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

MOUNTING = ("nav_x", "nav_y", "nav_yaw")


def seeds_of(text: str) -> list[int]:
    """``9000-9009`` or ``9000,9003``: the seeds."""
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out += list(range(int(a), int(b) + 1)) if b else [int(a)]
    return out


def true_lever(sim: object, log: str, nav_x: float, nav_y: float) -> tuple[float, float]:
    """The simulated device's skew lever on this drive (m, head frame): the reported head
    positions' error against the true head at the middle of each reported revolution, fitted
    by ``(omega T / pi) R(heading) s`` (``omega`` the true turn rate over the revolution)."""
    from lgvtool.log import LogReader

    frame = LogReader(log).dataframe("/nav/pose")
    t = frame["t"].to_numpy() - sim.start_ns * 1e-9  # type: ignore[attr-defined]
    polls = np.asarray(sim.nav_traffic.poll_times)  # type: ignore[attr-defined]
    solution = np.asarray(sim.nav_traffic.solution)  # type: ignore[attr-defined]
    k = np.searchsorted(polls, t, side="right") - 1
    ok = (k >= 0) & frame["valid"].to_numpy().astype(bool)
    s = np.where(ok, solution[np.maximum(k, 0)], -1)
    ok &= s >= 0
    scans = sim.scans  # type: ignore[attr-defined]
    period = float(scans.period)
    mid = scans.start[s[ok]] + 0.5 * period
    x, y, h = sim.truth.pose_at(mid)  # type: ignore[attr-defined]
    _, _, h0 = sim.truth.pose_at(mid - 0.5 * period)  # type: ignore[attr-defined]
    _, _, h1 = sim.truth.pose_at(mid + 0.5 * period)  # type: ignore[attr-defined]
    w = np.unwrap(np.stack([h0, h1]), axis=0)
    omega = (w[1] - w[0]) / period
    c, sn = np.cos(h), np.sin(h)
    hx, hy = x + c * nav_x - sn * nav_y, y + sn * nav_x + c * nav_y
    rx = frame["x"].to_numpy()[ok] - hx
    ry = frame["y"].to_numpy()[ok] - hy
    kk = omega * period / math.pi
    a = np.concatenate([np.stack([kk * c, -kk * sn], 1), np.stack([kk * sn, kk * c], 1)])
    b = np.concatenate([rx, ry])
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    return float(sol[0]), float(sol[1])


def effective_age(sim: object, log: str) -> float:
    """The age (s) that aligns the reported headings with the true heading, less the MCU
    frames' mean delay from sample to read (the odometry's clock is that late)."""
    from lgvtool.log import LogReader

    frame = LogReader(log).dataframe("/nav/pose")
    ok = frame["valid"].to_numpy().astype(bool)
    t = frame["t"].to_numpy()[ok] - sim.start_ns * 1e-9  # type: ignore[attr-defined]
    h = frame["heading"].to_numpy()[ok]
    ages = np.arange(0.05, 0.35, 0.0005)
    cost = []
    for a in ages:
        _, _, th = sim.truth.pose_at(t - a)  # type: ignore[attr-defined]
        e = np.angle(np.exp(1j * (h - th)))
        cost.append(float(np.mean(e * e)))
    k = int(np.argmin(cost))
    c0, c1, c2 = cost[k - 1], cost[k], cost[k + 1]
    aligned = float(ages[k] + 0.5 * (c0 - c2) / (c0 - 2 * c1 + c2) * 0.0005)
    mcu = sim.settings.mcu  # type: ignore[attr-defined]
    delay = (30 * 10 / mcu.baud + mcu.send_jitter_s / 2 + mcu.host_latency_s
             + mcu.host_jitter_s / 2)
    return aligned - delay


def one(scenario: str, seed: int, folder: Path) -> dict[str, float]:
    """Simulate, calibrate twice, and the truth of one run (SI units)."""
    from calibrate_accuracy import pose_ages

    from lgvtool.calibrate.calibration_run import calibrate
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    sim = simulate(scenario, seed=seed)
    path = folder / f"{scenario}-{seed}.mcap"
    write_log(sim, path)
    row: dict[str, float] = {"age_true": float(np.mean(pose_ages(sim, str(path)))),
                             "age_effective": effective_age(sim, str(path))}
    out_default = calibrate([str(path)], compare_with=(), allow_unobservable=True)
    vehicle = out_default.start_config.vehicle
    row["skew_x_true"], row["skew_y_true"] = true_lever(sim, str(path), vehicle.nav_x,
                                                        vehicle.nav_y)
    # the simulated head sits where the vehicle is configured (no installation error)
    for name in MOUNTING:
        e = out_default.estimates[name]
        row[name + "_error"] = e.value - e.start
        row[name + "_sigma"] = e.sigma if e.sigma is not None else math.nan
    for tag, fix in (("", ()), ("_fixed", MOUNTING)):
        cal = out_default if not fix else calibrate([str(path)], compare_with=(),
                                                    allow_unobservable=True, fix=list(fix))
        pm = cal.pose_model
        if pm is None:
            continue
        row["age" + tag] = pm.total_age_s if pm.age.determined else math.nan
        row["age_sigma" + tag] = pm.age.sigma if pm.age.determined else math.nan
        row["skew_x" + tag] = pm.skew_x.value
        row["skew_y" + tag] = pm.skew_y.value
        row["skew_sigma" + tag] = pm.skew_x.sigma
    return row


def summary(rows: list[dict[str, float]], what: str, tag: str, unit: float, name: str,
            truth: str = "_true") -> str:
    """Mean and RMS error, coverage within 1 and 2 sigma, of estimate ``what + tag`` against
    ``what + truth``."""
    err, z = [], []
    for r in rows:
        v = r.get(what + tag, math.nan)
        sig = r.get(("age_sigma" if what == "age" else "skew_sigma") + tag, math.nan)
        if math.isfinite(v) and math.isfinite(sig):
            e = v - r[what + truth]
            err.append(e)
            z.append(abs(e) / sig)
    if not err:
        return f"{name}: never determined"
    errors = np.asarray(err) * unit
    zz = np.asarray(z)
    return (f"{name}: determined {len(err)}/{len(rows)}, error mean {errors.mean():+.3g}, RMS "
            f"{math.sqrt(float(np.mean(errors * errors))):.3g}, within 1 sigma {np.mean(zz <= 1):.0%}, "
            f"within 2 sigma {np.mean(zz <= 2):.0%}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenarios", nargs="+", default=["warehouse", "fast"])
    ap.add_argument("--seeds", default="9000-9009", help="e.g. 9000-9009 or 9000,9001")
    args = ap.parse_args()
    seeds = seeds_of(args.seeds)
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios:
            rows = []
            print(f"\n{scenario}: age ms (true, effective, calibrated +- 1-sigma, mounting held); "
                  f"lever m (true; calibrated +- 1-sigma; mounting held)")
            for seed in seeds:
                r = one(scenario, seed, Path(tmp))
                rows.append(r)

                def age(tag: str, r: dict[str, float] = r) -> str:
                    v = r.get("age" + tag, math.nan)
                    return ("  undetermined  " if not math.isfinite(v) else
                            f"{v * 1e3:7.1f} +- {r['age_sigma' + tag] * 1e3:4.1f}")

                def lever(tag: str, r: dict[str, float] = r) -> str:
                    return (f"({r.get('skew_x' + tag, math.nan):+.2f}, "
                            f"{r.get('skew_y' + tag, math.nan):+.2f}) +- "
                            f"{r.get('skew_sigma' + tag, math.nan):.2f}")

                print(f"  seed {seed}: age {r['age_true'] * 1e3:6.1f}, "
                      f"{r['age_effective'] * 1e3:6.1f} | {age('')} | "
                      f"{age('_fixed')};  lever ({r['skew_x_true']:+.2f}, "
                      f"{r['skew_y_true']:+.2f}) | {lever('')} | {lever('_fixed')}",
                      flush=True)
            print("  mounting of the default calibration (error, its 1-sigma):")
            for name, unit, shown in (("nav_x", 1e3, "mm"), ("nav_y", 1e3, "mm"),
                                      ("nav_yaw", math.degrees(1.0), "deg")):
                err = np.array([r[name + "_error"] for r in rows]) * unit
                sig = np.array([r[name + "_sigma"] for r in rows]) * unit
                if not np.isfinite(sig).any():
                    print(f"    {name}: not observable on any seed (held)")
                    continue
                z = np.abs(err) / sig
                print(f"    {name}, {shown}: error mean {err.mean():+.3g}, RMS "
                      f"{math.sqrt(float(np.mean(err * err))):.3g}, 1-sigma median "
                      f"{np.nanmedian(sig):.3g}, within 1 sigma {np.mean(z <= 1):.0%}, "
                      f"within 2 sigma {np.mean(z <= 2):.0%}")
            for tag, label in (("", "default"), ("_fixed", "mounting held")):
                print(f"  {label}:")
                print("    " + summary(rows, "age", tag, 1e3, "age, ms"))
                print("    " + summary(rows, "age", tag, 1e3, "age against the effective, ms",
                                        "_effective"))
                print("    " + summary(rows, "skew_x", tag, 1.0, "lever s_x, m"))
                print("    " + summary(rows, "skew_y", tag, 1.0, "lever s_y, m"))


if __name__ == "__main__":
    main()
