"""The verdict that ends ``lgvtool evaluate``: what is good, what is bad, on which reference.
Pure: no I/O (docs/evaluation.md, "The verdict").

Per log, :func:`verdict_of` scores every estimator on the best reference the log has:

1. ``"truth"``: the ground truth (``/truth/pose``): the position RMSE over the whole drive, m;
2. else ``"circle"``: the reference circle of a circle drive: the average over the complete
   rotations of the radial RMSE (Table 1's Average row), m;
3. else ``"none"``: no figure of accuracy; what can be said instead is how far each estimate
   lies from the laser's (RMS distance, m) and the NAV's own record (replies without a
   position, requests unanswered, gaps).

Each estimator's error is also given as a multiple of the laser's error on the same
reference (``0.19`` = 0.19 x the laser; lower is better), with the observations it used
(reflector scans, NAV poses, odometry only). On the paper's experiment (a circle at 60 deg
steering, drive wheel at 36 cm/s) the paper's own Table 1 figures are shown beside lgvtool's
circle figures, labelled as the paper's. Where the log has both a circle and the truth and
they rank the estimators differently, a warning says so.

:func:`format_verdict` prints a verdict in at most :data:`MAX_LINES` lines of at most
``width`` columns; :func:`summary_line` sums up several logs in one line. The Verdict is also
the ``verdict`` key of the evaluation's JSON document (:func:`verdict_dict`).
"""

from __future__ import annotations

import math
import re
import textwrap
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

from lgvtool.json_types import JSONObject

if TYPE_CHECKING:
    from lgvtool.evaluate.evaluation import EvaluationResult
    from lgvtool.evaluate.quality import DataQuality
    from lgvtool.trajectory import Trajectory

__all__ = ["COLUMN_HELP", "MAX_LINES", "PAPER", "EstimatorVerdict", "Verdict", "format_verdict",
           "is_paper_experiment", "nav_quality_text", "paths_line", "summary_line",
           "verdict_dict", "verdict_of"]

MAX_LINES = 10
"""Most lines :func:`format_verdict` prints for one log."""
WIDTH = 100
"""Default width of a verdict line, columns."""

BASELINE = "laser"
"""The estimator every error is compared with (the paper's baseline)."""
PAPER_FILTER = "pf-paper"
"""lgvtool's implementation of the paper's filter, compared with the paper's figure."""

PAPER: Mapping[str, float] = {
    "laser_rmse_mm": 56.8978,
    "filter_rmse_mm": 20.4341,
    "laser_variance_mm2": 472.6535,
    "filter_variance_mm2": 117.6301,
}
"""The paper's published Table 1 Average row (Ali et al., section 4): RMSE in mm and variance
in mm^2 of the laser navigation and of its particle filter on its own vehicle. Shown only
beside lgvtool's figures and labelled as the paper's, never in place of a computed one."""

PAPER_STEERING_DEG = 60.0
"""Steering angle of the paper's experiment, degrees ..."""
PAPER_STEERING_TOL_DEG = 2.0
"""... within this many degrees."""
PAPER_SPEED_M_S = 0.36
"""Drive-wheel speed of the paper's experiment, m/s ..."""
PAPER_SPEED_TOL = 0.15
"""... within this fraction of it."""

RANK_MARGIN = 0.10
"""Two estimators count as ranked differently by the circle and the truth only when each
metric tells them apart by more than this fraction of the larger figure (no warning over a
near tie)."""
CONVERGING = 1.5
"""A truth note gives the RMSE over the complete rotations when the whole drive's is more than
this many times larger (a filter that converges slowly from its start)."""

