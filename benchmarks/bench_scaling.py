"""Speed and memory of the commands a user runs, on simulated paper-circle logs of 0.5, 1, 2
and 4 hours: wall time and peak resident set of each command, run as a subprocess.

Run by hand (never a timed test)::

    python benchmarks/bench_scaling.py [--hours 0.5,1,2,4] [--cache DIR] [--tree CHECKOUT]
                                       [--repeat 1] [--commands pf-paper,replay,evaluate]

Wall time and CPU time (user + system, which depends less on the machine's other load) are
printed. Per log: ``lgvtool replay LOG -o OUT --seed 0`` (the five default estimators and the
view channels: "replay five estimators"), ``lgvtool evaluate LOG -o DIR --seed 0`` on the raw
log (it runs the five estimators and writes Table 1 and report.html: "evaluate raw"), and on the
one-hour log ``lgvtool replay LOG -o OUT --estimator pf-paper --particles 150 --seed 0 --json``
("replay pf-paper end to end", with the command's own split into reading, filtering and
writing); ``calibrate`` (not in the default set) times ``lgvtool calibrate LOG -o FILE
--allow-unobservable --compare none`` (one circle cannot observe the lever arm and the wheels:
they are held and the rest estimated); ``simulate`` (not in the default set either) times
``lgvtool simulate --scenario paper-circle --seed 1 --duration H`` writing a log of each length;
``cut`` (not in the default set) cuts each log off at 90 % of its bytes, as a crash or a power
loss would, and times ``lgvtool info CUT`` and ``lgvtool recover CUT -o OUT``; ``export`` (not
in the default set) times ``lgvtool export LOG -o DIR --format tum --seed 0`` of
the raw log (it runs the five estimators and writes their TUM files beside the NAV poses and
the truth);
``floor`` times ``lgvtool replay LOG --estimator laser``
on the one-hour log with and without ``--no-view``: reading the log and writing the output with
almost no filtering and no compiled kernel, the floor under the end-to-end rows. The logs are
simulated once (``lgvtool simulate --scenario paper-circle --seed 1``) and kept in ``--cache``.
``--tree`` runs the lgvtool of another checkout (its folder is put on ``PYTHONPATH``), so that
the code before and after a change can be measured alternately in the same minutes; the load
average is printed before and after the runs.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_memory import measure, simulate

REPO = Path(__file__).resolve().parents[1]

TARGETS = {"replay pf-paper end to end": 0.72, "replay five estimators": 3.0,
           "evaluate raw": 5.0}
"""Wall-time targets on the one-hour log, s (evaluate of the 4-hour log: 25 s, 500 MB)."""


def median_run(tree: Path, args: list[str], repeat: int) -> dict[str, Any]:
    """The run of median wall time of ``repeat`` runs (with every run's wall time)."""
    runs = sorted((measure(args, tree) for _ in range(repeat)), key=lambda r: float(r["wall_s"]))
    best = dict(runs[len(runs) // 2])
    best["walls"] = [float(r["wall_s"]) for r in runs]
    return best


def load() -> str:
    return "load average " + ", ".join(f"{v:.2f}" for v in os.getloadavg())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--hours", default="0.5,1,2,4", help="log durations, h (comma-separated)")
    ap.add_argument("--cache", type=Path,
                    default=Path(tempfile.gettempdir()) / "lgvtool-bench-scaling",
                    help="folder of the simulated logs (kept between runs)")
    ap.add_argument("--tree", type=Path, default=REPO,
                    help="checkout whose lgvtool is run (default: this one)")
    ap.add_argument("--repeat", type=int, default=1, help="runs per cell (the median is shown)")
    ap.add_argument("--commands", default="pf-paper,replay,evaluate",
                    help="which runs: pf-paper (one hour), floor (one hour), replay, evaluate, "
                         "calibrate, simulate, export, cut")
    opts = ap.parse_args()
    hours = [float(h) for h in opts.hours.split(",")]
    wanted = set(opts.commands.split(","))
    opts.cache = opts.cache.resolve()  # the commands run in --tree's folder
    opts.cache.mkdir(parents=True, exist_ok=True)
    tree = opts.tree.resolve()
    print(f"lgvtool of {tree}; {load()}", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.mcap"
        if "pf-paper" in wanted:
            log = opts.cache / "paper-circle-1h.mcap"
            simulate(log, 1.0, tree)
            r = median_run(tree, ["replay", str(log), "-o", str(out), "--estimator", "pf-paper",
                                  "--particles", "150", "--seed", "0", "--json", "--force"],
                           opts.repeat)
            sec = json.loads(str(r["stdout"]))["seconds"]
            print(f"replay pf-paper end to end, 1 h: {r['wall_s']:.2f} s wall, "
                  f"{r['cpu_s']:.2f} s CPU (walls "
                  f"{', '.join(f'{w:.2f}' for w in r['walls'])}; target "
                  f"{TARGETS['replay pf-paper end to end']} s), peak {r['peak_mb']:.0f} MB; "
                  f"inside: read {sec['read']:.2f} s, filter {sec['filter']:.2f} s, write "
                  f"{sec['write']:.2f} s", flush=True)
        if "floor" in wanted:
            log = opts.cache / "paper-circle-1h.mcap"
            simulate(log, 1.0, tree)
            for view in ("--view", "--no-view"):
                r = median_run(tree, ["replay", str(log), "-o", str(out), "--estimator", "laser",
                                      view, "--seed", "0", "--force", "--no-progress"],
                               opts.repeat)
                print(f"replay laser {view}, 1 h (the output's floor): {r['wall_s']:.2f} s wall "
                      f"(walls {', '.join(f'{w:.2f}' for w in r['walls'])}), peak "
                      f"{r['peak_mb']:.0f} MB", flush=True)
        rows: list[tuple[str, float, dict[str, Any]]] = []
        for h in hours:
            log = opts.cache / f"paper-circle-{h:g}h.mcap"
            simulate(log, h, tree)
            runs = {
                "replay": ("replay five estimators",
                           ["replay", str(log), "-o", str(out), "--seed", "0", "--force",
                            "--no-progress"]),
                "calibrate": ("calibrate",
                              ["calibrate", str(log), "-o", str(Path(tmp) / "vehicle.toml"),
                               "--allow-unobservable", "--compare", "none", "--force"]),
                "simulate": ("simulate",
                             ["simulate", "--scenario", "paper-circle", "--seed", "1",
                              "--duration", f"{h * 3600:g}", "-o", str(Path(tmp) / "sim.mcap"),
                              "--force"]),
                "export": ("export raw",
                           ["export", str(log), "-o", str(Path(tmp) / f"tum-{h:g}"),
                            "--format", "tum", "--seed", "0", "--force"]),
                "evaluate": ("evaluate raw",
                             ["evaluate", str(log), "-o", str(Path(tmp) / f"report-{h:g}"),
                              "--seed", "0", "--force", "--no-progress"]),
            }
            if "cut" in wanted:  # the log cut off at 90 % of its bytes, as by a power loss
                broken = Path(tmp) / f"cut-{h:g}h.mcap"
                with open(log, "rb") as src, open(broken, "wb") as dst:
                    dst.write(src.read(int(log.stat().st_size * 0.9)))
                runs["info-cut"] = ("info cut log", ["info", str(broken)])
                runs["recover-cut"] = ("recover cut log",
                                       ["recover", str(broken), "-o",
                                        str(Path(tmp) / "recovered.mcap"), "--force"])
            for command, (name, args) in runs.items():
                if command in wanted or (command.endswith("-cut") and "cut" in wanted):
                    r = median_run(tree, args, opts.repeat)
                    rows.append((name, h, r))
                    print(f"{name:<22} {h:4g} h: {r['wall_s']:7.2f} s wall, "
                          f"{r['cpu_s']:7.2f} s CPU, peak {r['peak_mb']:6.0f} MB", flush=True)
    if rows:
        print("\n| run | " + " | ".join(f"{h:g} h" for h in hours) + " |")
        print("|---|" + "---:|" * len(hours))
        for name in dict.fromkeys(n for n, _, _ in rows):
            cells = {h: r for n, h, r in rows if n == name}
            print(f"| {name}: wall, s | " + " | ".join(
                f"{float(cells[h]['wall_s']):.2f}" if h in cells else "" for h in hours) + " |")
            print(f"| {name}: CPU, s | " + " | ".join(
                f"{float(cells[h]['cpu_s']):.2f}" if h in cells else "" for h in hours) + " |")
            print(f"| {name}: peak RSS, MB | " + " | ".join(
                f"{float(cells[h]['peak_mb']):.0f}" if h in cells else "" for h in hours) + " |")
    print(load())


if __name__ == "__main__":
    main()
