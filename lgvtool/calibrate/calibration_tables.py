"""Text and TOML of a calibration: the estimates table, the before/after table, the file."""

from __future__ import annotations

import math

from lgvtool.calibrate.calibration_run import Calibration
from lgvtool.calibrate.quantities import QUANTITIES


def _num(v: float, unit: str) -> str:
    digits = {"mm": 2, "deg": 4, "ms": 2, "deg/s": 4, "": 5}.get(unit, 4)
    return f"{v:.{digits}f}"


def estimates_table(cal: Calibration) -> list[str]:
    """One line per quantity: start, calibrated, 1-sigma, change, status."""
    lines = [f"{'quantity':20s} {'unit':6s} {'start':>12s} {'calibrated':>12s} "
             f"{'1-sigma':>9s} {'change':>10s}  status"]
    for name, e in cal.estimates.items():
        q = QUANTITIES[name]
        sig = "" if e.sigma is None else _num(e.sigma * q.display, q.unit)
        change = _num((e.value - e.start) * q.display, q.unit)
        lines.append(f"{name:20s} {q.unit or '1':6s} {_num(e.start * q.display, q.unit):>12s} "
                     f"{_num(e.value * q.display, q.unit):>12s} {sig:>9s} {change:>10s}  "
                     f"{e.status}")
    return lines


def comparison_table(cal: Calibration) -> list[str]:
    """One line per log and estimator: its error with the starting and the calibrated file."""
    if not cal.comparison:
        return []
    lines = [f"{'log':28s} {'estimator':14s} {'metric':12s} {'start, mm':>10s} "
             f"{'calibrated, mm':>15s} {'change':>8s}"]
    for r in cal.comparison:
        metric = "truth RMSE" if r.metric == "truth_rmse_m" else "circle RMSE"
        change = f"{r.change:+.1f} %" if math.isfinite(r.change) else ""
        log = r.log if len(r.log) <= 28 else "..." + r.log[-25:]
        lines.append(f"{log:28s} {r.estimator:14s} {metric:12s} {r.before * 1e3:10.1f} "
                     f"{r.after * 1e3:15.1f} {change:>8s}")
    return lines


def text(cal: Calibration, output: str) -> str:
    """What ``calibrate`` prints on stdout (its warnings go to stderr, as every command's)."""
    out = [f"calibrated {len(cal.logs)} log(s) -> {output}", *estimates_table(cal)]
    comp = comparison_table(cal)
    if comp:
        out += ["", "estimators with the starting and with the calibrated configuration:",
                *comp]
    return "\n".join(out)


def toml(cal: Calibration) -> str:
    """The calibrated configuration as TOML, headed by what it was calibrated from."""
    from lgvtool.config import to_toml

    head = ["# vehicle calibrated by lgvtool calibrate from: "
            + ", ".join(str(d["path"]) for d in cal.logs)]
    for name, e in cal.estimates.items():
        if e.sigma is not None:
            q = QUANTITIES[name]
            head.append(f"#   {name} = {_num(e.value * q.display, q.unit)} +- "
                        f"{_num(e.sigma * q.display, q.unit)} {q.unit} (1-sigma)")
    for est, params in cal.settings_set().items():
        for name, value in params.items():
            head.append(f"#   [estimators.{est}] {name} = {value:.5g} (set from the "
                        f"calibration)")
    return "\n".join(head) + "\n\n" + to_toml(cal.config.to_dict())