COLUMN_HELP: tuple[tuple[str, str], ...] = (
    ("Log", "the log a row belongs to (several logs)"),
    ("Rotation / Number", "the complete rotation's number in time order (the paper's "
     "'Number'; over several logs 'Number' counts the rows of all logs); Average: the mean "
     "of the rotation rows, as in the paper"),
    ("RMSE", "circle: root mean square of the signed radial error (distance from the circle "
     "centre minus the radius), mm; ground truth: of the distance from the truth, mm"),
    ("σ² / variance", "population variance of the signed radial error, mm² (RMSE² = bias² "
     "+ σ²)"),
    ("bias", "mean signed radial error, mm (positive: outside the circle)"),
    ("max|e| / max |error|", "largest |radial error| of any rotation, mm"),
    ("centre / centre offset", "distance of the estimator's circle centre from the reference "
     "centre (the truth's, else the lap source's), mm: the radial error cannot see a circle "
     "driven in the wrong place"),
    ("x laser / less error than laser (%)", "the estimator's circle RMSE divided by the "
     "laser's: 0.19 = 0.19 x the laser's error, below 1 is better than the laser; --wide "
     "gives 100 x (1 - that) %, positive is better"),
    ("ground truth RMSE / true RMSE", "root mean square of the distance from the ground "
     "truth over the whole drive, mm"),
    ("in rot. / true RMSE in rotations", "the same over the complete rotations only: the "
     "samples the circle columns score, mm"),
    ("mean, p95, max / true mean, p95, max", "mean, 95th percentile and largest distance "
     "from the ground truth over the whole drive, mm"),
    ("heading / heading RMSE", "RMSE of the heading error against the ground truth, "
     "degrees"),
)
"""Every column of the tables, as (terminal header / ``--wide``, file and report header,
meaning with its unit): for ``--help`` and the report."""


@dataclass(frozen=True)
class EstimatorVerdict:
    """One estimator's line of the verdict."""

    name: str
    error_m: float | None
    """The error on the verdict's reference, m: the truth's position RMSE over the whole drive,
    or the circle's average radial RMSE over the complete rotations; None without a reference
    (or without a figure of this estimator on it)."""
    ratio_to_laser: float | None
    """``error_m`` divided by the laser's ``error_m`` (dimensionless; 1.0 for the laser; lower
    is better); None without both figures."""
    observations: str
    """What the estimator updated with: "reflector scans", "NAV poses", "odometry only",
    "NAV poses (the laser itself)", ..."""
    note: str = ""
    """One short remark (e.g. the truth RMSE over the rotations of a filter that converges
    slowly, or, without a reference, how far it lies from the laser)."""
    disagreement_m: float | None = None
    """Without a reference: RMS distance between this estimate and the laser's at the same
    times, m (None for the laser itself, or with a reference)."""


@dataclass(frozen=True)
class Verdict:
    """The verdict on one log (see the module docstring)."""

    log: str
    """The log's name."""
    reference: str
    """``"truth"``, ``"circle"`` or ``"none"``: what ``error_m`` is measured against."""
    reference_text: str
    """One phrase naming the reference and its figure."""
    estimators: tuple[EstimatorVerdict, ...]
    """In the order of the tables (laser first)."""
    paper: str | None
    """On the paper's experiment: one line with the paper's published Table 1 figures (mm)
    beside lgvtool's circle figures (mm) of this log; else None."""
    warnings: tuple[str, ...]
    """Verdict-level warnings, one sentence each without a "Warning:" prefix: the circle and
    the truth rank the estimators differently; no laser to compare with."""
    paths: tuple[str, ...]
    """The files written (report.html first), as given; empty when nothing was written."""
    no_reference_text: str | None
    """Without a reference: why there is none, and the NAV's own quality record; else None."""


# ------------------------------------------------------------------------------ building


def is_paper_experiment(result: EvaluationResult) -> bool:
    """True when ``result`` is a drive of the paper's experiment: a circle drive at the paper's
    steering angle (60 +- 2 deg) with the drive wheel at its speed (0.36 m/s +- 15 %, median
    of the MCU frames while moving)."""
    ref = result.reference
    speed = getattr(result, "drive_speed", None)
    if not ref.circle_drive or ref.steering_angle is None or speed is None:
        return False
    return (abs(abs(math.degrees(ref.steering_angle)) - PAPER_STEERING_DEG)
            <= PAPER_STEERING_TOL_DEG
            and abs(speed - PAPER_SPEED_M_S) <= PAPER_SPEED_TOL * PAPER_SPEED_M_S)


def nav_quality_text(q: DataQuality | None) -> str:
    """One sentence on the NAV's own record in the log: replies, replies without a position,
    requests unanswered, the longest silence of /nav/pose (s)."""
    if q is None:
        return "The NAV's own record could not be read."
    if q.nav_replies == 0:
        return "The log holds no NAV pose replies."
    share = 100.0 * q.nav_no_position / q.nav_replies
    gaps = [g.length for g in q.gaps if g.topic == "/nav/pose"]
    gap = f"longest pose gap {max(gaps):.1f} s" if gaps else "no pose gaps"
    return (f"NAV: {q.nav_replies} replies, {q.nav_no_position} without a position "
            f"({share:.1f} %), {q.nav_unanswered} unanswered, {gap}.")


