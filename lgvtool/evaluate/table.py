"""Table 1 of the paper, extended: assembly from evaluations and Markdown/CSV/LaTeX writers.

The paper's layout is ``Number | laser RMSE | laser variance | filter RMSE | filter variance``
with one row per rotation and an Average row. lgvtool keeps it and adds one column pair per
estimator. Over several logs, the aggregated table lists every rotation of every log (with a
Log column) and averages over all of them.

A summary table follows Table 1: per estimator the average RMSE, variance, bias and largest
|error| on the circle, the improvement over ``laser``, and, where the log has ground truth, the
true position error beside it. Figures are in mm, mm^2 and degrees (the edges of lgvtool).

On the terminal (:func:`to_text`) both tables fit :data:`TEXT_WIDTH` columns: short headers
under each estimator's (or figure group's) name with a unit line, further estimators in a
block below; ``wide`` gives the spelled-out headers of the files, one line per row.
"""

from __future__ import annotations

import csv
import functools
import io
import math
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from lgvtool.evaluate.evaluation import BASELINE, EvaluationResult
from lgvtool.evaluate.metrics import (
    RadialStats,
    TruthStats,
    average_stats,
    improvement,
    truth_stats,
)

MM = 1e3


@dataclass(frozen=True)
class TableRow:
    """One rotation of one log: its radial statistics per estimator, and with ground truth the
    RMSE of the true position error per estimator (m)."""

    log: str
    rotation: int
    number: int
    start: float
    end: float
    stats: dict[str, RadialStats]
    truth_rmse: dict[str, float] = field(default_factory=dict)


@dataclass(frozen=True)
class Table1:
    """Table 1 over one or more logs."""

    estimators: tuple[str, ...]
    rows: tuple[TableRow, ...]
    average: dict[str, RadialStats]
    improvement: dict[str, float]
    truth: dict[str, TruthStats]
    logs: tuple[str, ...]
    partial: int
    """Partial rotations left out, over all logs."""
    circle: bool = True
    """Whether some log has a reference circle (even without a complete rotation)."""
    centre_offset: dict[str, float] = field(default_factory=dict)
    """Largest distance of an estimator's circle centre from the reference centre, over the
    logs, m."""
    truth_in_rotations: dict[str, float] = field(default_factory=dict)
    """RMSE of the true position error over the samples of the complete rotations, m: the
    same samples as the circle figures."""
    observations: dict[str, str] = field(default_factory=dict)
    """What each estimator updated with (the verdict's words, e.g. "NAV200 scans (the paper's
    setup)"), over the logs; "mixed" where the logs differ."""

    @property
    def setup_note(self) -> str | None:
        """One line saying which observations the figures come from when a log is in the
        paper's setup (reflector scans a NAV200 recording does not hold), else None."""
        paper = [n for n in self.estimators if "the paper's setup" in self.observations.get(n, "")]
        if not paper:
            return None
        return (f"Observations: {', '.join(paper)} weighed the NAV200's reflector scans of "
                "the paper's setup, which no NAV200 recording holds.")

    @property
    def multi_log(self) -> bool:
        """True when the table spans several logs."""
        return len(self.logs) > 1

    @property
    def has_truth(self) -> bool:
        """True when some estimator has ground-truth figures."""
        return bool(self.truth)


def estimator_order(names: Sequence[str]) -> tuple[str, ...]:
    """``laser`` first (the paper's baseline), then the others in the given order."""
    uniq = list(dict.fromkeys(names))
    return tuple(([BASELINE] if BASELINE in uniq else []) + [n for n in uniq if n != BASELINE])


