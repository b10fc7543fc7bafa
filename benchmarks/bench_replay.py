"""Replay speed: ``lgvtool replay --estimator pf-paper`` on a one-hour paper-circle log, and the
cost of a particle-filter update per particle.

Run by hand (never a timed test)::

    python benchmarks/bench_replay.py [--log ONE_HOUR.mcap] [--keep DIR] [--repeat 3]

It simulates the log with ``lgvtool simulate`` unless one is given, times the replay command
as a subprocess from start to exit (the output file is closed when the process ends; median
and best of ``--repeat`` runs), prints the split between reading, filtering and writing that
the command reports with ``--json`` for the median run, then times the filter loop as the
replay runs it (:meth:`Estimator.run`: predict, update and estimate per observation) for the
paper's filter and the improved one (fixed count) in-process at 150, 1 000, 10 000 and
100 000 particles over ``--updates`` updates of the log (best of 3), and the time of one
pf-paper update at 150 particles.

The filters run their compiled kernels when numba is installed (the ``fast`` extra);
``LGVTOOL_KERNELS=numpy`` times the numpy path instead. ``--filters-only`` skips the replay.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
# the in-process filter timings import this checkout's lgvtool
sys.path.insert(1, str(Path(__file__).resolve().parents[1]))

from bench_memory import _tree_env, simulate

REPO = Path(__file__).resolve().parents[1]

PARTICLES = (150, 1_000, 10_000, 100_000)
TARGET_S = 0.72
#: targets: pf-paper update at 150 particles (us); ns per particle per update at 100 000
TARGET_UPDATE_US = 20.0
TARGET_NS = {"pf-paper": 40.0, "pf": 60.0}


def lgvtool(*args: str) -> subprocess.CompletedProcess[str]:
    """``lgvtool ARGS`` of this checkout, run as a subprocess."""
    return subprocess.run([sys.executable, "-m", "lgvtool", *args], capture_output=True,
                          text=True, check=False, env=_tree_env(REPO), cwd=REPO)


def time_replay(log: Path, out: Path, repeat: int) -> list[tuple[float, dict]]:
    """``(wall s, --json summary)`` of each run, sorted by wall time."""
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = lgvtool("replay", str(log), "-o", str(out), "--estimator", "pf-paper",
                      "--particles", "150", "--seed", "0", "--json", "--force")
        wall = time.perf_counter() - t0
        if res.returncode != 0:
            raise SystemExit(f"replay failed: {res.stderr.strip()}")
        runs.append((wall, json.loads(res.stdout)))
    return sorted(runs, key=lambda r: r[0])


def per_particle(log: Path, updates: int, repeat: int = 3) -> list[tuple[str, int, int, float]]:
    """``(estimator, particles, updates, ns per particle per update)``: the filter loop alone
    (:meth:`Estimator.run`, as the replay runs it, without particle clouds), over the first
    ``updates`` observations after the first NAV pose (the filter starts there, so that every
    update is a tracking one); the best of ``repeat`` runs."""
    import numpy as np

    from lgvtool.localize.motion import MotionTrack
    from lgvtool.localize.registry import ESTIMATORS, resolve_params
    from lgvtool.localize.replay_driver import _observations, estimator_rng, load_log
    from lgvtool.log import LogReader

    reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors)
    rows = []
    for name, extra in (("pf-paper", {"init": "laser"}),
                        ("pf", {"kld": False, "init": "laser"})):
        cls = ESTIMATORS[name]
        for n in PARTICLES:
            params = resolve_params(name, {}, {"particles": n, **extra})
            ms = params.motion_settings()
            track = MotionTrack(data.increments(ms, cfg.vehicle), ms.step_form)
            obs, starts = _observations(data, cls, params, track, cfg.vehicle)
            first = starts[0] if starts else obs[0]
            obs = [o for o in obs if o.t > first.t][:updates]
            times = np.array([first.t] + [o.t for o in obs])
            steps = track.deltas(times[:-1], times[1:])
            best = float("inf")
            for _ in range(repeat):
                est = cls(params, vehicle=cfg.vehicle, reflectors=data.reflectors,
                          area=cfg.area, rng=estimator_rng(0, name))
                est.update(first)
                t0 = time.perf_counter()
                est.run(times, [None, *obs], steps, cloud_size=0)
                best = min(best, time.perf_counter() - t0)
            rows.append((name, n, len(obs), best / len(obs) / n * 1e9))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path, help="one-hour paper-circle log (default: simulate)")
    ap.add_argument("--keep", type=Path, help="folder for the logs (default: a temp folder)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="replay runs; the median and the best are reported")
    ap.add_argument("--updates", type=int, default=100,
                    help="updates timed per particle count")
    ap.add_argument("--filters-only", action="store_true",
                    help="only the filter rows (no replay)")
    args = ap.parse_args()
    # as the replay command: single-threaded BLAS (set before numpy is imported here)
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory() as tmp:
        # resolved: the commands run in this checkout's folder
        folder = (args.keep or Path(tmp)).resolve()
        folder.mkdir(parents=True, exist_ok=True)
        log = (args.log or folder / "paper-circle-1h.mcap").resolve()
        if not log.exists():
            print(f"simulating {log} ...", flush=True)
            simulate(log, 1.0, REPO)
        print(f"kernels: {kernels()}; load average {os.getloadavg()[0]:.2f}")
        if not args.filters_only:
            replay_rows(log, folder, args.repeat)
        print(f"cost per particle per update ({args.updates} updates, filter only, best of 3):")
        for name, n, updates, ns in per_particle(log, args.updates):
            target = f"  (target {TARGET_NS[name]:.0f} ns)" if n == 100_000 else ""
            print(f"  {name:8s} {n:7d} particles  {updates:5d} updates  {ns:8.1f} ns{target}")
            if name == "pf-paper" and n == 150:
                print(f"  pf-paper update at 150 particles: {ns * n * 1e-3:.1f} us "
                      f"(target {TARGET_UPDATE_US:.0f} us)")
        print(f"load average after: {os.getloadavg()[0]:.2f}")


def kernels() -> str:
    """Which inner loops the filters run: numba (with its version) or numpy."""
    try:
        from lgvtool.localize.kernel_choice import uses_kernels
    except ImportError:  # a tree without kernels
        return "numpy"
    if not uses_kernels():
        return "numpy"
    import numba

    return f"numba {numba.__version__}"


def replay_rows(log: Path, folder: Path, repeat: int) -> None:
    """The replay rows: end to end wall time and the command's own split."""
    runs = time_replay(log, folder / "replayed.mcap", repeat)
    wall, summary = runs[len(runs) // 2]
    print(f"replay --estimator pf-paper, one hour, 150 particles: median {wall:.3f} s, best "
          f"{runs[0][0]:.3f} s wall of {len(runs)} runs (target {TARGET_S} s: "
          f"{'met' if wall <= TARGET_S else 'NOT met'})")
    print("  walls: " + ", ".join(f"{r[0]:.3f}" for r in runs))
    sec = summary["seconds"]
    print(f"  inside the command (median run): read {sec['read']:.3f} s, filter "
          f"{sec['filter']:.3f} s, write {sec['write']:.3f} s, total {sec['total']:.3f} s; "
          f"start-up and exit {wall - sec['total']:.3f} s")
    print(f"  updates: {summary['estimators']['pf-paper']['estimates']}, "
          f"messages written: {summary['messages_written']}")


if __name__ == "__main__":
    main()