def _mm(v: float) -> str:
    return f"{v * 1e3:.1f} mm"


def _ordinal(k: int) -> str:
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"


def _apart(a: float, b: float) -> bool:
    return abs(a - b) > RANK_MARGIN * max(abs(a), abs(b))


def _rank_warning(circle: Mapping[str, float], truth: Mapping[str, float]) -> str | None:
    """A warning when the circle (average radial RMSE, m) and the truth (position RMSE over
    the same rotations, m) rank the estimators differently by more than a near tie."""
    names = [n for n in circle if n in truth and math.isfinite(circle[n])
             and math.isfinite(truth[n])]
    pairs = [(a, b) for i, a in enumerate(names) for b in names[i + 1:]
             if _apart(circle[a], circle[b]) and _apart(truth[a], truth[b])
             and (circle[a] < circle[b]) != (truth[a] < truth[b])]
    if not pairs:
        return None
    by_circle = sorted(names, key=lambda n: circle[n])
    by_truth = sorted(names, key=lambda n: truth[n])

    def shift(n: str) -> int:
        return abs(by_circle.index(n) - by_truth.index(n))

    def flattered(n: str) -> bool:  # the circle ranks it better than the truth does
        return by_circle.index(n) < by_truth.index(n)

    involved = {n for pair in pairs for n in pair}
    worst = max(involved, key=lambda n: (shift(n), flattered(n), sum(n in p for p in pairs),
                                         n))
    others = [p for p in pairs if worst not in p]
    tail = f" (and {len(others)} other pair{'s' if len(others) > 1 else ''})" if others else ""
    return (f"the circle ranks {worst} {_ordinal(by_circle.index(worst) + 1)} "
            f"({_mm(circle[worst])}), the truth {_ordinal(by_truth.index(worst) + 1)} "
            f"({_mm(truth[worst])}, same rotations){tail}")


def _paper_line(circle: Mapping[str, float]) -> str:
    """The paper's Table 1 Average beside this log's circle figures (mm)."""
    ratio = PAPER["filter_rmse_mm"] / PAPER["laser_rmse_mm"]
    paper = (f"The paper's Table 1: laser {PAPER['laser_rmse_mm']:.1f}, its filter "
             f"{PAPER['filter_rmse_mm']:.1f} mm ({ratio:.2f} x)")
    laser, filt = circle.get(BASELINE), circle.get(PAPER_FILTER)
    if laser is not None and filt is not None and laser > 0:
        here = (f"this log's circle: laser {laser * 1e3:.1f}, {PAPER_FILTER} "
                f"{filt * 1e3:.1f} mm ({filt / laser:.2f} x)")
    elif laser is not None:
        here = f"this log's circle: laser {laser * 1e3:.1f} mm"
    elif filt is not None:
        here = f"this log's circle: {PAPER_FILTER} {filt * 1e3:.1f} mm"
    elif circle:
        here = f"this log: no {BASELINE} or {PAPER_FILTER} on the circle to compare"
    else:
        here = "this log has no complete rotation to compare"
    return f"{paper}; {here}"


def _no_reference_reason(result: EvaluationResult) -> str:
    ref = result.reference
    if ref.circle_drive and result.laps.complete == 0:
        why = "less than one complete rotation and no ground truth"
    elif ref.steering_angle is not None and ref.kinematic_radius is None:
        why = "a straight drive (steering 0) and no ground truth"
    elif ref.steering_angle is None:
        why = "no steering angle and no ground truth"
    else:
        why = "the drive is not a circle and the log has no ground truth"
    return f"No reference: {why}."


def _disagreement(est: Trajectory, laser: Trajectory) -> float | None:
    """RMS distance of ``est`` from ``laser`` (trajectories: t s, x, y m, heading rad) at
    ``est``'s times inside the laser's span, m."""
    import numpy as np

    from lgvtool.evaluate.metrics import truth_errors

    err = truth_errors(est, laser)["position_error"].to_numpy(dtype=float)
    err = err[np.isfinite(err)]
    return float(np.sqrt(np.mean(err * err))) if err.size else None


