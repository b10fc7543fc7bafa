"""The live view's figures: online estimate update time and latency, first message after a
subscription, and whether the online pf keeps up with 8 Hz scans at 500 particles.

Run by hand (never a timed test)::

    python benchmarks/bench_live.py [--duration 120] [--play 30]

1. Simulates a paper-circle log (8 Hz reflector scans, NAV200 polled every 0.45 s, MCU at
   10 Hz) of ``--duration`` s.
2. Feeds every message of it, in log order, to the online estimators (``ekf``, ``pf-paper``,
   ``pf`` at 500 particles fixed, and ``pf`` at its default KLD-adapted count) as fast as they
   go, and prints per update: median, 95th percentile, 99th percentile and maximum processing
   time (ms), updates per second of data, and the share of real time the estimator needs
   (below 1: it keeps up; the 8 Hz scan budget is 125 ms per update).
3. Plays the first ``--play`` s of the log at 1x to the live server with the online
   estimators, with a Foxglove WebSocket client connected; prints the time from each
   subscription to its first message (ms) and the latency from a message reaching the live
   feed to the estimate it caused being published (median, p95, max, ms), at the rate each
   estimator updates (pf: every scan; pf-paper and the NAV-pose estimators: every NAV poll).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests" / "live"))

CASES = {"ekf": {}, "pf-paper": {}, "pf (500 fixed)": {"pf.particles": 500,
                                                        "pf.min_particles": 500},
         "pf (default)": {}}


def _stats(seconds: list[float]) -> str:
    from lgvtool.live.tap import latency_summary

    s = latency_summary(seconds)
    if not s["count"]:
        return "no updates"
    ordered = sorted(seconds)
    p99 = 1e3 * ordered[min(len(ordered) - 1, int(0.99 * (len(ordered) - 1) + 0.5))]
    return (f"{s['count']:5d} updates, median {s['median_ms']:6.2f} ms, p95 {s['p95_ms']:6.2f}, "
            f"p99 {p99:6.2f}, max {s['max_ms']:6.2f}")


def offline(log: Path) -> None:
    from lgvtool.live.online import OnlineEstimator
    from lgvtool.log import LogReader

    reader = LogReader(log)
    cfg = reader.config()
    msgs = list(reader.raw_messages())
    span = (msgs[-1].log_time_ns - msgs[0].log_time_ns) * 1e-9
    print(f"online estimators fed {len(msgs)} messages ({span:.0f} s of data) as fast as they go")
    for label, settings in CASES.items():
        name = label.split()[0]
        est = OnlineEstimator(name, cfg, settings=settings)
        t0 = time.perf_counter()
        for m in msgs:
            est.feed(m.topic, m.data, m.log_time_ns)
        busy = time.perf_counter() - t0
        rate = len(est.update_seconds) / span
        print(f"  {label:15s} {_stats(est.update_seconds)}; {rate:.2f} updates/s of data; "
              f"needs {busy / span:.3f} of real time")


def live(log: Path, play_s: float) -> None:
    from foxglove_client import collect

    from lgvtool.live.live_playback import play, prepare_channels
    from lgvtool.live.live_server import LiveAddress, LiveServer
    from lgvtool.live.online import OnlineEstimator
    from lgvtool.live.tap import LiveFeed
    from lgvtool.log import LogReader, topics

    reader = LogReader(log)
    cfg = reader.config()
    names = ("laser", "ekf", "pf-paper", "pf")
    ests = [OnlineEstimator(n, cfg, settings={"pf.particles": 500, "pf.min_particles": 500}
                            if n == "pf" else None) for n in names]
    server = LiveServer(LiveAddress("127.0.0.1", 0))
    prepare_channels(server, reader)
    feed = LiveFeed(server, ests)
    stop = threading.Event()
    player = threading.Thread(target=play, args=(reader, feed), kwargs={"speed": 1.0,
                                                                       "stop": stop})
    player.start()
    time.sleep(2.0)
    wanted = {topics.MCU_FRAME, topics.NAV_POSE, topics.NAV_REFLECTORS, topics.MAP,
              *(topics.estimate_pose(n) for n in names)}
    got = collect(server.url, wanted, wanted=10 ** 9, timeout=play_s - 2.0)
    stop.set()
    player.join()
    feed.close()
    print(f"played {play_s:.0f} s at 1x with a client connected after 2 s "
          f"(subprotocol {got.subprotocol}):")
    for t in sorted(wanted):
        first = got.first_after_subscribe_s.get(t)
        n = len(got.messages.get(t, []))
        shown = "never" if first is None else f"{1e3 * first:7.1f} ms"
        print(f"  first message after subscribing to {t:28s} {shown}  ({n} received)")
    print("  latency from a message reaching the feed to its estimate published "
          f"(all estimators): {_stats(feed.latencies)}")
    for e in ests:
        print(f"  {e.name:9s} latency {_stats(feed.latency_of[e.name])}")
        print(f"  {'':9s} update  {_stats(e.update_seconds)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--play", type=float, default=30.0)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "circle.mcap"
        subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "-s", "paper-circle",
                        "--seed", "1", "--duration", str(args.duration), "-o", str(log)],
                       check=True, capture_output=True)
        offline(log)
        live(log, args.play)


if __name__ == "__main__":
    main()
