"""Decoder crashes in 10^6 fuzz inputs: every stream decoder (MCU, NAV200 replies, NAV200
requests) fed seeded random inputs (byte soups; valid traffic with flipped, dropped, repeated
or inserted bytes; cut off; spliced with random bytes) in random chunks.

Run by hand::

    python benchmarks/fuzz_decoders.py [--inputs 1000000] [--seed 1]

Prints, per decoder, the inputs run, the failures (an exception from ``feed``/``flush`` or
broken byte accounting; target 0) and the time taken. The test suite runs the same fuzzer on
a few thousand inputs (tests/wire/test_nav200_stream.py).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path[:0] = [str(REPO), str(REPO / "tests" / "wire")]

from wire_fuzz import DECODERS, fuzz  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--inputs", type=int, default=1_000_000, help="inputs in all")
    ap.add_argument("--seed", type=int, default=1)
    opts = ap.parse_args()
    total_fail = 0
    for i, name in enumerate(DECODERS):
        # the inputs shared out, the first decoders taking the remainder
        per = opts.inputs // len(DECODERS) + (i < opts.inputs % len(DECODERS))
        t0 = time.perf_counter()
        failures = fuzz(name, per, opts.seed + i)
        total_fail += len(failures)
        print(f"{name}: {per} inputs, {len(failures)} failures, "
              f"{time.perf_counter() - t0:.0f} s", flush=True)
        for data, exc in failures[:3]:
            print(f"  {type(exc).__name__}: {exc} on {data.hex()}")
    print(f"all decoders: {opts.inputs} inputs, {total_fail} failures (target 0)")


if __name__ == "__main__":
    main()