def build_table(results: Sequence[EvaluationResult]) -> Table1:
    """Table 1 over ``results`` (one per log); the Average row and the ground-truth figures
    are over all rotations and samples of all logs."""
    names = estimator_order([n for r in results for n in r.estimators])
    rows: list[TableRow] = []
    for res in results:
        by_number: dict[int, TableRow] = {}
        for n in names:
            ev = res.estimators.get(n)
            if ev is None:
                continue
            for rot in ev.rotations:
                row = by_number.get(rot.number)
                if row is None:
                    row = TableRow(res.name, rot.number, 0, rot.start, rot.end, {}, {})
                    by_number[rot.number] = row
                row.stats[n] = rot.stats
                if rot.truth_rmse is not None:
                    row.truth_rmse[n] = rot.truth_rmse
        rows.extend(by_number[k] for k in sorted(by_number))
    rows = [TableRow(r.log, r.rotation, i + 1, r.start, r.end, r.stats, r.truth_rmse)
            for i, r in enumerate(rows)]
    average = {n: average_stats([r.stats[n] for r in rows if n in r.stats]) for n in names
               if any(n in r.stats for r in rows)}
    impr: dict[str, float] = {}
    if BASELINE in average:
        impr = {n: improvement(s.rmse, average[BASELINE].rmse) for n, s in average.items()}
    truth: dict[str, TruthStats] = {}
    truth_rot: dict[str, float] = {}
    for n in names:
        pes, hes, inside = [], [], []
        for res in results:
            ev = res.estimators.get(n)
            if ev is None or ev.truth_error is None:
                continue
            pes.append(ev.truth_error["position_error"].to_numpy())
            hes.append(ev.truth_error["heading_error"].to_numpy())
            inside.append(res.laps.index(ev.truth_error["t"]) > 0)
        if not pes:
            continue
        ts = truth_stats(np.concatenate(pes), np.concatenate(hes))
        if ts.samples:
            truth[n] = ts
        pe_in = np.concatenate(pes)[np.concatenate(inside)]
        if pe_in.size:
            truth_rot[n] = float(np.sqrt(np.mean(pe_in * pe_in)))
    offsets: dict[str, float] = {}
    for res in results:
        for n, ev in res.estimators.items():
            if ev.centre_offset is not None:
                offsets[n] = max(offsets.get(n, 0.0), ev.centre_offset)
    observed: dict[str, str] = {}
    for res in results:
        for n, what in (getattr(res, "observations", None) or {}).items():
            observed[n] = what if observed.get(n, what) == what else "mixed"
    return Table1(names, tuple(rows), average, impr, truth,
                  logs=tuple(r.name for r in results),
                  partial=sum(r.laps.partial for r in results),
                  circle=any(r.reference.circle_drive for r in results),
                  centre_offset=offsets, truth_in_rotations=truth_rot, observations=observed)


# --------------------------------------------------------------------------- formatting


def _f(value: float | None, digits: int = 2) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    return f"{value:.{digits}f}"


def table1_cells(table: Table1, digits: int = 2) -> tuple[list[str], list[list[str]]]:
    """Header and body cells of Table 1 (mm, mm^2), the Average row last."""
    head = (["Log"] if table.multi_log else []) + ["Number"]
    for n in table.estimators:
        head += [f"{n} RMSE (mm)", f"{n} variance (mm²)"]
    body: list[list[str]] = []
    for r in table.rows:
        cells = ([r.log] if table.multi_log else []) + [str(r.number)]
        for n in table.estimators:
            s = r.stats.get(n)
            cells += [_f(s.rmse * MM if s else None, digits),
                      _f(s.variance * MM * MM if s else None, digits)]
        body.append(cells)
    avg = ([""] if table.multi_log else []) + ["Average"]
    for n in table.estimators:
        s = table.average.get(n)
        avg += [_f(s.rmse * MM if s else None, digits),
                _f(s.variance * MM * MM if s else None, digits)]
    if table.rows:
        body.append(avg)
    return head, body


