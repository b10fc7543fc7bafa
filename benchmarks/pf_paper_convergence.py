"""How fast ``pf-paper`` finds the vehicle from its uniform start, over many seeds.

For each seed the script simulates the first ``--duration`` seconds of a scenario (default 30 s
of ``paper-circle``), replays them through ``pf-paper`` with the default settings (or
``--set`` overrides) and measures the position error of O against the ground truth. A run
*converges* at the first time from which the error stays below ``--within`` (10 cm) until the
end of the run; it is counted when that time is at most ``--by`` (20 s). Only the first part of
each run is simulated, so forty seeds take about a minute; ``--duration 0`` runs whole
scenarios, to see that the filter never loses the vehicle again.

Usage::

    python benchmarks/pf_paper_convergence.py [--scenario paper-circle] [--seeds 100-139]
        [--duration 30] [--within 0.1] [--by 20] [--set pf-paper.KEY=VALUE ...] [--json]
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


def seeds_of(text: str) -> list[int]:
    """``"100-139"`` or ``"1,2,5"`` as a list of seeds."""
    out: list[int] = []
    for part in text.split(","):
        a, _, b = part.partition("-")
        out.extend(range(int(a), int(b) + 1) if b else [int(a)])
    return out


def settings_of(items: list[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings as estimator settings (JSON values, else strings)."""
    out: dict[str, Any] = {}
    for item in items:
        key, _, value = item.partition("=")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def converge_time(t: np.ndarray, err: np.ndarray, within: float) -> float | None:
    """First time (s) from which ``err`` stays below ``within`` to the end; None if never."""
    bad = np.nonzero(err >= within)[0]
    if len(bad) == 0:
        return float(t[0])
    if bad[-1] + 1 >= len(t):
        return None
    return float(t[bad[-1] + 1])


def run_seed(scenario: str, seed: int, duration: float, settings: dict[str, Any],
             estimator: str, tmp: Path) -> dict[str, Any]:
    """Simulate, replay and measure one seed."""
    from lgvtool.localize.replay_driver import load_log, replay_data
    from lgvtool.log import LogReader
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    path = tmp / f"{scenario}-{seed}.mcap"
    write_log(simulate(scenario, seed=seed, duration=duration or None), path)
    reader = LogReader(path)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors, truth=True)
    truth = data.truth
    assert truth is not None
    res = replay_data(data, [estimator], config=cfg, seed=seed, settings=settings, cloud_size=0)
    tab = res.estimates[estimator]
    t = (tab.t_ns - data.t0_ns) * 1e-9
    err = np.hypot(tab.x - np.interp(t, truth["t"], truth["x"]),
                   tab.y - np.interp(t, truth["t"], truth["y"]))
    path.unlink()
    return {"t": t, "err": err}


def main(argv: list[str] | None = None) -> int:
    """Command line of the benchmark."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", default="paper-circle")
    ap.add_argument("--seeds", default="100-139")
    ap.add_argument("--duration", type=float, default=30.0,
                    help="simulated seconds of each run; 0: the whole scenario")
    ap.add_argument("--within", type=float, default=0.1, help="error bound, m")
    ap.add_argument("--by", type=float, default=20.0, help="time limit, s")
    ap.add_argument("--estimator", default="pf-paper")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    settings = settings_of(args.set)
    started = time.perf_counter()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds_of(args.seeds):
            r = run_seed(args.scenario, seed, args.duration, settings, args.estimator, Path(tmp))
            conv = converge_time(r["t"], r["err"], args.within)
            ok = conv is not None and conv <= args.by
            after = r["err"][r["t"] >= (args.by if conv is None else conv)]
            worst = float(after.max() * 1000.0) if len(after) else math.nan
            late = r["err"][r["t"] >= args.by]
            worst_late = float(late.max() * 1000.0) if len(late) else math.nan
            rows.append({"seed": seed, "converged_s": conv, "ok": ok,
                         "max_after_mm": worst, "max_after_by_mm": worst_late})
            if not args.json:
                text = "never" if conv is None else f"{conv:5.1f} s"
                print(f"seed {seed}: within {args.within * 100:.0f} cm from {text}, then at "
                      f"most {worst:.0f} mm, after {args.by:g} s at most {worst_late:.0f} mm"
                      f"{'' if ok else '  <- not by ' + str(args.by) + ' s'}", flush=True)
    n_ok = sum(r["ok"] for r in rows)
    times = [r["converged_s"] for r in rows if r["ok"]]
    summary = {"scenario": args.scenario, "estimator": args.estimator, "settings": settings,
               "runs": len(rows), "converged": n_ok,
               "median_s": float(np.median(times)) if times else math.nan,
               "worst_s": float(max(times)) if times else math.nan,
               "max_after_by_mm": float(np.nanmax([r["max_after_by_mm"] for r in rows]))}
    if args.json:
        print(json.dumps({"summary": summary, "runs": rows}, indent=2))
    else:
        print(f"\n{args.scenario}, {args.estimator} {settings or '(defaults)'}: "
              f"{n_ok} of {len(rows)} within {args.within * 100:.0f} cm by {args.by:g} s "
              f"(median {summary['median_s']:.1f} s, worst {summary['worst_s']:.1f} s); "
              f"after {args.by:g} s the error is at most {summary['max_after_by_mm']:.0f} mm")
        print(f"({time.perf_counter() - started:.0f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
