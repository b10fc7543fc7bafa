"""The calibration's normal-equation solver against scipy.optimize.least_squares on the same
problem (docs/calibration.md, "Solver").

Builds the least squares of ``lgvtool calibrate`` for two simulated drives with installation
errors (paper-circle and warehouse, ``--duration`` s each), fixes the measurement links and
noise scales of the first round, and solves it from the same start (a) with lgvtool's damped
Gauss-Newton on the sparse normal equations (SuperLU), (b) with
``scipy.optimize.least_squares`` (method ``trf``, Huber loss, the same sparse analytic
Jacobian, ``lsmr`` trust-region solver). Prints the time, the function and Jacobian evaluations
and the quantities each found.

    python benchmarks/calibrate_solvers.py --duration 200
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from calibrate_accuracy import ERRORS  # noqa: E402  (the same installation errors)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=200.0)
    ap.add_argument("--seeds", type=int, nargs=2, default=(31, 32))
    args = ap.parse_args()
    import numpy as np
    from scipy.optimize import least_squares

    from lgvtool.calibrate.drive import prepare
    from lgvtool.calibrate.quantities import QUANTITIES, default_names
    from lgvtool.calibrate.solve import Problem, SolveSettings
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    drives = []
    with tempfile.TemporaryDirectory() as tmp:
        for scenario, seed in zip(("paper-circle", "warehouse"), args.seeds, strict=True):
            path = Path(tmp) / f"{scenario}.mcap"
            write_log(simulate(scenario, seed=seed, duration=args.duration, overrides=ERRORS),
                      path)
            reader = LogReader(path)
            cfg = reader.config()
            drives.append(prepare(scenario, load_log(reader, cfg.reflectors), cfg.reflectors))
    start = {n: float(getattr(cfg.vehicle, n)) for n in QUANTITIES}
    names = [n for n in default_names("mcu", True, True) if n != "nav_pose_age"]

    def problem() -> Problem:
        p = Problem(drives, names, start, cfg.reflectors, cfg.vehicle.encoder_ppr,
                    SolveSettings(iterations=30, tolerance=1e-9), [False, False])
        p.relink()
        return p

    shown = [n for n in names if n != "gyro_bias"]
    a = problem()
    t0 = time.perf_counter()
    steps = a.gauss_newton()
    ta = time.perf_counter() - t0
    print(f"sparse Gauss-Newton (SuperLU): {ta:.2f} s, {steps} steps")
    b = problem()
    calls = {"f": 0, "j": 0}

    def fun(x: np.ndarray) -> np.ndarray:
        calls["f"] += 1
        return b.evaluate(x, jac=False)[0]

    def jac(x: np.ndarray):  # type: ignore[no-untyped-def]
        calls["j"] += 1
        return b.evaluate(x)[1]

    t0 = time.perf_counter()
    res = least_squares(fun, b.x, jac=jac, method="trf", loss="huber", f_scale=2.0,
                        tr_solver="lsmr", x_scale="jac", max_nfev=200)
    tb = time.perf_counter() - t0
    print(f"scipy least_squares trf/lsmr: {tb:.2f} s, {calls['f']} evaluations, "
          f"{calls['j']} Jacobians, status {res.status} ({res.message})")
    print(f"{'quantity':20s} {'Gauss-Newton':>14s} {'least_squares':>14s} {'difference':>11s}")
    for i, n in enumerate(shown):
        q = QUANTITIES[n]
        va, vb = a.x[i] * q.display, res.x[i] * q.display
        print(f"{n:20s} {va:14.5f} {vb:14.5f} {vb - va:+11.5f} {q.unit}")
    print(f"cost: Gauss-Newton {a.cost(a.x):.1f}, least_squares {a.cost(res.x):.1f}")


if __name__ == "__main__":
    main()
