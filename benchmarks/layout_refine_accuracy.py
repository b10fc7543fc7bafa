"""``lgvtool layout refine`` against the simulator's true reflector positions (docs/audit.md,
"Refining the layout").

For each seed: a ``warehouse`` drive of ``--duration`` s with the NAV350
(``sim.nav_device=nav350``) and a survey error of ``--survey-mm`` per axis
(``site.survey_sigma_mm``), written to a log and refined by the command's own operation
(:func:`lgvtool.app.layout_job.refine_layout`, the layout's prior at the same sigma); the
refined positions are compared with where the simulator put the reflectors
(``Simulation.landmarks``: ``x``, ``y`` of each layout id), which no log holds. Prints per seed
and over all seeds:

- the RMS position error per axis and in the plane (m -> mm), of the surveyed and of the
  refined layout;
- the refined layout's RMS error after the best rigid alignment with the truth (rotation and
  translation: the frame a drive cannot observe, which only the survey's prior fixes);
- the reflectors whose true position lies within 3 sigma on both axes;
- the time of the adjustment (the solve, the log already read: wall time), and the CPU time
  of the whole operation (reading the log, the solve, writing the layout), which a loaded
  machine changes less.

    python benchmarks/layout_refine_accuracy.py --seeds 9200-9209
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def _seeds(text: str) -> list[int]:
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def _rigid_residual(ex: list[float], ey: list[float], tx: list[float], ty: list[float]
                    ) -> float:
    """RMS per axis (m) of the errors ``(ex, ey)`` at the true points ``(tx, ty)`` after the
    best small rigid motion (rotation about the centroid and translation) is taken out."""
    import numpy as np

    e = np.column_stack([ex, ey])
    p = np.column_stack([tx, ty])
    p = p - p.mean(axis=0)
    # e ~ t + w * (-py, px): linear least squares in (tx, ty, w)
    a = np.zeros((2 * len(e), 3))
    a[0::2, 0] = 1.0
    a[1::2, 1] = 1.0
    a[0::2, 2] = -p[:, 1]
    a[1::2, 2] = p[:, 0]
    b = e.reshape(-1)
    sol, *_ = np.linalg.lstsq(a, b, rcond=None)
    r = b - a @ sol
    return float(np.sqrt(np.mean(r * r)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="9200-9209", help="seeds, FIRST-LAST")
    ap.add_argument("--duration", type=float, default=300.0, help="drive, s")
    ap.add_argument("--survey-mm", type=float, default=20.0, help="survey error per axis, mm")
    args = ap.parse_args()

    from lgvtool.app.layout_job import LayoutRefineOptions, refine_layout
    from lgvtool.sim.logfile import write_log
    from lgvtool.sim.simulation import simulate

    overrides = {"sim.nav_device": "nav350", "site.survey_sigma_mm": args.survey_mm}
    all_s: list[float] = []
    all_r: list[float] = []
    all_a: list[float] = []
    inside = total = 0
    times: list[float] = []
    cpus: list[float] = []
    print(f"warehouse, NAV350, {args.duration:g} s, survey error {args.survey_mm:g} mm per axis")
    print(f"{'seed':>6} {'survey mm':>10} {'refined mm':>11} {'2-D mm':>7} {'aligned mm':>11} "
          f"{'in 3 sigma':>11} {'solve s':>8} {'cpu s':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in _seeds(args.seeds):
            sim = simulate("warehouse", seed=seed, duration=args.duration, overrides=overrides)
            log = Path(tmp) / f"w{seed}.mcap"
            write_log(sim, log)
            marks = sim.landmarks
            truth = {int(i): (float(x), float(y)) for i, x, y, extra in
                     zip(marks.ids, marks.x, marks.y, marks.is_false, strict=True) if not extra}
            cpu0 = time.process_time()
            out = refine_layout(LayoutRefineOptions(
                (str(log),), str(Path(tmp) / f"w{seed}.toml"),
                settings={"survey_sigma_m": args.survey_mm * 1e-3}))
            cpu = time.process_time() - cpu0
            cpus.append(cpu)
            doc = out.document
            es, er, ex, ey, tx, ty = [], [], [], [], [], []
            ok = 0
            for row in doc["reflectors"]:
                txx, tyy = truth[row["id"]]
                sx0, sy0 = row["surveyed"]
                es += [sx0 - txx, sy0 - tyy]
                dx, dy = row["x"] - txx, row["y"] - tyy
                er += [dx, dy]
                ex.append(dx)
                ey.append(dy)
                tx.append(txx)
                ty.append(tyy)
                sx, sy = row["sigma_m"]
                ok += abs(dx) <= 3.0 * sx and abs(dy) <= 3.0 * sy
            aligned = _rigid_residual(ex, ey, tx, ty)
            rms_s = math.sqrt(sum(e * e for e in es) / len(es))
            rms_r = math.sqrt(sum(e * e for e in er) / len(er))
            all_s += es
            all_r += er
            all_a.append(aligned)
            inside += ok
            total += len(ex)
            times.append(doc["solve_s"])
            print(f"{seed:>6} {rms_s * 1e3:>10.1f} {rms_r * 1e3:>11.1f} "
                  f"{rms_r * math.sqrt(2) * 1e3:>7.1f} {aligned * 1e3:>11.1f} "
                  f"{ok:>4}/{len(ex):<6} {doc['solve_s']:>8.2f} {cpu:>6.2f}")
    rs = math.sqrt(sum(e * e for e in all_s) / len(all_s))
    rr = math.sqrt(sum(e * e for e in all_r) / len(all_r))
    ra = math.sqrt(sum(a * a for a in all_a) / len(all_a))
    print(f"{'all':>6} {rs * 1e3:>10.1f} {rr * 1e3:>11.1f} {rr * math.sqrt(2) * 1e3:>7.1f} "
          f"{ra * 1e3:>11.1f} {inside:>4}/{total:<6} {sum(times) / len(times):>8.2f} "
          f"{sum(cpus) / len(cpus):>6.2f}")
    print(f"refined RMS error per axis {rr * 1e3:.1f} mm (target <= 7 mm); true position within "
          f"3 sigma on {100.0 * inside / total:.1f} % of reflectors (target >= 95 %); "
          f"mean solve {sum(times) / len(times):.2f} s (wall), whole operation "
          f"{sum(cpus) / len(cpus):.2f} s of CPU")


if __name__ == "__main__":
    main()