def verdict_of(
    result: EvaluationResult,
    *,
    paths: Sequence[str] = (),
    observations: Mapping[str, str] | None = None,
    quality: DataQuality | None = None,
) -> Verdict:
    """The verdict on one evaluated log.

    :param result: the evaluation of the log (figures in m, times in s).
    :param paths: the files written for it (report.html first), as the user named them.
    :param observations: estimator name -> what it updated with; default
        ``result.observations`` (set by :func:`lgvtool.evaluate.log_evaluation.evaluate_log`), and
        "unknown" for a name it lacks.
    :param quality: the log's data quality (the NAV's record, used without a reference);
        default ``result.quality``.
    """
    from lgvtool.evaluate.table import build_table

    obs = dict(getattr(result, "observations", None) or {})
    obs.update(observations or {})
    q = quality if quality is not None else result.quality
    table = build_table([result])
    names = list(table.estimators)
    circle = {n: s.rmse for n, s in table.average.items() if math.isfinite(s.rmse)}
    truth = {n: t.position_rmse for n, t in table.truth.items()
             if math.isfinite(t.position_rmse)}
    truth_rot = {n: v for n, v in table.truth_in_rotations.items() if math.isfinite(v)}

    if truth:
        reference = "truth"
        figures: dict[str, float] = truth
        reference_text = "position RMSE against the ground truth, whole drive"
    elif circle:
        reference = "circle"
        figures = circle
        k = result.laps.complete
        reference_text = (f"radial RMSE on the reference circle, mean of {k} "
                          f"rotation{'s' if k != 1 else ''}")
    else:
        reference = "none"
        figures = {}
        reference_text = "no reference: neither ground truth nor a circle with a complete " \
                         "rotation"

    laser_err = figures.get(BASELINE)
    laser_df = (result.estimators[BASELINE].trajectory if BASELINE in result.estimators
                else None)
    rows: list[EstimatorVerdict] = []
    for n in names:
        err = figures.get(n)
        ratio = (err / laser_err if err is not None and laser_err is not None and laser_err > 0
                 else None)
        note = ""
        apart: float | None = None
        if reference == "truth" and err is not None:
            inside = truth_rot.get(n)
            if inside is not None and err > CONVERGING * inside and err - inside > 0.005:
                note = f"{_mm(inside)} in the rotations"
        elif reference == "none" and n != BASELINE and laser_df is not None:
            apart = _disagreement(result.estimators[n].trajectory, laser_df)
            if apart is not None:
                note = f"{_mm(apart)} RMS from the laser"
        elif reference == "circle" and obs.get(n, "").startswith("odometry only"):
            note = "the circle cannot see its drift"
        elif reference != "none" and err is None:
            note = f"no figure on the {reference}"
        rows.append(EstimatorVerdict(n, err, ratio, obs.get(n, "unknown"), note, apart))

    warnings: list[str] = []
    if BASELINE not in result.estimators:
        warnings.append(f"no {BASELINE} estimate: nothing to set the errors beside "
                        f"(evaluate with -e {BASELINE} too)")
    elif reference != "none" and laser_err is None:
        warnings.append(f"no {BASELINE} figure on the {reference}: no ratio to the laser")
    if circle and truth_rot:
        w = _rank_warning(circle, truth_rot)
        if w is not None:
            warnings.append(w)
    paper = _paper_line(circle) if is_paper_experiment(result) else None
    no_ref = None
    if reference == "none":
        no_ref = f"{_no_reference_reason(result)} {nav_quality_text(q)}"
    return Verdict(result.name, reference, reference_text, tuple(rows), paper,
                   tuple(warnings), tuple(paths), no_ref)


def verdict_dict(v: Verdict) -> JSONObject:
    """The verdict as a JSON-ready dict (the ``verdict`` key of the evaluation document):
    the fields of :class:`Verdict`, ``estimators`` a list of dicts (``error_m`` and
    ``disagreement_m`` in m), plus ``lines``: :func:`format_verdict`'s lines."""
    d: JSONObject = asdict(v)
    d["estimators"] = [asdict(e) for e in v.estimators]
    d["warnings"] = [*v.warnings]
    d["paths"] = [*v.paths]
    d["lines"] = [*format_verdict(v)]
    return d


