"""The floor under ``replay --estimator pf-paper`` end to end that the log format sets, measured
without lgvtool's code.

Run by hand::

    python benchmarks/bench_json_floor.py [LOG] [--repeat 5]

Whatever a Python program does with a one-hour log (default: the paper-circle hour, simulated
into the system's temporary directory and kept), the paper's filter needs the MCU frames, the
NAV poses and the reflector scans, which the log stores as JSON messages (the log contract) in
zstd-compressed chunks that hold every topic. So any replay pays at least, each part measured
here on its own, best of ``--repeat``:

- ``start``: a fresh interpreter importing numpy, orjson and zstandard, and exiting (a
  subprocess);
- ``decompress``: every chunk's records decompressed (python-zstandard, the compressed bytes
  already in memory);
- ``json``: ``orjson.loads`` of every /mcu/frame, /nav/pose and /nav/reflectors message (the
  payloads already cut out of the records);
- ``copy``: the input's bytes copied to an output file (the output holds the input's messages;
  copying its chunks unchanged is the cheapest way to write them);
- ``numba``: importing numba and calling one function from numba's disk cache, timed inside a
  fresh interpreter that has imported the rest (what the compiled kernels cost before their
  first useful instruction; numba's share of the exit is left out).

The messages are cut out with the ``mcap`` package beforehand (not timed), so none of the parts
is lgvtool's code. Their sum is printed beside the 0.72 s target of the pf-paper row.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import orjson
import zstandard
from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_memory import best, hour_log_options

TOPICS = ("/mcu/frame", "/nav/pose", "/nav/reflectors")
"""The topics the paper's filter reads."""

_START = "import numpy, orjson, zstandard"
_NUMBA = """
import time
import numpy, orjson, zstandard
t0 = time.perf_counter()
import numba
def plus_one(x):
    return x + 1.0
numba.njit(cache=True)(plus_one)(0.0)
print(time.perf_counter() - t0)
"""


def fresh(code: str, place: Path) -> str:
    """Run ``code`` as a script in a fresh interpreter (numba caches only functions of a
    file), which must succeed; what it printed."""
    script = place / "script.py"
    if not script.exists() or script.read_text() != code:
        script.write_text(code)
    return subprocess.run([sys.executable, str(script)], check=True, cwd=place,
                          capture_output=True, text=True).stdout


def main() -> None:
    log, repeat = hour_log_options(__doc__ or "")

    with open(log, "rb") as f:
        chunks = [r.data for r in StreamReader(f, emit_chunks=True).records
                  if isinstance(r, Chunk)]
    with open(log, "rb") as f:
        payloads = [m.data for _, ch, m in make_reader(f).iter_messages(topics=list(TOPICS))
                    if ch.topic in TOPICS]
    zstd = zstandard.ZstdDecompressor()
    size = sum(len(c) for c in chunks)

    def decompress() -> None:
        for c in chunks:
            zstd.decompress(c)

    def decode() -> None:
        for p in payloads:
            orjson.loads(p)

    with tempfile.TemporaryDirectory() as tmp:
        place = Path(tmp)
        out = place / "copy.mcap"
        parts = {
            "start": best(lambda: fresh(_START, place), repeat),
            "decompress": best(decompress, repeat),
            "json": best(decode, repeat),
            "copy": best(lambda: shutil.copyfile(log, out), repeat),
        }
        fresh(_NUMBA, place)  # compiles into numba's cache beside the script
        parts["numba"] = min(float(fresh(_NUMBA, place)) for _ in range(repeat))

    print(f"log: {log} ({log.stat().st_size / 1e6:.1f} MB; {len(chunks)} chunks, "
          f"{size / 1e6:.1f} MB compressed records; {len(payloads)} messages of "
          f"{', '.join(TOPICS)}); best of {repeat}, load average "
          + ", ".join(f"{v:.2f}" for v in os.getloadavg()))
    for name, s in parts.items():
        print(f"  {name:<10} {s:6.3f} s")
    total = sum(parts.values())
    print(f"  {'sum':<10} {total:6.3f} s   (target of replay pf-paper end to end: 0.72 s; "
          f"without numba: {total - parts['numba']:.3f} s)")


if __name__ == "__main__":
    main()