def summary_cells(table: Table1, digits: int = 2) -> tuple[list[str], list[list[str]]]:
    """Header and body cells of the summary table: one row per estimator (mm, mm^2, %, deg).
    Circle columns appear when some rotation was scored, the improvement column when
    ``laser`` was, the ground-truth columns when some estimator has them."""
    circle = bool(table.average)
    versus = circle and BASELINE in table.average
    head = ["Estimator"]
    if circle:
        head += ["RMSE (mm)", "variance (mm²)", "bias (mm)", "max |error| (mm)",
                 "centre offset (mm)"]
    if versus:
        head.append(f"less error than {BASELINE} (%)")
    in_rot = circle and bool(table.truth_in_rotations)
    if in_rot:
        head.append("true RMSE in rotations (mm)")
    if table.has_truth:
        head += ["true RMSE (mm)", "true mean (mm)", "true p95 (mm)", "true max (mm)",
                 "heading RMSE (°)"]
    body = []
    for n in table.estimators:
        cells = [n]
        s = table.average.get(n)
        if circle:
            cells += [_f(s.rmse * MM if s else None, digits),
                      _f(s.variance * MM * MM if s else None, digits),
                      _f(s.mean * MM if s else None, digits),
                      _f(s.max_abs * MM if s else None, digits)]
            off = table.centre_offset.get(n)
            cells.append(_f(off * MM if off is not None else None, digits))
        if versus:
            cells.append(_f(table.improvement.get(n), 1))
        if in_rot:
            tr = table.truth_in_rotations.get(n)
            cells.append(_f(tr * MM if tr is not None else None, digits))
        if table.has_truth:
            t = table.truth.get(n)
            cells += [_f(t.position_rmse * MM if t else None, digits),
                      _f(t.position_mean * MM if t else None, digits),
                      _f(t.position_p95 * MM if t else None, digits),
                      _f(t.position_max * MM if t else None, digits),
                      _f(math.degrees(t.heading_rmse) if t else None, 3)]
        body.append(cells)
    return head, body


def no_rows_note(table: Table1) -> str:
    """Why Table 1 has no rows."""
    if table.circle:
        return "No complete rotation: no circle metrics."
    return "No reference circle: ground-truth metrics only."


def _md(head: list[str], body: list[list[str]]) -> str:
    align = ["---" if i == 0 or h == "Log" else "---:" for i, h in enumerate(head)]
    lines = ["| " + " | ".join(h.replace("|", "\\|") for h in head) + " |",
             "|" + "|".join(align) + "|"]
    lines += ["| " + " | ".join(c.replace("|", "\\|") for c in row) + " |" for row in body]
    return "\n".join(lines)


def to_markdown(table: Table1, *, title: str = "Table 1", digits: int = 2) -> str:
    """Table 1 and the summary table as Markdown (mm, mm^2, degrees)."""
    parts = [f"### {title}: RMSE and variance of the radial error per rotation", ""]
    if table.setup_note:
        parts += [table.setup_note, ""]
    if table.rows:
        parts.append(_md(*table1_cells(table, digits)))
    else:
        parts.append(no_rows_note(table))
    if table.circle:
        parts += ["", f"Partial rotations left out: {table.partial}."]
    parts += ["", "### Summary", ""]
    parts.append(_md(*summary_cells(table, digits)))
    return "\n".join(parts) + "\n"


def _truth_average(table: Table1, name: str) -> float | None:
    vals = [r.truth_rmse[name] for r in table.rows if name in r.truth_rmse]
    return float(np.mean(vals)) if vals else None


def to_csv(table: Table1, *, per_log: Sequence[Table1] = ()) -> str:
    """One row per rotation, then the Average row: log, number, rotation, start_s, end_s and
    per estimator ``<name>_rmse_mm``, ``_variance_mm2``, ``_mean_mm``, ``_max_abs_mm`` and, with
    ground truth, ``_truth_rmse_mm`` (true position RMSE); full precision.

    With ``per_log`` (the tables of the single logs behind an aggregated ``table``), each log's
    rotations and Average row come first, then the Average over all logs (log ``all``).
    """
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    head = ["log", "number", "rotation", "start_s", "end_s"]
    for n in table.estimators:
        head += [f"{n}_rmse_mm", f"{n}_variance_mm2", f"{n}_mean_mm", f"{n}_max_abs_mm"]
        if table.has_truth:
            head.append(f"{n}_truth_rmse_mm")
    w.writerow(head)

    def stats_cells(s: RadialStats | None, truth: float | None) -> list[str]:
        vals = ([s.rmse * MM, s.variance * MM * MM, s.mean * MM, s.max_abs * MM]
                if s else [math.nan] * 4)
        if table.has_truth:
            vals.append(truth * MM if truth is not None else math.nan)
        return ["" if not math.isfinite(v) else repr(float(v)) for v in vals]

    def write(t: Table1, label: str) -> None:
        for r in t.rows:
            cells = [r.log, str(r.number), str(r.rotation), repr(r.start), repr(r.end)]
            for n in table.estimators:
                cells += stats_cells(r.stats.get(n), r.truth_rmse.get(n))
            w.writerow(cells)
        if t.rows:
            cells = [label, "Average", "", "", ""]
            for n in table.estimators:
                cells += stats_cells(t.average.get(n), _truth_average(t, n))
            w.writerow(cells)

    if per_log:
        for t in per_log:
            write(t, t.logs[0])
        if table.rows:
            cells = ["all", "Average", "", "", ""]
            for n in table.estimators:
                cells += stats_cells(table.average.get(n), _truth_average(table, n))
            w.writerow(cells)
    else:
        write(table, "all" if table.multi_log else table.logs[0])
    return out.getvalue()


_TEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "_": r"\_", "#": r"\#",
        "$": r"\$", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
        "^": r"\textasciicircum{}"}


def _tex_escape(s: str) -> str:
    return "".join(_TEX.get(c, c) for c in s)


def to_latex(table: Table1, *, caption: str = "Comparison of variance and RMSE",
             digits: int = 4) -> str:
    """Table 1 as a LaTeX ``table`` (booktabs), the paper's two-row header with one column pair
    per estimator; mm and mm^2."""
    lead = 2 if table.multi_log else 1
    cols = "l" * lead + "rr" * len(table.estimators)
    top = (["Log"] if table.multi_log else []) + ["Number"]
    head1 = " & ".join([""] * lead + [rf"\multicolumn{{2}}{{c}}{{{_tex_escape(n)}}}"
                                      for n in table.estimators])
    head2 = " & ".join([_tex_escape(t) for t in top] +
                       ["RMSE", r"Variance ($\sigma^2$)"] * len(table.estimators))
    if table.setup_note:
        caption += " (the paper's setup: NAV200 reflector scans)"
    lines = [r"\begin{table}[ht]", r"\centering", rf"\caption{{{_tex_escape(caption)}}}",
             rf"\begin{{tabular}}{{{cols}}}", r"\toprule", head1 + r" \\"]
    rules = " ".join(rf"\cmidrule(lr){{{lead + 1 + 2 * i}-{lead + 2 + 2 * i}}}"
                     for i in range(len(table.estimators)))
    lines += [rules, head2 + r" \\", r"\midrule"]
    _, body = table1_cells(table, digits)
    for k, row in enumerate(body):
        if table.rows and k == len(body) - 1:
            lines.append(r"\midrule")
            row = [*row]
            row[lead - 1] = "Average (mm)"
        lines.append(" & ".join(_tex_escape(c) for c in row) + r" \\")
    lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
    return "\n".join(lines) + "\n"


TEXT_WIDTH = 120
"""Widest line of the default terminal tables, columns (``--wide``: no limit)."""


@dataclass(frozen=True)
class _Col:
    """One column of a terminal table: its header, unit line and cells."""

    head: str
    unit: str
    cells: list[str]
    left: bool = False
    least: int = 0

    @property
    def width(self) -> int:
        return max([self.least, len(self.head), len(self.unit), *(len(c) for c in self.cells)])

    def cell(self, text: str) -> str:
        return text.ljust(self.width) if self.left else text.rjust(self.width)

    def row(self, i: int) -> str:
        return self.cell(self.cells[i])


def _widened(cols: list[_Col], least: int, sep: int) -> list[_Col]:
    """``cols`` with the first widened so that together they span ``least`` columns."""
    span = sum(c.width for c in cols) + sep * (len(cols) - 1)
    if span >= least or not cols:
        return cols
    first = cols[0]
    return [replace(first, least=first.width + least - span), *cols[1:]]


