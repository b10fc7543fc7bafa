"""The NAV350 targets over loopback: a recording against the virtual NAV350 with faults, every
pose and landmark counted on both sides, and the clock estimate against the true device clock.

Run by hand (real time: ``--seconds`` of wall clock)::

    python benchmarks/bench_nav350_loopback.py [--seconds 60] [--no-faults] [--out rec.mcap]

The virtual NAV350 plays the simulator's paper-circle run with its clock 50 ppm fast; the
faults (run time, s) are 400 bytes of garbage at 8, three replies with a wrong checksum at 16,
``sFA 13`` at 24, errorCode 7 for 1 s at 32 and a 3 s link drop at 40. Prints both sides'
counts, the diagnostics by kind, and the largest clock error of the poses 10 s or more after the
first (target: under 2 ms).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

FAULTS = ("garbage:nav350:8:400", "badsum:nav350:16:3", "sfa:nav350:24:13",
          "error:nav350:32:1:7", "drop:nav350:40:3")


def main() -> None:
    from lgvtool.sim.emulate.emulator_playback import playback_from_scenario
    from lgvtool.sim.emulate.nav350.nav350_loopback import loopback

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=60.0)
    ap.add_argument("--no-faults", action="store_true")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    out = args.out or Path(tempfile.mkdtemp(prefix="nav350-loopback-")) / "rec.mcap"
    pb = playback_from_scenario("paper-circle", seed=0, duration=args.seconds + 30.0)
    faults = () if args.no_faults else FAULTS
    r = loopback(pb, out, seconds=args.seconds, faults=faults, drift_ppm=50.0)
    print(f"log: {out}")
    print(f"faults applied: {', '.join(r.faults) or 'none'}")
    print(f"poses:     device served {r.device_poses}, log holds {r.log_poses}")
    print(f"landmarks: device served {r.device_landmarks}, log holds {r.log_landmarks}")
    lost = (r.device_poses - r.log_poses, r.device_landmarks - r.log_landmarks)
    print(f"lost: {lost[0]} poses, {lost[1]} landmarks; reconnects {r.reconnects}; "
          f"{r.in_flight} reply(ies) still in flight when the recording stopped")
    print("diagnostics: " + ", ".join(f"{k} {v}" for k, v in sorted(r.diagnostics.items())))
    at10 = [e for t, e in r.clock_errors_ms if 10.0 <= t < 11.0]
    print(f"clock error at 10-11 s: {max(map(abs, at10)):.3f} ms; max |error| after 10 s: "
          f"{r.clock_error_after(10.0):.3f} ms (target < 2 ms)" if at10 else "no clock figures")


if __name__ == "__main__":
    main()
