"""Does ``lgvtool audit``'s stations section give each station's repeatability as the truth has
it, and what does the section cost? Simulated ``warehouse`` drives, whose vehicle stops at its
stations every lap (the simulator's docking controller: a per-visit error of its own), audited
together.

Run by hand (never a timed test)::

    python benchmarks/audit_stations.py [--seeds 9000-9009] [--laps 6] [--device nav200]
                                        [--estimator NAME] [--workdir DIR] [--rounds 3]
                                        [--json]

Per seed: ``lgvtool simulate --scenario warehouse --seed S --set scenario.laps=LAPS`` (kept in
``--workdir``), then one ``lgvtool audit LOG... -o DIR --json`` of all of them (pooled; the
stations found automatically) and one with ``--stations`` (the simulator's nominal stations,
which each log's ``simulator`` metadata lists, with a tolerance of 5 cm and 2 deg).

**Repeatability.** Per station, over the visits that have all three sources (the same visits
for each): the standard deviation of x and y (m) and of the heading (deg) of the truth, of the
raw laser and of the audit's estimator (the best the log allows: ``ekf`` on a NAV200's poses,
``pf`` on a NAV350's scans), and each one's ratio to the truth's. Target: the laser's and the
estimator's within 10 % of the truth's (0.9-1.1) with at least 50 visits per station.

Each seed draws its own site (``site.*``: the layout's survey error, each reflector's range
offset, the floor's tilt), so the laser, and every estimator fitted to the stored layout,
stands off the truth at a station by an offset of that seed's own, the same on every visit.
One site's repeatability is the scatter about that site's own mean: the figures judged are
the **within-log** standard deviations, each visit's deviation from its log's mean, pooled over
the logs (sum of squares over visits minus logs); the 95 % radius the same way. The audit's
own figures, which pool the ten sites as one, are printed beside them ("pooled").

**Cost.** The section adds no reading of the log: it works on the odometry, the NAV poses and
the replayed poses the audit already has. Its own time is measured in this process on the first
log: the log's visits (:func:`lgvtool.audit.stations.log_visits`, on inputs built as the
audit builds them), the stations and their section over all the logs' visits, and the report's
stations page; best of ``--rounds``. Against the I/O floor, ``lgvtool replay LOG -e laser
--no-view -o OUT`` of the same log (median of ``--rounds``). Target: at most 1 x the floor.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_memory import measure

ROLES = ("truth", "laser", "estimator")


def _seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = text.split("-")
        return list(range(int(a), int(b) + 1))
    return [int(s) for s in text.split(",")]


def simulate(path: Path, seed: int, laps: int, device: str) -> Path:
    """A warehouse log of ``laps`` laps at ``path`` (simulated unless it exists)."""
    if path.exists():
        return path
    tmp = path.with_suffix(".part.mcap")
    tmp.unlink(missing_ok=True)
    res = subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario",
                          "warehouse", "--seed", str(seed), "--set", f"scenario.laps={laps}",
                          "--set", f"sim.nav_device={device}", "-o", str(tmp)],
                         capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"simulate failed: {res.stderr.strip()}")
    tmp.rename(path)
    return path


def audit(logs: list[Path], out: Path, *more: str) -> dict[str, Any]:
    """``lgvtool audit LOGS -o OUT --json --force``: the document."""
    res = subprocess.run([sys.executable, "-m", "lgvtool", "audit", *map(str, logs), "-o",
                          str(out), "--json", "--force", "--no-progress", *more],
                         capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"audit failed: {res.stderr.strip()}")
    doc: dict[str, Any] = json.loads(res.stdout)
    return doc


def nominal_stations(log: Path) -> list[dict[str, Any]]:
    """The simulator's stations as its metadata lists them (name, x, y m, heading_deg); empty
    when the log has none."""
    from lgvtool.log import LogReader

    sim = LogReader(log).metadata.get("simulator", {})
    listed = sim.get("stations") if isinstance(sim, dict) else None
    return list(listed) if isinstance(listed, list) else []


def within_logs(p: np.ndarray, logs: list[str]) -> tuple[float, float, float, float]:
    """Sigma x, y (m), sigma heading (rad) and 95 % radius (m) of the poses ``p`` (rows x, y,
    heading) about their own log's mean (circular for the heading), pooled over the logs:
    sum of squares over (visits - logs); NaN without two visits of one log."""
    from lgvtool.angles import circular_mean, wrap_angle

    dev = np.zeros_like(p)
    names = sorted(set(logs))
    of = np.array([names.index(n) for n in logs])
    for k in range(len(names)):
        m = of == k
        dev[m, 0] = p[m, 0] - p[m, 0].mean()
        dev[m, 1] = p[m, 1] - p[m, 1].mean()
        dev[m, 2] = wrap_angle(p[m, 2] - circular_mean(p[m, 2]))
    dof = len(p) - len(names)
    if dof < 1:
        return math.nan, math.nan, math.nan, math.nan
    sx, sy, sh = (math.sqrt(float(np.sum(dev[:, i] ** 2)) / dof) for i in range(3))
    return sx, sy, sh, float(np.percentile(np.hypot(dev[:, 0], dev[:, 1]), 95.0))


def repeatability(section: dict[str, Any]) -> list[dict[str, Any]]:
    """Per station, over the visits with every source: visits, and per source the within-log
    sigma x, y (m), sigma heading (deg) and 95 % radius (m), and the same pooled over all
    visits as the audit gives them (``pooled``)."""
    from lgvtool.audit.stations import spread, stop_spread

    rows = []
    for st in section["per_station"]:
        visits = [v for v in st["visit_list"] if all(r in v["poses"] for r in ROLES)]
        logs = [str(v["log"]) for v in visits]
        row: dict[str, Any] = {"station": st["name"], "visits": len(visits),
                               "logs": len(set(logs)), "x": st["x"], "y": st["y"]}
        for role in ROLES:
            p = np.array([v["poses"][role] for v in visits], dtype=np.float64).reshape(-1, 3)
            _, _, _, px, py, ph, pr = spread(p[:, 0], p[:, 1], p[:, 2])
            sx, sy, sh, r95 = within_logs(p, logs)
            se = np.array([[math.nan if e is None else e
                            for e in v.get("standard_errors", {}).get(role, [None] * 3)]
                           for v in visits], dtype=np.float64).reshape(-1, 3)
            alone = [stop_spread(sigma, se[:, i])[0] for i, sigma in enumerate((sx, sy, sh))]
            row[role] = {"sigma_x_m": sx, "sigma_y_m": sy,
                         "stops_alone": {"sigma_x_m": alone[0], "sigma_y_m": alone[1],
                                         "sigma_heading_deg": math.degrees(alone[2])},
                         "sigma_heading_deg": math.degrees(sh), "radius95_m": r95,
                         "pooled": {"sigma_x_m": px, "sigma_y_m": py,
                                    "sigma_heading_deg": math.degrees(ph),
                                    "radius95_m": pr}}
        rows.append(row)
    return rows


def section_time(log: Path, logs: list[Path], rounds: int) -> dict[str, float]:
    """The stations section's own time (s, best of ``rounds``) on ``log``: its visits from the
    audit's inputs, the stations and section over the visits of all ``logs`` (the first's
    repeated), and the report's page."""
    import warnings

    from lgvtool.audit.audit_report import _stations_html
    from lgvtool.audit.log_audit import _increments, _laser_at_o, best_estimator
    from lgvtool.audit.stations import (
        StationSettings,
        find_stations,
        log_visits,
        stations_section,
    )
    from lgvtool.localize.logdata import load_log
    from lgvtool.localize.replay_driver import replay_data
    from lgvtool.log import LogReader
    from lgvtool.trajectory import Trajectory

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors, decode_scans=True, truth=True)
    name, _ = best_estimator(data)
    est = replay_data(data, [name], config=cfg, seed=0, threads=1).estimates[name]
    estimate = Trajectory(np.asarray(est.t, dtype=np.float64), est.x, est.y, est.heading,
                          data.t0_ns)
    inc = _increments(data, cfg)
    assert inc is not None
    sources = {"truth": data.truth, "laser": _laser_at_o(data, cfg), "estimator": estimate}
    s = StationSettings()
    best_visits = best_pool = best_page = math.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        visits = log_visits(str(log), inc, sources, name, s)
        t1 = time.perf_counter()
        pooled = [v for _ in logs for v in visits]
        section = stations_section(find_stations(pooled, None, s), s)
        t2 = time.perf_counter()
        _stations_html(section, lambda slug, fig: fig.to_html(full_html=False,
                                                               include_plotlyjs=False))
        t3 = time.perf_counter()
        best_visits = min(best_visits, t1 - t0)
        best_pool = min(best_pool, t2 - t1)
        best_page = min(best_page, t3 - t2)
    return {"visits_s": best_visits, "stations_s": best_pool, "page_s": best_page,
            "total_s": best_visits + best_pool + best_page}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="9000-9009", help="seeds, a-b or comma-separated")
    ap.add_argument("--laps", type=int, default=6, help="laps per seed (scenario.laps)")
    ap.add_argument("--device", default="nav200", choices=("nav200", "nav350"),
                    help="the simulated NAV (sim.nav_device)")
    ap.add_argument("--estimator", default=None,
                    help="the audit's estimator (-e); default: the best each log allows")
    ap.add_argument("--workdir", type=Path,
                    default=Path(tempfile.gettempdir()) / "lgvtool-bench-stations")
    ap.add_argument("--rounds", type=int, default=3, help="rounds of the timings")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON too")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE",
                    help="a setting passed to both audits (stations.settle_s=1, pf.particles=500)")
    opts = ap.parse_args()
    seeds = _seeds(opts.seeds)
    opts.workdir.mkdir(parents=True, exist_ok=True)
    logs = [simulate(opts.workdir / f"warehouse-{opts.device}-{opts.laps}laps-s{s}.mcap", s,
                     opts.laps, opts.device) for s in seeds]
    est = ["-e", opts.estimator] if opts.estimator else []
    est += [arg for kv in opts.sets for arg in ("--set", kv)]
    started = time.perf_counter()
    doc = audit(logs, opts.workdir / "audit-auto", *est)
    audit_s = time.perf_counter() - started
    sec = doc["stations"]
    print(f"warehouse, {opts.device}, seeds {opts.seeds}, {opts.laps} laps each; audit of "
          f"{len(logs)} logs pooled: {audit_s:.1f} s; pose: {sec['sources']['estimator']}; "
          f"{sec['visits']} standstills, {len(sec['unmatched'])} at no station")
    results: dict[str, Any] = {"device": opts.device, "seeds": seeds, "laps": opts.laps,
                               "audit_wall_s": audit_s}
    named = nominal_stations(logs[0])
    docs = {"automatic": sec}
    if named:
        f = opts.workdir / "stations.toml"
        f.write_text("".join(
            f'[[stations]]\nname = "{s["name"]}"\nx = {s["x"]!r}\ny = {s["y"]!r}\n'
            f'heading = {s["heading_deg"]!r}\ntolerance_xy_m = 0.05\ntolerance_deg = 2.0\n\n'
            for s in named), encoding="utf-8")
        docs["named"] = audit(logs, opts.workdir / "audit-named", "--stations", str(f),
                              *est)["stations"]
    else:
        print("the logs list no simulator stations: the named run is left out")
    judged_any = False
    ok_all = alone_all = True
    for mode, section in docs.items():
        rows = repeatability(section)
        results[mode] = rows
        print(f"\n{mode} stations (over the visits with every source; sigma within each "
              "log, pooled; ratio to the truth's; the audit's own sigma over all visits)")
        print("  station      visits  source       sigma x mm  sigma y mm  sigma h deg  "
              "r95 mm   ratio x  ratio y  ratio h   pooled x, y mm  ratio x  ratio y")
        for row in rows:
            tr = row["truth"]
            for role in ROLES:
                r = row[role]
                ratios = [r[k] / tr[k] if tr[k] > 0 else math.nan
                          for k in ("sigma_x_m", "sigma_y_m", "sigma_heading_deg")]
                r["ratio"] = ratios
                po, tp = r["pooled"], tr["pooled"]
                po["ratio"] = [po[k] / tp[k] if tp[k] > 0 else math.nan
                               for k in ("sigma_x_m", "sigma_y_m")]
                al, ta = r["stops_alone"], tr["stops_alone"]
                al["ratio"] = [al[k] / ta[k] if ta[k] > 0 else math.nan
                               for k in ("sigma_x_m", "sigma_y_m", "sigma_heading_deg")]
                name = sec["sources"][role] if role == "estimator" else role
                print(f"  {row['station']:<12} {row['visits']:>6}  {name:<11} "
                      f"{r['sigma_x_m'] * 1000:>10.2f}  {r['sigma_y_m'] * 1000:>10.2f}  "
                      f"{r['sigma_heading_deg']:>11.3f}  {r['radius95_m'] * 1000:>6.2f}   "
                      + "  ".join(f"{v:>7.3f}" for v in ratios)
                      + f"   {po['sigma_x_m'] * 1000:6.2f}, {po['sigma_y_m'] * 1000:6.2f}  "
                      + "  ".join(f"{v:>7.3f}" for v in po["ratio"]))
            for role in ROLES:
                al = row[role]["stops_alone"]
                name = sec["sources"][role] if role == "estimator" else role
                print(f"  {'':<12} {'':>6}  {name:<11} stops alone (own noise over each stop "
                      f"taken off): {al['sigma_x_m'] * 1000:.2f}, {al['sigma_y_m'] * 1000:.2f} "
                      f"mm, {al['sigma_heading_deg']:.3f} deg; ratio "
                      + "  ".join(f"{v:.3f}" for v in al["ratio"]))
            judged = row["visits"] >= 50
            inside = all(0.9 <= v <= 1.1 for role in ("laser", "estimator")
                         for v in row[role]["ratio"][:2])
            alone_in = all(0.9 <= v <= 1.1 for role in ("laser", "estimator")
                           for v in row[role]["stops_alone"]["ratio"][:2])
            row["target_met"] = judged and inside
            row["target_met_stops_alone"] = judged and alone_in
            if judged:
                judged_any = True
                ok_all &= inside
                alone_all &= alone_in
        if mode == "named":
            for st in section["per_station"]:
                res = {s["role"]: s["pass"] for s in st["sources"]}
                print(f"  {st['name']}: pass per source {res} (tolerance "
                      f"{st['tolerance_xy_m']} m, {st['tolerance_deg']} deg)")
    verdict = ("no station has 50 visits: not judged" if not judged_any
               else "met" if ok_all else "NOT met")
    print("\ntarget (stations of >= 50 visits: laser and estimator sigma x, y within each log "
          f"within 10 % of the truth's): {verdict}")
    verdict_alone = ("no station has 50 visits: not judged" if not judged_any
                     else "met" if alone_all else "NOT met")
    print(f"the same for the stops alone (each source's noise over a stop taken off): "
          f"{verdict_alone}")
    results["target"] = verdict
    results["target_stops_alone"] = verdict_alone
    floor_s = statistics.median(
        measure(["replay", str(logs[0]), "-e", "laser", "--no-view", "--no-progress", "-o",
                 str(opts.workdir / "floor.mcap"), "--force"])["wall_s"]
        for _ in range(opts.rounds))
    cost = section_time(logs[0], logs, opts.rounds)
    results.update({"floor_wall_s": floor_s, "section_s": cost})
    print(f"\ncost on {logs[0].name}: visits {cost['visits_s'] * 1000:.1f} ms, stations and "
          f"section over {len(logs)} logs' visits {cost['stations_s'] * 1000:.1f} ms, report "
          f"page {cost['page_s'] * 1000:.1f} ms; total {cost['total_s']:.3f} s against the "
          f"floor (replay -e laser --no-view) {floor_s:.2f} s: "
          f"{cost['total_s'] / floor_s:.3f} x (target <= 1)")
    if opts.json:
        print(json.dumps(results, indent=1, default=float))


if __name__ == "__main__":
    main()
