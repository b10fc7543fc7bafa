"""NAV350 codec speed: the 8896-byte full ``sAN mNPOSGetData`` reply (pose, three fully
populated landmarks, a 1440-point DIST1 and RSSI1), decoded by the stream decoder the recorder
uses (framing, checksum, walking every block), target under 200 us per reply.

Run by hand (never a timed test)::

    python benchmarks/bench_nav350_decode.py [--repeat 2000]

Prints the median and best of 5 batches, microseconds per reply, for CoLa-B (the recorder's
dialect) and, for reference, the same reply in CoLa-A.
"""

from __future__ import annotations

import argparse
import statistics
import time

TARGET_US = 200.0


def full_reply() -> object:
    from lgvtool.devices.nav350 import nav350_telegrams as tg

    marks = tuple(tg.Landmark((1000 * i, -2000 * i), (3000 + 17 * i, 45000 * i),
                              tg.LandmarkInfo(i, 10 + i, 1, 1, 90, 1000 + i, 80, 5, 200, 10, 12))
                  for i in range(3))
    dist = tg.ScanChannel("DIST1", 1.0, 0.0, 0, 250, 1000, tuple(range(5000, 6440)))
    rssi = tg.ScanChannel("RSSI1", 1.0, 0.0, 0, 250, 1000, tuple(i % 256 for i in range(1440)))
    data = tg.PoseData(1, 0, 1, 2, (12345, -6789, 90000), tg.PoseInfo(1, 1_000_000, 15, 4, 0, 3),
                       tg.LandmarkData(1, marks), (dist,), rssi)
    return tg.Telegram("sAN", "mNPOSGetData", data)


def per_reply_us(raw: bytes, repeat: int) -> tuple[float, float]:
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder

    dec = Nav350StreamDecoder()
    batches = []
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(repeat):
            out = dec.feed(raw)
        batches.append((time.perf_counter() - t0) / repeat * 1e6)
        assert len(out) == 1
    return statistics.median(batches), min(batches)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2000)
    args = ap.parse_args()
    reply = full_reply()
    for dialect in ("binary", "ascii"):
        raw = reply.encode(dialect)  # type: ignore[attr-defined]
        med, best = per_reply_us(raw, args.repeat if dialect == "binary" else args.repeat // 10)
        verdict = ("meets" if med < TARGET_US else "misses") if dialect == "binary" else "info"
        print(f"{dialect:6s} {len(raw):6d} B: median {med:7.1f} us, best {best:7.1f} us per "
              f"reply ({verdict}; target {TARGET_US:.0f} us for CoLa-B)")


if __name__ == "__main__":
    main()