# ----------------------------------------------------------------------------- formatting


def _fit(line: str, width: int) -> str:
    """``line`` cut to ``width`` columns (an ellipsis marks the cut)."""
    return line if len(line) <= width else line[: max(width - 1, 0)] + "…"


def _brace(names: Sequence[str]) -> list[str]:
    """File names grouped by stem: table1.md, table1.csv -> table1.{md,csv}."""
    stems: dict[str, list[str]] = {}
    for name in names:
        stem, dot, ext = name.rpartition(".")
        key = stem if dot else name
        stems.setdefault(key, []).append(ext if dot else "")
    out = []
    for stem, exts in stems.items():
        if len(exts) == 1:
            out.append(f"{stem}.{exts[0]}" if exts[0] else stem)
        else:
            out.append(f"{stem}.{{{','.join(exts)}}}")
    return out


def paths_line(paths: Sequence[str], width: int = WIDTH) -> str:
    """One line naming the files written (report.html first, the rest beside it grouped by
    name); with none, how to get them."""
    import posixpath

    if not paths:
        return _fit("Nothing written: -o DIR writes report.html and table1.{md,csv,tex,json}",
                    width)
    first = paths[0]
    folder = posixpath.dirname(first.replace("\\", "/"))
    beside, elsewhere, pngs = [], [], 0
    for p in paths[1:]:
        d, name = posixpath.split(p.replace("\\", "/"))
        if d == folder:
            if name.endswith(".png"):
                pngs += 1
            else:
                beside.append(name)
        else:
            elsewhere.append(p)
    rest = _brace(beside) + ([f"{pngs} PNG figures"] if pngs else []) + elsewhere
    head = "Report: " if first.endswith("report.html") else "Wrote: "
    line = head + first + (f"; beside it {', '.join(rest)}" if rest else "")
    if len(line) > width:  # the report's path matters most
        line = head + first + ("; tables beside it" if rest else "")
    return _fit(line, width)


def _estimator_line(e: EstimatorVerdict, name_w: int, fig_w: int, width: int) -> str:
    if e.error_m is not None:
        figure = f"{e.error_m * 1e3:.1f} mm".rjust(fig_w)
        ratio = (f"{e.ratio_to_laser:.2f} x the laser" if e.ratio_to_laser is not None
                 else "(no laser)")
        head = f"  {e.name:<{name_w}}  {figure}  {ratio:<16}  "
        tail = e.observations + (f"; {e.note}" if e.note else "")
    else:
        head = f"  {e.name:<{name_w}}  "
        tail = (f"{e.note}; " if e.note else "") + e.observations
    line = head + tail
    if len(line) > width and e.note and e.error_m is not None:
        # the note matters more than a parenthesis of the observations (the other lines of
        # the verdict still carry it): "NAV200 scans (the paper's setup)" -> "NAV200 scans"
        short = re.sub(r" \([^)]*\)", "", e.observations)
        line = head + short + f"; {e.note}"
        if len(line) > width:
            line = head + e.observations
    return _fit(line, width)


def _wrap(text: str, width: int, indent: str = "  ") -> list[str]:
    """``text`` in lines of at most ``width`` columns, each after ``indent``; a line of
    clauses breaks after a "; " first."""
    if len(indent + text) <= width:
        return [indent + text]
    head, sep, rest = text.partition("; ")
    if sep and len(indent + head + ";") <= width and len(indent * 2 + rest) <= width:
        return [indent + head + ";", indent * 2 + rest]
    return [indent + w for w in textwrap.wrap(text, width=width - len(indent),
                                               break_on_hyphens=False)]


def _compact(rows: Sequence[EstimatorVerdict], lines: int, width: int) -> list[str]:
    """Estimators several to a line when one line each does not fit the budget."""
    items = []
    for e in rows:
        if e.error_m is not None:
            r = f" {e.ratio_to_laser:.2f}x" if e.ratio_to_laser is not None else ""
            items.append(f"{e.name} {e.error_m * 1e3:.1f} mm{r}")
        elif e.disagreement_m is not None:
            items.append(f"{e.name} {e.disagreement_m * 1e3:.1f} mm from laser")
        else:
            items.append(e.name)
    wrapped: list[str] = []
    for item in items:  # greedily, never breaking an item
        if wrapped and len(wrapped[-1]) + 2 + len(item) <= width - 2:
            wrapped[-1] += "; " + item
        else:
            wrapped.append(item)
    if len(wrapped) > lines:
        wrapped = wrapped[:lines]
        wrapped[-1] = _fit(wrapped[-1] + " …(see the report)", width - 2)
    return ["  " + w for w in wrapped]


