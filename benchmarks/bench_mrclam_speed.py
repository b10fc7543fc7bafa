"""Wall time of import + replay + evaluate of one MRCLAM robot (15 minutes of data) with ``pf``.

Two measurements, each end to end and repeated (``--repeat``, the minimum and the median are
reported):

- ``cli``: ``lgvtool import mrclam DATASET --robot N -o rN.mcap && lgvtool evaluate rN.mcap
  --estimator pf`` as two processes, Python start-up and module imports included;
- ``python``: :func:`lgvtool.importers.mrclam_log.import_robot` then
  :func:`lgvtool.app.evaluate_job.evaluate_log` with ``estimators=["pf"]`` in this process,
  split into import and evaluate (read, replay, metrics).

The estimator runs with the settings the importer stores in the log (docs/mrclam.md). The
machine's load average is printed beside the figures: other processes on the same cores slow
every figure down.

Usage::

    python benchmarks/bench_mrclam_speed.py                 # robot 1, 3 repeats
    python benchmarks/bench_mrclam_speed.py --robots 1,2,3,4,5 --repeat 1 --json

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", International Journal of Robotics Research
30(8):969-974, 2011. The folder is ``$LGVTOOL_MRCLAM``, else
``../shared/data/mrclam/MRCLAM_Dataset6`` beside the repository, else ``--dataset``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

BUDGET_S = 5.0
"""Target: import + replay + evaluate of one robot with ``pf`` within this many seconds."""


def default_dataset() -> Path:
    """``$LGVTOOL_MRCLAM``, else the shared data folder beside the repository."""
    env = os.environ.get("LGVTOOL_MRCLAM")
    if env:
        return Path(env)
    return Path(__file__).resolve().parent.parent.parent / "shared" / "data" / "mrclam" / \
        "MRCLAM_Dataset6"


def lgvtool_command() -> list[str]:
    """The ``lgvtool`` entry point of this environment, else ``python -m lgvtool``."""
    exe = shutil.which("lgvtool", path=str(Path(sys.executable).parent)) or shutil.which(
        "lgvtool")
    return [exe] if exe else [sys.executable, "-m", "lgvtool"]


def time_cli(dataset: Path, robot: int, workdir: Path, estimator: str) -> float:
    """Seconds for the two commands, run one after the other as new processes."""
    log = workdir / f"r{robot}.mcap"
    log.unlink(missing_ok=True)
    cmd = lgvtool_command()
    t0 = time.perf_counter()
    subprocess.run([*cmd, "import", "mrclam", str(dataset), "--robot", str(robot), "-o",
                    str(log)], check=True, stdout=subprocess.DEVNULL)
    subprocess.run([*cmd, "evaluate", str(log), "--estimator", estimator], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def time_python(dataset: Path, robot: int, workdir: Path, estimator: str
                ) -> dict[str, float]:
    """Seconds of the import and of the evaluation (read, replay, metrics) in this process,
    and the RMSE at the estimate times that evaluate reports (m)."""
    from lgvtool.app.evaluate_job import evaluate_log
    from lgvtool.importers.mrclam_log import import_robot

    log = workdir / f"p{robot}.mcap"
    t0 = time.perf_counter()
    import_robot(dataset, robot, log)
    t1 = time.perf_counter()
    result = evaluate_log(log, estimators=[estimator])
    t2 = time.perf_counter()
    rmse = _truth_rmse_m(result, estimator)
    return {"import_s": t1 - t0, "evaluate_s": t2 - t1, "total_s": t2 - t0,
            "truth_rmse_m": rmse}


def _truth_rmse_m(result: Any, estimator: str) -> float:
    """The position RMSE against the ground truth that evaluate reports for ``estimator`` (at
    its estimate times), m."""
    from lgvtool.evaluate.document import build_document

    est = build_document([result])["estimators"].get(estimator) or {}
    truth = est.get("truth") or {}
    return float(truth.get("position_rmse_m", float("nan")))


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark; print the figures (or JSON)."""
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--dataset", type=Path, default=None, help="MRCLAM dataset folder")
    ap.add_argument("--robots", default="1", help="comma-separated robot numbers")
    ap.add_argument("--repeat", type=int, default=3, help="runs per robot and kind")
    ap.add_argument("--estimator", default="pf", help="estimator to evaluate")
    ap.add_argument("--json", action="store_true", help="print JSON")
    args = ap.parse_args(argv)
    dataset = args.dataset or default_dataset()
    if not (dataset / "Barcodes.dat").is_file():
        print(f"bench_mrclam_speed: dataset folder not found: {dataset} "
              "(set LGVTOOL_MRCLAM or pass --dataset)", file=sys.stderr)
        return 2
    robots = [int(r) for r in args.robots.split(",") if r.strip()]
    load = os.getloadavg()
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        for robot in robots:
            cli = [time_cli(dataset, robot, work, args.estimator) for _ in range(args.repeat)]
            py = [time_python(dataset, robot, work, args.estimator)
                  for _ in range(args.repeat)]
            rows.append({
                "robot": robot,
                "cli_s": {"min": min(cli), "median": statistics.median(cli), "runs": cli},
                "python_s": {k: {"min": min(p[k] for p in py),
                                 "median": statistics.median(p[k] for p in py)}
                             for k in ("import_s", "evaluate_s", "total_s")},
                "truth_rmse_m": py[-1]["truth_rmse_m"],
            })
    if args.json:
        print(json.dumps({"estimator": args.estimator, "budget_s": BUDGET_S,
                          "cpus": os.cpu_count(), "load_average": load, "rows": rows},
                         indent=2))
        return 0
    print(f"estimator {args.estimator}; {os.cpu_count()} CPUs; load average "
          f"{load[0]:.2f} {load[1]:.2f} {load[2]:.2f} at the start; {args.repeat} run(s) each; "
          "min / median, s\n")
    print("| robot | CLI: import && evaluate | Python: import | Python: evaluate | "
          "Python: total | within budget |")
    print("|---|---:|---:|---:|---:|---|")
    for r in rows:
        c, p = r["cli_s"], r["python_s"]
        worst = max(c["median"], p["total_s"]["median"])
        print(f"| Robot{r['robot']} | {c['min']:.2f} / {c['median']:.2f} | "
              f"{p['import_s']['min']:.2f} / {p['import_s']['median']:.2f} | "
              f"{p['evaluate_s']['min']:.2f} / {p['evaluate_s']['median']:.2f} | "
              f"{p['total_s']['min']:.2f} / {p['total_s']['median']:.2f} | "
              f"{'yes' if worst <= BUDGET_S else 'no'} (<= {BUDGET_S:.0f} s) |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