def _text_blocks(keys: list[_Col], groups: list[tuple[str, list[_Col]]], width: int) -> str:
    """Aligned columns: the ``keys`` (left), then the ``groups`` of columns, each under its
    label; when they do not fit ``width`` columns, the groups continue in further blocks that
    repeat the keys. A unit line follows the header when some column has a unit."""
    sep, gsep = "  ", "   "
    groups = [(label, _widened(cols, len(label), len(sep))) for label, cols in groups]
    key_w = sum(c.width for c in keys) + len(sep) * (len(keys) - 1)
    chunks: list[list[tuple[str, list[_Col]]]] = [[]]
    used = key_w
    for label, cols in groups:
        w = len(gsep) + sum(c.width for c in cols) + len(sep) * (len(cols) - 1)
        if chunks[-1] and used + w > width:
            chunks.append([])
            used = key_w
        chunks[-1].append((label, cols))
        used += w
    rows = len(keys[0].cells)
    units = any(c.unit for c in keys) or any(c.unit for _, cols in groups for c in cols)
    out = []

    def line(chunk: list[tuple[str, list[_Col]]], pick: Callable[[_Col], str]) -> str:
        parts = [sep.join(pick(c) for c in keys)]
        parts += [sep.join(pick(c) for c in cols) for _, cols in chunk]
        return gsep.join(parts).rstrip()

    for chunk in chunks:
        labels = [" " * key_w]
        for label, cols in chunk:
            span = sum(c.width for c in cols) + len(sep) * (len(cols) - 1)
            labels.append(label[:span].ljust(span))
        text = []
        if any(label for label, _ in chunk):
            text.append(gsep.join(labels).rstrip())
        text.append(line(chunk, lambda c: c.cell(c.head)))
        if units:
            text.append(line(chunk, lambda c: c.cell(c.unit)))
        text.append(line(chunk, lambda c: "-" * c.width))
        for i in range(rows):
            text.append(line(chunk, functools.partial(_Col.row, i=i)))
        out.append("\n".join(text))
    return "\n\n".join(out)


def _table1_text(table: Table1, digits: int, width: int) -> str:
    """Table 1 for the terminal: a Rotation column (and Log over several logs), then per
    estimator the pair RMSE (mm), sigma^2 (mm^2) under its name."""
    keys = []
    if table.multi_log:
        keys.append(_Col("Log", "", [*(r.log for r in table.rows), ""], left=True))
    rot = [str(r.rotation if table.multi_log else r.number) for r in table.rows]
    keys.append(_Col("Rotation", "", [*rot, "Average"], left=True))
    groups = []
    for n in table.estimators:
        rmse, var = [], []
        for s in [r.stats.get(n) for r in table.rows] + [table.average.get(n)]:
            rmse.append(_f(s.rmse * MM if s else None, digits))
            var.append(_f(s.variance * MM * MM if s else None, digits))
        groups.append((n, [_Col("RMSE", "mm", rmse), _Col("σ²", "mm²", var)]))
    title = ("Table 1: signed radial error about the reference circle per complete rotation "
             "(lower is better)")
    return title + "\n" + _text_blocks(keys, groups, width)


def _summary_text(table: Table1, digits: int, width: int) -> str:
    """The summary for the terminal: per estimator the circle figures (Average row) and the
    ground-truth figures, short headers under a group label, units below them."""
    circle = bool(table.average)
    versus = circle and BASELINE in table.average
    names = list(table.estimators)
    keys = [_Col("Estimator", "", names, left=True)]
    groups: list[tuple[str, list[_Col]]] = []

    def col(head: str, unit: str, values: list[float | None], d: int = digits) -> _Col:
        return _Col(head, unit, [_f(v, d) for v in values])

    if circle:
        avg = [table.average.get(n) for n in names]
        cols = [col("RMSE", "mm", [s.rmse * MM if s else None for s in avg]),
                col("σ²", "mm²", [s.variance * MM * MM if s else None for s in avg]),
                col("bias", "mm", [s.mean * MM if s else None for s in avg]),
                col("max|e|", "mm", [s.max_abs * MM if s else None for s in avg]),
                col("centre", "mm", [table.centre_offset[n] * MM if n in table.centre_offset
                                     else None for n in names])]
        if versus:
            base = table.average[BASELINE].rmse
            cols.append(col("x laser", "", [s.rmse / base if s and base > 0 else None
                                             for s in avg]))
        groups.append(("circle (Average of the rotations)", cols))
    if table.has_truth:
        tr = [table.truth.get(n) for n in names]
        cols = [col("RMSE", "mm", [t.position_rmse * MM if t else None for t in tr])]
        if circle and table.truth_in_rotations:
            cols.append(col("in rot.", "mm", [table.truth_in_rotations[n] * MM
                                              if n in table.truth_in_rotations else None
                                              for n in names]))
        cols += [col("mean", "mm", [t.position_mean * MM if t else None for t in tr]),
                 col("p95", "mm", [t.position_p95 * MM if t else None for t in tr]),
                 col("max", "mm", [t.position_max * MM if t else None for t in tr]),
                 col("heading", "°", [math.degrees(t.heading_rmse) if t else None
                                      for t in tr], 3)]
        groups.append(("ground truth (whole drive)", cols))
    if not groups:
        return "No circle and no ground-truth figures: see the verdict."
    title = "Summary per estimator (lower is better; columns: lgvtool evaluate --help)"
    return title + "\n" + _text_blocks(keys, groups, width)


