"""How the simulated vehicle docks at the ``warehouse`` stations: the figures of
docs/simulator.md ("Stations and docking").

Per seed the script resolves ``warehouse`` (``--laps`` laps, ``--set`` settings) and runs its
drive (``lgvtool.sim.simulation.true_drive``: the plan, the docking controller's manoeuvre, the
true drive with every ``drive.*`` mechanism; the sensors are not needed), then per visit takes
the true pose of O in the middle of the standstill against the station's nominal pose, in the
station's frame: along (m), across (m), heading (rad). It prints, per station and over all:

- the visits, and the truth's standard deviation of the three about the station's mean, next to
  the settings (``drive.dock_sigma_*``): the repeatability an audit should find;
- the residual, truth minus nominal minus the visit's drawn docking error: what the path
  controller and the other drive mechanisms add (mean, standard deviation, largest).

Usage::

    python benchmarks/sim_docking.py [--seeds 9000-9009] [--laps 2] [--set section.key=value ...]
                                     [--json]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from pf_paper_convergence import seeds_of

from lgvtool.sim.simulation import STREAMS, resolve, true_drive, true_vehicle
from lgvtool.sim.station_poses import setup_stations


def three(v: list[float]) -> str:
    """Along and across (mm, 2 decimals) and heading (deg, 3 decimals)."""
    return f"{v[0]:.2f}, {v[1]:.2f}, {v[2]:.3f}"


SCALE = np.array([1e3, 1e3, 180.0 / math.pi])
"""m, m, rad -> mm, mm, deg."""


def visits_of(seed: int, laps: int, sets: dict[str, Any]) -> list[tuple[str, np.ndarray]]:
    """Per visit of one run: the station and (offset of the truth, drawn error), each along,
    across (m) and heading (rad), as a (2, 3) array."""
    setup = resolve("warehouse", overrides={**sets, "scenario.laps": laps})
    vehicle = true_vehicle(setup.config.vehicle, setup.settings.install)
    rng = np.random.default_rng(seed).spawn(len(STREAMS))[STREAMS.index("drive")]
    _, truth, visits = true_drive(setup, vehicle, rng)
    stations = {s.name: s for s in setup_stations(setup)}
    out = []
    for v in visits:
        st = stations[v.station]
        x, y, h = truth.pose_at(np.array([0.5 * (v.arrive_s + v.leave_s)]))
        dx, dy = float(x[0]) - st.x, float(y[0]) - st.y
        c, s = math.cos(st.heading), math.sin(st.heading)
        off = [c * dx + s * dy, -s * dx + c * dy, math.remainder(float(h[0]) - st.heading,
                                                                 2 * math.pi)]
        out.append((v.station, np.array([off, [v.error.along, v.error.across,
                                                v.error.heading]])))
    return out


def summary(rows: list[tuple[str, int, np.ndarray]]) -> dict[str, Any]:
    """Over (station, seed, offsets) rows: visits, the truth's spread about each station's
    mean (pooled over the stations: sum of squares over visits less stations; the truth does
    not depend on the seed's site), the residual's mean, spread and largest; mm, mm, deg."""
    groups: dict[str, list[np.ndarray]] = {}
    for name, _, pair in rows:
        groups.setdefault(name, []).append(pair)
    squares = np.zeros(3)
    for pairs in groups.values():
        truth = np.array([p[0] for p in pairs])
        squares += ((truth - truth.mean(axis=0)) ** 2).sum(axis=0)
    dof = max(len(rows) - len(groups), 1)
    residual = np.array([p[0] - p[1] for _, _, p in rows])
    return {"visits": len(rows),
            "truth_sigma": (np.sqrt(squares / dof) * SCALE).tolist(),
            "residual_mean": (residual.mean(axis=0) * SCALE).tolist(),
            "residual_sigma": (residual.std(axis=0, ddof=1) * SCALE).tolist(),
            "residual_max": (np.abs(residual).max(axis=0) * SCALE).tolist()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="9000-9009")
    ap.add_argument("--laps", type=int, default=2)
    ap.add_argument("--set", dest="sets", action="append", default=[],
                    help="a simulator setting, section.key=value (JSON values)")
    ap.add_argument("--json", action="store_true")
    opts = ap.parse_args()
    sets: dict[str, Any] = {}
    for item in opts.sets:
        key, _, value = item.partition("=")
        try:
            sets[key] = json.loads(value)
        except json.JSONDecodeError:
            sets[key] = value
    started = time.perf_counter()
    rows = [(name, seed, pair) for seed in seeds_of(opts.seeds)
            for name, pair in visits_of(seed, opts.laps, sets)]
    drive = resolve("warehouse", overrides=sets).settings.drive
    doc: dict[str, Any] = {"settings": [drive.dock_sigma_along_m * 1e3, drive.dock_sigma_across_m * 1e3,
                        drive.dock_sigma_heading_deg],
           "stations": {name: summary([r for r in rows if r[0] == name])
                        for name in dict.fromkeys(r[0] for r in rows)},
           "all": summary(rows), "seconds": time.perf_counter() - started}
    if opts.json:
        print(json.dumps(doc, indent=2))
        return 0
    s = doc["settings"]
    print(f"warehouse, seeds {opts.seeds}, {opts.laps} laps; settings: {s[0]:.1f} mm along, "
          f"{s[1]:.1f} mm across, {s[2]:.2f} deg ({doc['seconds']:.0f} s)\n")
    print("| station | visits | truth σ along mm | across mm | heading deg | residual mean "
          "(along, across mm, heading deg) | residual σ | residual max |")
    print("|---|---:|---:|---:|---:|---|---|---|")
    for name, f in [*doc["stations"].items(), ("all", doc["all"])]:
        t = f["truth_sigma"]
        print(f"| {name} | {f['visits']} | {t[0]:.2f} | {t[1]:.2f} | {t[2]:.3f} | "
              f"{three(f['residual_mean'])} | {three(f['residual_sigma'])} | "
              f"{three(f['residual_max'])} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
