"""Speed and memory of ``lgvtool audit`` on simulated NAV350 warehouse logs: wall time of one
hour against the I/O floor, and peak memory of four hours against one.

Run by hand (never a timed test)::

    python benchmarks/audit_speed.py [--hours 1,4] [--rounds 3] [--cache DIR] [--seed 1]

The logs are simulated once (``lgvtool simulate --scenario warehouse --set
sim.nav_device=nav350 --seed SEED --duration ...``) and kept in ``--cache`` (default: a folder
in the system's temporary directory). Each command runs as a subprocess, measured as
``bench_memory.measure`` does (peak RSS of the child, wall and CPU time).

- Speed (target: at most 4): ``lgvtool audit LOG -o DIR`` of the one-hour log against the I/O
  floor, ``lgvtool replay LOG -e laser --no-view -o OUT`` of the same log (read every message,
  run the cheapest estimator, write the log again), alternating in the same run, ``--rounds``
  of each; the ratio of the medians is reported, with each round's figures.
- Memory (target: at most 1.6): peak RSS of ``audit`` of the four-hour log over that of the
  one-hour log.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_memory import measure

CACHE = Path(tempfile.gettempdir()) / "lgvtool-bench-audit"
"""Where the simulated logs are kept between runs (by default)."""


def simulate(path: Path, hours: float, seed: int) -> Path:
    """A warehouse NAV350 log of ``hours`` at ``path`` (simulated unless it exists)."""
    if path.exists():
        return path
    tmp = path.with_suffix(".part.mcap")
    tmp.unlink(missing_ok=True)
    res = subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario",
                          "warehouse", "--set", "sim.nav_device=nav350", "--seed", str(seed),
                          "--duration", str(hours * 3600), "-o", str(tmp)],
                         capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"simulate failed: {res.stderr.strip()}")
    tmp.rename(path)
    return path


def audit(log: Path, out: Path) -> dict[str, float]:
    """``lgvtool audit LOG -o OUT --json --force``: peak RSS (MB), wall and CPU time (s)."""
    r = measure(["audit", str(log), "-o", str(out), "--json", "--force", "--no-progress"])
    return {k: float(r[k]) for k in ("peak_mb", "wall_s", "cpu_s")}


def floor(log: Path, out: Path) -> dict[str, float]:
    """The I/O floor: ``lgvtool replay LOG -e laser --no-view -o OUT --force``."""
    r = measure(["replay", str(log), "-e", "laser", "--no-view", "--no-progress", "-o",
                 str(out), "--force"])
    return {k: float(r[k]) for k in ("peak_mb", "wall_s", "cpu_s")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", default="1,4", help="log durations, h (comma-separated; the "
                    "first is timed against the floor, the last's peak set against the first's)")
    ap.add_argument("--rounds", type=int, default=3, help="alternating rounds of audit and floor")
    ap.add_argument("--cache", type=Path, default=CACHE, help="folder of the simulated logs")
    ap.add_argument("--seed", type=int, default=1, help="seed of the simulated logs")
    ap.add_argument("--json", action="store_true", help="print the figures as JSON too")
    opts = ap.parse_args()
    hours = [float(h) for h in opts.hours.split(",")]
    opts.cache.mkdir(parents=True, exist_ok=True)
    logs = {h: simulate(opts.cache / f"warehouse-nav350-{h:g}h-s{opts.seed}.mcap", h,
                        opts.seed) for h in hours}
    first = hours[0]
    rounds: list[dict[str, dict[str, float]]] = []
    for k in range(opts.rounds):
        pair = {}
        # alternate which goes first, so that neither always meets a warm or a cold cache
        order = ("audit", "floor") if k % 2 == 0 else ("floor", "audit")
        for what in order:
            pair[what] = (audit(logs[first], opts.cache / "audit-out") if what == "audit"
                          else floor(logs[first], opts.cache / "floor-out.mcap"))
        rounds.append(pair)
        print(f"round {k + 1}: audit {pair['audit']['wall_s']:6.2f} s "
              f"({pair['audit']['peak_mb']:6.1f} MB), floor {pair['floor']['wall_s']:6.2f} s "
              f"({pair['floor']['peak_mb']:6.1f} MB), ratio "
              f"{pair['audit']['wall_s'] / pair['floor']['wall_s']:.2f}", flush=True)
    a = statistics.median(r["audit"]["wall_s"] for r in rounds)
    f = statistics.median(r["floor"]["wall_s"] for r in rounds)
    out: dict[str, object] = {"hours": first, "audit_wall_s": a, "floor_wall_s": f,
                              "speed_ratio": a / f, "rounds": rounds}
    print(f"audit of {first:g} h: median {a:.2f} s; floor (replay -e laser --no-view): "
          f"median {f:.2f} s; ratio {a / f:.2f} (target <= 4)")
    if len(hours) > 1:
        peaks = {h: audit(logs[h], opts.cache / "audit-out")["peak_mb"] for h in hours}
        peaks[first] = min([peaks[first]] + [r["audit"]["peak_mb"] for r in rounds])
        last = hours[-1]
        ratio = peaks[last] / peaks[first]
        out.update({"peak_mb": {f"{h:g}": p for h, p in peaks.items()}, "memory_ratio": ratio})
        print("peak RSS: " + ", ".join(f"{h:g} h {p:.1f} MB" for h, p in peaks.items())
              + f"; {last:g} h / {first:g} h = {ratio:.2f} (target <= 1.6)")
    if opts.json:
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