def to_text(table: Table1, *, digits: int = 2, wide: bool = False,
            width: int = TEXT_WIDTH) -> str:
    """Table 1 and the summary as aligned plain text for the terminal: short headers under
    each estimator's or figure group's name, with a unit line, at most ``width`` columns
    (further estimators continue below); ``wide``: one line per row with every header
    spelled out (mm, mm^2, degrees)."""
    note = [_wrap_note(table.setup_note, width)] if table.setup_note else []
    if not wide:
        parts = [*note, _table1_text(table, digits, width) if table.rows
                 else no_rows_note(table)]
        if table.circle:
            parts.append(f"Partial rotations left out: {table.partial}.")
        parts.append(_summary_text(table, digits, width))
        return "\n\n".join(parts) + "\n"

    def block(head: list[str], body: list[list[str]]) -> str:
        widths = [max(len(c) for c in col) for col in zip(head, *body, strict=False)]
        fmt = [f"{{:<{w}}}" if i == 0 or h == "Log" else f"{{:>{w}}}"
               for i, (h, w) in enumerate(zip(head, widths, strict=True))]
        lines = ["  ".join(f.format(c) for f, c in zip(fmt, head, strict=True))]
        lines.append("  ".join("-" * w for w in widths))
        lines += ["  ".join(f.format(c) for f, c in zip(fmt, row, strict=True)) for row in body]
        return "\n".join(lines)

    parts = list(note)
    if table.rows:
        parts.append(block(*table1_cells(table, digits)))
    else:
        parts.append(no_rows_note(table))
    if table.circle:
        parts.append(f"Partial rotations left out: {table.partial}.")
    parts.append(block(*summary_cells(table, digits)))
    return "\n\n".join(parts) + "\n"


def _wrap_note(text: str, width: int) -> str:
    """``text`` in lines of at most ``width`` columns."""
    return "\n".join(textwrap.wrap(text, width))


FORMATS = ("text", "md", "csv", "tex")
"""Table formats of :func:`render_tables`."""


def render_tables(results: Sequence[EvaluationResult], fmt: str = "text", *,
                  wide: bool = False) -> str:
    """The tables of one or more logs in ``fmt`` (one of :data:`FORMATS`). Several logs give
    the aggregated table first, then one per log (CSV: one table with a log column).
    ``wide``: text tables with every header spelled out, whatever their width
    (:func:`to_text`)."""
    if fmt not in FORMATS:
        raise ValueError(f"unknown table format {fmt!r}")
    per = [build_table([r]) for r in results]
    if len(results) == 1:
        t = per[0]
        if fmt == "md":
            return to_markdown(t)
        if fmt == "csv":
            return to_csv(t)
        return to_latex(t) if fmt == "tex" else to_text(t, wide=wide)
    agg = build_table(results)
    if fmt == "csv":
        return to_csv(agg, per_log=per)
    sections = [("All logs", agg)] + [(r.name, t) for r, t in zip(results, per, strict=True)]
    parts = []
    for name, t in sections:
        if fmt == "md":
            parts.append(f"## {name}\n\n" + to_markdown(t))
        elif fmt == "tex":
            parts.append(f"% {name}\n" + to_latex(t, caption=f"Comparison of variance and RMSE: "
                                                            f"{name}"))
        else:
            parts.append(f"== {name} ==\n\n" + to_text(t, wide=wide))
    return "\n".join(parts)
