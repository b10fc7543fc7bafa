"""Check that evo's APE on ``lgvtool export``'s TUM files equals lgvtool's true position RMSE
(run by hand; the test suite checks the same on a short drive).

For a log (default: a simulated paper-circle drive of 120 s, seed 0) it replays the estimators
into a log, exports their TUM files, and for every trajectory NAME computes evo's APE
(translation part, no alignment, evo's own nearest-stamp association with its default
``t_max_diff`` of 0.01 s) of ``NAME.tum`` against ``truth-at-NAME.tum``, beside lgvtool's
``true RMSE`` of the same trajectory. Needs the ``evo`` package (in the test extra).

Usage::

    python benchmarks/evo_ape_check.py                  # simulate, replay, export, compare
    python benchmarks/evo_ape_check.py --log run.mcap   # a log of your own (with truth)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path


def evo_rmse(reference: Path, estimate: Path) -> tuple[float, int]:
    """evo's APE RMSE (m) of ``estimate`` against ``reference`` and the poses it compared."""
    from evo.core import metrics, sync
    from evo.tools import file_interface

    ref = file_interface.read_tum_trajectory_file(str(reference))
    est = file_interface.read_tum_trajectory_file(str(estimate))
    ref, est = sync.associate_trajectories(ref, est)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    return float(ape.get_statistic(metrics.StatisticsType.rmse)), est.num_poses


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--log", type=Path, help="a log with ground truth (default: simulate)")
    parser.add_argument("--duration", type=float, default=120.0, help="simulated drive, s")
    args = parser.parse_args()

    from lgvtool.app.evaluate_job import evaluate_log
    from lgvtool.cli import main as cli
    from lgvtool.interop.trajectory_export import export_log

    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        log = args.log
        if log is None:
            from lgvtool.sim.logfile import write_log
            from lgvtool.sim.simulation import simulate

            log = work / "drive.mcap"
            write_log(simulate("paper-circle", seed=0, duration=args.duration), log)
        replayed = work / "replayed.mcap"
        try:
            cli(["replay", str(log), "-o", str(replayed)])
        except SystemExit as exc:
            if exc.code:
                return int(exc.code)
        summary = export_log(replayed, work / "tum", "tum")
        result = evaluate_log(replayed)
        print(f"log {log.name}: evo APE (translation, no alignment) vs lgvtool true RMSE")
        print(f"{'trajectory':<14} {'poses':>6} {'evo APE mm':>11} {'lgvtool mm':>11} "
              f"{'diff mm':>9}")
        worst = 0.0
        for name in summary.trajectories:
            if name.startswith("truth") or name not in result.estimators:
                continue
            truth = result.estimators[name].truth
            if truth is None:
                continue
            ape, n = evo_rmse(work / "tum" / f"truth-at-{name}.tum", work / "tum" / f"{name}.tum")
            diff = abs(ape - truth.position_rmse) * 1e3
            worst = max(worst, diff)
            print(f"{name:<14} {n:>6} {ape * 1e3:>11.4f} {truth.position_rmse * 1e3:>11.4f} "
                  f"{diff:>9.5f}")
        print(f"largest difference {worst:.5f} mm (target: below 0.1 mm)")
        return 0 if worst < 0.1 else 1


if __name__ == "__main__":
    sys.exit(main())
