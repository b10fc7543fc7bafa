"""The cost of checking every chunk's CRC-32 when a log is read.

Run by hand::

    python benchmarks/bench_crc.py [LOG] [--repeat 5]

Reads every chunk of LOG (default: a one-hour paper-circle log simulated into the system's
temporary directory and kept) three ways, best of ``--repeat``: decompressed only;
decompressed and checked as every read now does (:func:`verified_records`: size, CRC-32);
and the whole of what ``replay`` reads (:func:`load_log`). Prints the seconds and the CRC's
share.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

import zstandard  # noqa: E402
from bench_memory import best, hour_log_options  # noqa: E402

from lgvtool.localize.logdata import load_log  # noqa: E402
from lgvtool.log import LogReader  # noqa: E402
from lgvtool.log.mcap_chunks import _chunk_frame, chunk_window, verified_records  # noqa: E402
from lgvtool.log.mcap_records import decompress  # noqa: E402


def main() -> None:
    log, repeat = hour_log_options(__doc__ or "")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    chunks = reader._chunk_indexes  # the benchmark reads the raw chunk list
    zstd = zstandard.ZstdDecompressor()
    size = sum(ci.uncompressed_size for ci in chunks)

    def plain() -> None:
        with open(log, "rb") as f:
            for ci in chunks:
                buf, local = chunk_window(f, ci)
                kind, at, n, _crc = _chunk_frame(buf, local)
                if kind == "zstd":
                    zstd.decompress(buf[at:at + n], max_output_size=ci.uncompressed_size)
                else:
                    decompress(kind, buf[at:at + n], ci.uncompressed_size)

    def checked() -> None:
        with open(log, "rb") as f:
            for ci in chunks:
                buf, local = chunk_window(f, ci)
                verified_records(buf, local, zstd)

    def replay_read() -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = LogReader(log)
        load_log(r, r.config().reflectors or None)

    a, b, c = best(plain, repeat), best(checked, repeat), best(replay_read, repeat)
    print(f"{log.name}: {len(chunks)} chunks, {size / 1e6:.1f} MB of records")
    print(f"decompress only:        {a:.3f} s")
    print(f"decompress + check:     {b:.3f} s  (CRC-32 and size: +{b - a:.3f} s, "
          f"{100 * (b - a) / a:.0f} % of decompressing, {size / 1e6 / max(b - a, 1e-9):.0f} MB/s)")
    print(f"replay's whole read:    {c:.3f} s  (the check is {100 * (b - a) / c:.0f} % of it)")


if __name__ == "__main__":
    main()
