"""Data lost when a recording is killed with ``kill -9``: 20 tries, median and maximum.

Run by hand::

    python benchmarks/kill9_recording.py [--tries 20] [--seed 1]

Each try plays the test circle drive on the device emulator (pseudo-terminals, real time),
starts ``lgvtool record`` on it, waits a random 3-8 s once MCU data flows, kills the recorder
with SIGKILL, and reads the cut-off log as ``lgvtool recover`` would: the loss is the time
from the kill to the last MCU frame kept (target: at most 1 s in every try).
"""

from __future__ import annotations

import argparse
import random
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(REPO), str(REPO / "tests" / "devices")]

from devices_helpers import record_args, start_emulator, wait_for  # noqa: E402

from lgvtool.log import LogReader, topics  # noqa: E402


def one_try(tmp: Path, wait_s: float) -> float:
    """Seconds of MCU data lost by one kill -9."""
    server = start_emulator(tmp, "pty", duration=60.0, speed=1.0)
    out = tmp / "crash.mcap"
    try:
        p = subprocess.Popen([sys.executable, "-m", "lgvtool",
                              *record_args(server, out, speed=1.0)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            if not wait_for(lambda: len(server.sent("mcu")) > 30 * 5, 15.0):
                raise SystemExit("no MCU data reached the recorder")
            time.sleep(wait_s)
            killed_ns = time.time_ns()
            p.kill()
            p.wait(timeout=10)
        finally:
            if p.poll() is None:
                p.kill()
    finally:
        server.stop()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(out)
    last_ns = max(m.log_time_ns for m in reader.messages([topics.MCU_FRAME]))
    return (killed_ns - last_ns) / 1e9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tries", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    opts = ap.parse_args()
    rng = random.Random(opts.seed)
    lost = []
    for i in range(opts.tries):
        with tempfile.TemporaryDirectory() as d:
            lost.append(one_try(Path(d), rng.uniform(3.0, 8.0)))
        print(f"try {i + 1}: {lost[-1]:.3f} s lost", flush=True)
    print(f"{len(lost)} kills: median {statistics.median(lost):.3f} s, max {max(lost):.3f} s "
          f"lost (target <= 1 s)")


if __name__ == "__main__":
    main()
