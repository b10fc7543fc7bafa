"""Peak memory and wall time of ``lgvtool evaluate`` and ``lgvtool replay`` on 1, 2 and
4-hour simulated paper-circle logs.

Run by hand (never a timed test)::

    python benchmarks/bench_memory.py [--hours 1,2,4] [--cache DIR] [--estimator NAME]
                                      [--view | --no-view]

The logs are simulated once with ``lgvtool simulate --scenario paper-circle --seed 1`` and
kept in ``--cache`` (default: a folder in the system's temporary directory), so a second run
measures only the commands. Each command runs as a subprocess; its peak resident set (the
largest RSS of the child, ``getrusage(RUSAGE_CHILDREN).ru_maxrss`` read in a fresh
intermediate process so that earlier runs do not mask it) and its wall time are printed,
with the ratio of the 4-hour peak to the 1-hour peak (target: at most 2). ``replay`` writes
the Foxglove view channels (its default, ``--view``) unless ``--no-view`` is given.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

#: runs a command in a child and prints its peak RSS (KiB), wall and CPU time (s) and the end
#: of its stdout as JSON
_MEASURE = r"""
import json, resource, subprocess, sys, time
t0 = time.perf_counter()
res = subprocess.run(sys.argv[1:], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
wall = time.perf_counter() - t0
use = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps({"rc": res.returncode, "wall_s": wall, "peak_kib": use.ru_maxrss,
                  "cpu_s": use.ru_utime + use.ru_stime,
                  "stdout": res.stdout[-20000:], "stderr": res.stderr[-400:]}))
"""


def _tree_env(tree: Path | None) -> dict[str, str] | None:
    """The environment that runs the lgvtool of the checkout ``tree`` (None: this one's)."""
    return None if tree is None else dict(os.environ, PYTHONPATH=str(tree))


def _paper_setup(tree: Path | None) -> list[str]:
    """``--set sim.paper_scans=true`` when the checkout ``tree`` (default: this one) has that
    setting (earlier versions logged the scans by default)."""
    root = tree if tree is not None else Path(__file__).resolve().parents[1]
    settings = root / "lgvtool" / "sim" / "settings.py"
    known = settings.exists() and "paper_scans" in settings.read_text(encoding="utf-8")
    return ["--set", "sim.paper_scans=true"] if known else []


def simulate(path: Path, hours: float, tree: Path | None = None) -> None:
    """Simulate a paper-circle log of ``hours`` into ``path`` unless it exists (with the
    lgvtool of the checkout ``tree`` when given, as :func:`measure` runs it), in the paper's
    setup (the NAV200's reflector scans logged, so that the filters weigh reflectors) when the
    checkout's simulator knows it."""
    if path.exists():
        return
    tmp = path.with_suffix(".part.mcap")
    tmp.unlink(missing_ok=True)
    res = subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario",
                          "paper-circle", "--seed", "1", "--duration", str(hours * 3600),
                          "-o", str(tmp)], capture_output=True, text=True,
                         check=False, env=_tree_env(tree), cwd=tree)
    if res.returncode != 0:
        raise SystemExit(f"simulate failed: {res.stderr.strip()}")
    tmp.rename(path)


CACHE = Path(tempfile.gettempdir()) / "lgvtool-bench-memory"
"""Where the simulated logs are kept between runs (by default)."""


def hour_log(log: Path | None = None) -> Path:
    """``log``, else the one-hour paper-circle log of :data:`CACHE` (simulated if missing)."""
    if log is not None:
        return log
    CACHE.mkdir(parents=True, exist_ok=True)
    path = CACHE / "paper-circle-1h.mcap"
    simulate(path, 1.0)
    return path


def hour_log_options(doc: str) -> tuple[Path, int]:
    """The command line ``[LOG] [--repeat N]`` of a benchmark of one log (described by the
    first paragraph of ``doc``): the log (:func:`hour_log`) and the repeat count (default 5)."""
    ap = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    ap.add_argument("log", nargs="?", type=Path,
                    help="a log (default: the one-hour paper-circle log, simulated once)")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each measurement (best kept)")
    opts = ap.parse_args()
    return hour_log(opts.log), opts.repeat


def best(fn: Callable[[], object], repeat: int) -> float:
    """The least wall time of ``repeat`` calls of ``fn``, s."""
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def measure(args: list[str], tree: Path | None = None) -> dict[str, Any]:
    """Peak RSS (MB), wall and CPU time (s) and the end of the stdout of ``lgvtool ARGS`` run
    as a subprocess (the lgvtool of the checkout ``tree`` when given: it is put on PYTHONPATH
    and the command runs in that folder, since ``python -m`` looks there first)."""
    res = subprocess.run([sys.executable, "-c", _MEASURE, sys.executable, "-m", "lgvtool",
                          *args], capture_output=True, text=True, check=True,
                         env=_tree_env(tree), cwd=tree)
    out = json.loads(res.stdout)
    if out["rc"] != 0:
        raise SystemExit(f"lgvtool {' '.join(args)} failed: {out['stderr'].strip()}")
    return {"peak_mb": out["peak_kib"] / 1024.0, "wall_s": out["wall_s"],
            "cpu_s": out["cpu_s"], "stdout": out["stdout"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", default="1,2,4", help="log durations, h (comma-separated)")
    ap.add_argument("--cache", type=Path, default=CACHE,
                    help="folder of the simulated logs (kept between runs)")
    ap.add_argument("--estimator", action="append", default=[],
                    help="estimator(s) to run (default: the commands' defaults, all five)")
    ap.add_argument("--commands", default="evaluate,replay", help="which commands to measure")
    ap.add_argument("--view", action=argparse.BooleanOptionalAction, default=True,
                    help="replay with its Foxglove view channels (default) or --no-view")
    opts = ap.parse_args()
    hours = [float(h) for h in opts.hours.split(",")]
    opts.cache.mkdir(parents=True, exist_ok=True)
    est: list[str] = [a for e in opts.estimator for a in ("--estimator", e)]
    rows: dict[str, dict[float, dict[str, float]]] = {}
    for h in hours:
        log = opts.cache / f"paper-circle-{h:g}h.mcap"
        simulate(log, h)
        out = opts.cache / "out"
        if "evaluate" in opts.commands:
            rows.setdefault("evaluate", {})[h] = measure(
                ["evaluate", str(log), "--json", "--seed", "0", *est])
        if "replay" in opts.commands:
            out.with_suffix(".mcap").unlink(missing_ok=True)
            rows.setdefault("replay", {})[h] = measure(
                ["replay", str(log), "-o", str(out.with_suffix(".mcap")), "--seed", "0",
                 "--view" if opts.view else "--no-view", *est])
        for cmd, per in rows.items():
            r = per[h]
            print(f"{cmd:9s} {h:4g} h: peak RSS {r['peak_mb']:7.1f} MB, "
                  f"wall {r['wall_s']:7.1f} s", flush=True)
    lo, hi = min(hours), max(hours)
    for cmd, per in rows.items():
        ratio = per[hi]["peak_mb"] / per[lo]["peak_mb"]
        print(f"{cmd}: peak RSS at {hi:g} h / at {lo:g} h = {ratio:.2f} (target <= 2)")


if __name__ == "__main__":
    main()
