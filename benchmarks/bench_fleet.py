"""Benchmark of the fleet engine (run by hand; never part of the test suite).

1. Engine overhead: N tasks that do nothing through :func:`lgvtool.fleet.engine.run_tasks` on a
   local cluster of 2 workers, in ms per task (cluster start-up reported apart), with the
   adaptive chunking and with one Dask task per task.
2. Speed-up: a real sweep (simulated paper-circle logs x 2 settings of pf.particles x seeds,
   lgvtool's default estimators) with 1 and then 2 local workers, each into a fresh output
   directory; wall time of the whole sweep (cluster start-up included) and the ratio.

Usage::

    python benchmarks/bench_fleet.py                 # 10 logs x 2 settings x 10 seeds = 200
    python benchmarks/bench_fleet.py --logs 2 --seeds 3 --noop 500     # a quick look
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path


def noop(task: int) -> int:
    """A task that does nothing."""
    return task


def burn(n: int) -> float:
    """Pure-Python CPU work; returns its wall time, s."""
    t0 = time.perf_counter()
    s = 0
    for i in range(n):
        s += i * i
    return time.perf_counter() - t0


def cpu_probe(n: int = 20_000_000) -> float:
    """Throughput of 2 processes burning CPU at once relative to 1: the ceiling of any 1 -> 2
    worker speed-up on this machine at this moment (2.0 on two idle cores)."""
    import multiprocessing as mp

    one = burn(n)
    with mp.get_context("spawn").Pool(2) as pool:
        t0 = time.perf_counter()
        pool.map(burn, [n, n])
        two = time.perf_counter() - t0
    return 2 * one / two


def bench_overhead(counts: list[int], workers: int) -> None:
    from lgvtool.fleet.engine import open_client, run_tasks

    t0 = time.perf_counter()
    with open_client(workers=workers) as client:
        start = time.perf_counter() - t0
        list(run_tasks(noop, range(50), client=client, progress=False))  # warm the workers
        print(f"engine overhead, no-op tasks, {workers} local workers "
              f"(cluster start-up {start:.2f} s, not counted):")
        for n in counts:
            for label, target in (("adaptive chunks", 0.2), ("one Dask task per task", 0.0)):
                t1 = time.perf_counter()
                outs = list(run_tasks(noop, range(n), client=client, progress=False,
                                      chunk_target_s=target))
                dt = time.perf_counter() - t1
                assert len(outs) == n and all(o.ok for o in outs)
                print(f"  {n:5d} tasks, {label:24s} {dt:7.2f} s  {dt / n * 1e3:7.3f} ms/task")


def make_logs(folder: Path, count: int, duration_s: float) -> list[Path]:
    from lgvtool.sim import simulate, write_log

    paths = []
    for seed in range(1, count + 1):
        p = folder / f"circle-{seed:02d}.mcap"
        write_log(simulate("paper-circle", seed=seed, duration=duration_s), p)
        paths.append(p)
    return paths


def bench_speedup(logs: list[Path], seeds: int, grid: dict[str, list[int]], work: Path,
                  estimators: list[str], repeat: int) -> None:
    """Sweeps with 1 and 2 workers, alternated ``repeat`` times; the best wall time of each
    counts (the run least disturbed by anything else on the machine)."""
    from lgvtool.fleet.sweep_run import run_sweep

    best: dict[int, float] = {}
    tasks = 0
    for round_ in range(repeat):
        for workers in (1, 2):
            out = work / f"sweep-{workers}-{round_}"
            load = os.getloadavg()[0]
            ceiling = cpu_probe()
            t0 = time.perf_counter()
            res = run_sweep(logs, out, grid=grid, seeds=seeds, estimators=estimators,
                            workers=workers, progress=False)
            wall = time.perf_counter() - t0
            assert res.ran == res.tasks and res.failed == 0, res.failures
            tasks = res.tasks
            per_task = res.tidy.drop_duplicates("key")
            busy = per_task["elapsed_s"].sum() / (workers * wall)
            cpu_share = per_task["cpu_s"].sum() / per_task["elapsed_s"].sum()
            best[workers] = min(best.get(workers, math.inf), wall)
            print(f"  {workers} worker(s): {wall:7.1f} s for {res.tasks} tasks; mean task "
                  f"{per_task['elapsed_s'].mean():.3f} s wall, {per_task['cpu_s'].mean():.3f} s CPU "
                  f"({cpu_share:.0%}); workers busy {busy:.0%}; load average before {load:.2f}, "
                  f"CPU probe 2 vs 1 process {ceiling:.2f}x",
                  flush=True)
    print(f"speed-up 1 -> 2 workers over {tasks} tasks: {best[1] / best[2]:.2f}x "
          f"(best wall times {best[1]:.1f} s and {best[2]:.1f} s, cluster start-up included)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--logs", type=int, default=10, help="simulated logs (default 10)")
    ap.add_argument("--seeds", type=int, default=10, help="seeds per log and setting (10)")
    ap.add_argument("--duration", type=float, default=30.0, help="length of each log, s (30)")
    ap.add_argument("--noop", type=int, default=2000, help="no-op tasks for the overhead (2000)")
    ap.add_argument("--estimators", default="",
                    help="comma-separated estimators (default: lgvtool's default set)")
    ap.add_argument("--repeat", type=int, default=2,
                    help="sweeps per worker count, alternated; the best counts (2)")
    ap.add_argument("--skip-speedup", action="store_true", help="only the overhead")
    args = ap.parse_args()

    print(f"machine: {os.cpu_count()} CPU(s), Python {sys.version.split()[0]}, "
          f"load average {os.getloadavg()[0]:.2f}")
    bench_overhead(sorted({200, args.noop}), workers=2)
    if args.skip_speedup:
        return
    grid = {"pf.particles": [100, 300]}
    with tempfile.TemporaryDirectory(prefix="lgvtool-bench-fleet-") as tmp:
        work = Path(tmp)
        logs_dir = work / "logs"
        logs_dir.mkdir()
        t0 = time.perf_counter()
        logs = make_logs(logs_dir, args.logs, args.duration)
        estimators = [e for e in args.estimators.split(",") if e]
        print(f"sweep: {args.logs} simulated logs of {args.duration:g} s ({time.perf_counter() - t0:.1f}"
              f" s to make) x {len(grid['pf.particles'])} settings x {args.seeds} seeds, "
              f"estimators {', '.join(estimators) or 'default set'}:")
        bench_speedup(logs, args.seeds, grid, work, estimators, max(1, args.repeat))
    print(f"load average at the end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
