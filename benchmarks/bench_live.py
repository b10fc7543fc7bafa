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
4. The cost of the front that serves both subprotocol names (``lgvtool.live.front``): a
   client in a process of its own receives timestamped messages (``time.monotonic_ns()`` in
   the payload) published at ``--front-rate`` Hz, alternately straight from foxglove-sdk's
   server (offering ``foxglove.sdk.v1``) and through the front (offering only
   ``foxglove.websocket.v1``), ``--front-messages`` per path in 4 rounds each; prints the
   latency from publishing to the client's receipt (median, p90, p99, max, ms) per path, then
   a burst of 20000 messages as fast as they go: how many the client receives, over how long,
   and the front's CPU time per message received.

``--front-only`` runs step 4 alone.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

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


#: the front benchmark's client: connects, subscribes to /bench/stamp, prints "ready", then for
#: each message numbered ``first`` to ``last`` received (until ``last``, or 5 s without one)
#: keeps its receipt time minus the time in its payload; prints them (ns) as JSON (the message
#: resent on subscribing, the last of the round before, is not counted)
_STAMP_CLIENT = r"""
import asyncio, json, sys, time
import websockets

async def main(url, proto, first, last):
    async with websockets.connect(url, subprotocols=[proto], max_size=None, close_timeout=1) as ws:
        while True:
            m = json.loads(await ws.recv())
            if m["op"] == "advertise":
                ids = [c["id"] for c in m["channels"] if c["topic"] == "/bench/stamp"]
                await ws.send(json.dumps({"op": "subscribe",
                                          "subscriptions": [{"id": 1, "channelId": ids[0]}]}))
                break
        print("ready", flush=True)
        lags, t0, t1 = [], None, None
        while True:
            try:
                frame = await asyncio.wait_for(ws.recv(), 5.0)
            except TimeoutError:
                break
            now = time.monotonic_ns()
            if isinstance(frame, bytes) and frame[0] == 1:
                doc = json.loads(frame[13:])
                if doc["n"] >= first:
                    lags.append(now - doc["t"])
                    t0, t1 = t0 or now, now
                    if doc["n"] >= last:
                        break
        print(json.dumps({"lags": lags, "span_ns": t1 - t0}), flush=True)

asyncio.run(main(sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])))
"""


def _pct(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, int(q * (len(s) - 1) + 0.5))]


def front(messages: int, rate: float, size: int) -> None:
    from lgvtool.live.live_server import LiveAddress, LiveServer

    server = LiveServer(LiveAddress("127.0.0.1", 0), warn=print)
    topic, schema = "/bench/stamp", "foxglove.Log"
    server.prepare({topic: schema})
    pad = "x" * size
    paths = {"direct (foxglove.sdk.v1)": (server.sdk_url, "foxglove.sdk.v1"),
             "front (foxglove.websocket.v1)": (server.url, "foxglove.websocket.v1")}

    sent = [0]

    def run(url: str, proto: str, n: int, period: float) -> dict[str, Any]:
        import json

        first = sent[0]
        client = subprocess.Popen([sys.executable, "-c", _STAMP_CLIENT, url, proto, str(first),
                                   str(first + n - 1)], stdout=subprocess.PIPE, text=True)
        assert client.stdout is not None
        assert client.stdout.readline().strip() == "ready"
        time.sleep(0.2)
        t_next = time.perf_counter()
        for i in range(first, first + n):
            server.publish(topic, schema, f'{{"n": {i}, "t": {time.monotonic_ns()}, '
                           f'"pad": "{pad}"}}'.encode(), 2 + i)
            if period:
                t_next += period
                delay = t_next - time.perf_counter()
                if delay > 0:
                    time.sleep(delay)
        sent[0] += n
        out = json.loads(client.stdout.readline())
        client.wait(10)
        return dict(out)

    async def cpu() -> float:
        return time.thread_time()

    lags: dict[str, list[float]] = {k: [] for k in paths}
    per_round = max(1, messages // 4)
    front_cpu = 0.0
    for _ in range(4):
        for label, (url, proto) in paths.items():
            cpu0 = server.front.call(cpu()).result()
            lags[label] += [1e-6 * v for v in run(url, proto, per_round, 1.0 / rate)["lags"]]
            if url == server.url:
                front_cpu += server.front.call(cpu()).result() - cpu0
    print(f"front: {per_round * 4} messages of {size + 40} bytes per path at {rate:g} Hz, "
          f"a client in its own process (latency from publishing to receipt, ms):")
    for label, v in lags.items():
        print(f"  {label:30s} median {_pct(v, 0.5):.3f}  p90 {_pct(v, 0.9):.3f}  "
              f"p99 {_pct(v, 0.99):.3f}  max {max(v):.3f}")
    d, f = lags.values()
    print(f"  the front adds: median {_pct(f, 0.5) - _pct(d, 0.5):+.3f} ms, "
          f"p99 {_pct(f, 0.99) - _pct(d, 0.99):+.3f} ms; its CPU "
          f"{1e6 * front_cpu / max(1, len(f)):.1f} us per message received")

    burst = 20000
    for label, (url, proto) in paths.items():
        cpu0 = server.front.call(cpu()).result()
        t0 = time.perf_counter()
        out = run(url, proto, burst, 0.0)
        wall = time.perf_counter() - t0
        used = server.front.call(cpu()).result() - cpu0
        lag = [1e-6 * v for v in out["lags"]]
        print(f"  burst of {burst} as fast as they go, {label}: {len(lag)} received "
              f"(the SDK drops the oldest past its backlog) over "
              f"{1e-9 * float(out['span_ns']):.2f} s, latency median "
              f"{_pct(lag, 0.5):.1f} ms; the front's CPU {1e6 * used / len(lag):.1f} us per "
              f"message received ({wall:.1f} s in all)")
    server.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--play", type=float, default=30.0)
    ap.add_argument("--front-messages", type=int, default=4000)
    ap.add_argument("--front-rate", type=float, default=500.0)
    ap.add_argument("--front-size", type=int, default=300, help="payload padding, bytes")
    ap.add_argument("--front-only", action="store_true")
    args = ap.parse_args()
    if args.front_only:
        front(args.front_messages, args.front_rate, args.front_size)
        return
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "circle.mcap"
        subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "-s", "paper-circle",
                        "--seed", "1", "--duration", str(args.duration), "-o", str(log)],
                       check=True, capture_output=True)
        offline(log)
        live(log, args.play)
    front(args.front_messages, args.front_rate, args.front_size)


if __name__ == "__main__":
    main()
