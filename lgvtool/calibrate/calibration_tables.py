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


def pose_model_table(cal: Calibration) -> list[str]:
    """The NAV poses' observation model: one line per value (age ms, skew lever m, noise at
    standstill mm and mrad) with its 1-sigma and whether the drives determine it; what the file
    sets follows (docs/calibration.md, "The pose observation model")."""
    pm = cal.pose_model
    if pm is None:
        return []
    lines = ["", "NAV pose model (fitted with the calibrated vehicle; docs/filter.md):",
             f"{'value':20s} {'unit':6s} {'estimate':>12s} {'1-sigma':>9s}  status"]
    stated = pm.stated_age_s * 1e3
    if not pm.age.determined:
        age_note = f"not determined ({pm.age.why})"
    elif pm.age.value >= 0.0:
        age_note = (f"determined: the vehicle's {stated:.2f} ms (nav_time_offset + "
                    f"nav_pose_age) + {pm.age.value * 1e3:.2f} ms")
    else:
        age_note = (f"determined: {pm.age.value * 1e3:.2f} ms from the vehicle's {stated:.2f} ms "
                    f"(nav_time_offset + nav_pose_age), which are kept")
    rows = [("pose_age", "ms", pm.total_age_s * 1e3, pm.age.sigma * 1e3, pm.age.determined,
             age_note),
            ("pose_skew_x", "m", pm.skew_x.value, pm.skew_x.sigma, pm.skew_x.determined,
             "determined" if pm.skew_x.determined else f"not determined ({pm.skew_x.why})"),
            ("pose_skew_y", "m", pm.skew_y.value, pm.skew_y.sigma, pm.skew_y.determined,
             "determined" if pm.skew_y.determined else f"not determined ({pm.skew_y.why})")]
    still = sum(lg.noise.poses for lg in pm.logs)
    spans = sum(lg.noise.standstills for lg in pm.logs)
    seconds = sum(lg.noise.duration_s for lg in pm.logs)
    noise_note = (f"determined ({still} poses over {spans} standstill(s), {seconds:.0f} s)"
                  if pm.sigma_xy.determined else f"not determined ({pm.sigma_xy.why})")
    rows += [("sigma_pose_xy", "mm", pm.sigma_xy.value * 1e3, pm.sigma_xy.sigma * 1e3,
              pm.sigma_xy.determined, noise_note),
             ("sigma_pose_heading", "mrad", pm.sigma_heading.value * 1e3,
              pm.sigma_heading.sigma * 1e3, pm.sigma_heading.determined, noise_note)]
    for name, unit, value, sigma, determined, note in rows:
        digits = 3 if unit == "m" else 2
        shown = f"{value:.{digits}f}" if determined else "-"
        sig = f"{sigma:.{digits}f}" if determined else "-"
        lines.append(f"{name:20s} {unit:6s} {shown:>12s} {sig:>9s}  {note}")
    keys = ("pose_age_fit", "pose_latency_s", "pose_skew_fit", "pose_skew_x_m",
            "pose_skew_y_m", "sigma_pose_xy_m", "sigma_pose_heading_rad")
    written = {n: {k: v for k, v in t.items() if k in keys}
               for n, t in cal.settings_set().items()}
    said = False
    for name, values in written.items():
        if values:
            lines.append(f"written to [estimators.{name}]: "
                         + ", ".join(f"{k} = {_setting(v)}" for k, v in values.items()))
            said = True
    if not said:
        lines.append("nothing of the pose model written: the drives determine none of it")
    if pm.sigma_xy.determined:
        lines.append("the noise at standstill is written only where it exceeds an estimator's "
                     "own: an error that stays while the vehicle stands does not scatter")
    return lines


def _setting(v: object) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.5g}"
    return str(v)


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
    out = [f"calibrated {len(cal.logs)} log(s) -> {output}", *estimates_table(cal),
           *pose_model_table(cal)]
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
            head.append(f"#   [estimators.{est}] {name} = {_setting(value)} (set from the "
                        f"calibration)")
    return "\n".join(head) + "\n\n" + to_toml(cal.config.to_dict())
