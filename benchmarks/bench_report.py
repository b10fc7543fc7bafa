"""Report build time against evaluate's total, on a long log (the report must scale).

Run by hand (never a timed test)::

    python benchmarks/bench_report.py [--log FOUR_HOURS.mcap] [--hours 4] [-e pf-paper ...]

Simulates a paper-circle log of ``--hours`` hours unless one is given, then in this process:
evaluates it (reading, the estimators, the metrics: :func:`evaluate_log`), and builds the
outputs of ``-o``: the JSON document, Table 1 in four formats and report.html (the figures,
the data-quality section). Prints the seconds of each part, the rotations, the report's size
and the report's share of the total (target: under 10 %).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--log", type=Path)
    ap.add_argument("--hours", type=float, default=4.0)
    ap.add_argument("-e", "--estimator", action="append", dest="estimators")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        log = args.log
        if log is None:
            log = Path(tmp) / "long.mcap"
            subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "-s", "paper-circle",
                            "--seed", "1", "--duration", str(args.hours * 3600), "-o",
                            str(log)], check=True, capture_output=True)
        from lgvtool.app.evaluate_job import evaluate_log, write_outputs
        from lgvtool.evaluate.document import build_document

        t0 = time.perf_counter()
        res = evaluate_log(str(log), estimators=args.estimators)
        t1 = time.perf_counter()
        doc = build_document([res])
        out = Path(tmp) / "report"
        write_outputs(out, [res], doc, png=False)
        t2 = time.perf_counter()
        size = (out / "report.html").stat().st_size
    total = t2 - t0
    print(f"log {log.name}: {res.laps.complete} complete rotations, estimators "
          f"{', '.join(res.estimators)} ({res.source})")
    print(f"  evaluate (read, estimators, metrics) {t1 - t0:8.2f} s")
    print(f"  outputs (JSON, Table 1, report.html) {t2 - t1:8.2f} s  ({size / 1e6:.1f} MB)")
    print(f"  total                                {total:8.2f} s")
    print(f"  report share of the total            {100 * (t2 - t1) / total:8.1f} %  "
          "(target < 10 %)")


if __name__ == "__main__":
    main()