def format_verdict(v: Verdict, width: int = WIDTH, *, show_paths: bool = True) -> list[str]:
    """The verdict as at most :data:`MAX_LINES` lines of at most ``width`` columns: a header
    naming the log and the reference, one line per estimator (its error in mm, as a multiple
    of the laser's, and what it observed), the paper's figures on the paper's experiment,
    the warnings, without a reference why and the NAV's record, and the files written
    (``show_paths`` False leaves that line out, for all but the last of several logs)."""
    width = max(width, 40)
    if v.reference == "none":
        header = f"Verdict on {v.log}: no reference, so no figure of accuracy"
    else:
        header = f"Verdict on {v.log}: {v.reference_text}; lower is better"
        if len(header) > width:
            header = f"Verdict on {v.log} against the {v.reference}; lower is better"
    tail: list[str] = []
    if v.no_reference_text:  # a sentence a line where it fits
        text: list[str] = []
        for sentence in re.split(r"(?<=\.) ", v.no_reference_text):
            text += _wrap(sentence, width)
        tail += text[:3]
    if v.paper:
        tail += _wrap(v.paper, width)[:2]
    warns = [f"Warning: {w}" for w in v.warnings]
    if len(warns) > 2:
        warns = [*warns[:1], f"(+{len(warns) - 1} more warnings: the JSON document's "
                             "'verdict')"]
    for w in warns:
        tail += _wrap(w, width)[:2]
    if show_paths:
        tail.append("  " + paths_line(v.paths, width - 2))
    budget = MAX_LINES - 1 - len(tail)
    name_w = max([8, *(len(e.name) for e in v.estimators)])
    fig_w = max([7, *(len(f"{e.error_m * 1e3:.1f} mm") for e in v.estimators
                      if e.error_m is not None)])
    if len(v.estimators) <= budget and name_w <= 24:
        body = [_estimator_line(e, name_w, fig_w, width) for e in v.estimators]
    else:
        body = _compact(v.estimators, max(budget, 1), width)
    lines = [header, *body, *tail][:MAX_LINES]
    return [_fit(line, width) for line in lines]


def summary_line(verdicts: Sequence[Verdict], width: int = WIDTH) -> str:
    """One line over several logs: how many were scored on which reference, and per estimator
    the median over the logs of its error as a multiple of the laser's (lower is better), best
    first; estimators that do not fit ``width`` columns are counted at the end."""
    n = len(verdicts)
    refs: dict[str, int] = {}
    for v in verdicts:
        refs[v.reference] = refs.get(v.reference, 0) + 1
    where = ", ".join(f"{k} {refs[k]}" for k in ("truth", "circle", "none") if k in refs)
    ratios: dict[str, list[float]] = {}
    for v in verdicts:
        for e in v.estimators:
            if e.ratio_to_laser is not None and e.name != BASELINE:
                ratios.setdefault(e.name, []).append(e.ratio_to_laser)
    head = f"{n} logs ({where})"
    if not ratios:
        return _fit(f"{head}: no estimator has an error to set beside the laser's", width)

    def median(xs: list[float]) -> float:
        s = sorted(xs)
        m = len(s) // 2
        return s[m] if len(s) % 2 else 0.5 * (s[m - 1] + s[m])

    order = sorted(ratios, key=lambda k: (median(ratios[k]), k))
    parts = [f"{k} {median(ratios[k]):.2f}" for k in order]
    for keep in range(len(parts), 0, -1):
        for lead in (f"{head}; median x the laser, lower is better: ",
                     f"{head}; median x the laser: "):
            more = len(parts) - keep
            line = lead + ", ".join(parts[:keep]) + (f", +{more} more" if more else "")
            if len(line) <= width:
                return line
    return _fit(f"{head}; median x the laser: " + ", ".join(parts), width)
