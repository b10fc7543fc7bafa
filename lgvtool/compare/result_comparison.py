"""Two results of one site compared KPI by KPI (``lgvtool compare A B``), pure.

A result is an ``audit.json`` (:func:`lgvtool.audit.audit_document.audit_document`) or an
evaluation document (``table1.json``, :func:`lgvtool.evaluate.document.build_document`). A is
the baseline, B the run judged against it. Every KPI is declared once, in :data:`AUDIT_KPIS`,
:data:`SEGMENT_KPIS` and :data:`ESTIMATOR_KPIS`, with its unit and whether lower or higher is
better; a KPI is named by its path in the document, as ``evaluate --max`` names it
(``pf.truth.position_rmse_m``, ``coverage.gdop.median``).

The gate is the one of ``evaluate --baseline --tolerance`` (:mod:`lgvtool.evaluate.regress`:
its tolerance, its :class:`~lgvtool.evaluate.regress.Check`, its wording): a KPI fails when B
is worse than A by more than the tolerance (a fraction of A's value) plus the KPI's slack (an
absolute amount in its unit that absorbs the rounding of figures near zero), or when A has it
and B no longer does.

Two audits are of one site when their layouts (``layout``: reflector id, x, y in m) hold the
same ids, each within a stated distance (m) of the other's; an evaluation document holds no
layout, so two of them are compared without that check (a note says so).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal

from lgvtool.declared import setting
from lgvtool.errors import InputError
from lgvtool.evaluate.regress import BASELINE_FIGURES, Check
from lgvtool.json_types import JSON, JSONObject, JSONRecord

__all__ = ["AUDIT_KPIS", "ESTIMATOR_KPIS", "SEGMENT_KPIS", "CompareSettings", "Comparison", "Kpi", "KpiRow",
           "compare_documents", "comparison_dict", "kind_of", "names_of", "site_check",
           "table_lines"]

Better = Literal["lower", "higher"]
Kind = Literal["audit", "evaluation"]


@dataclass(frozen=True)
class CompareSettings:
    """How ``compare`` tells two results to be of one site."""

    site_tolerance_m: float = setting(
        0.05,
        "Two layouts are of one site when they hold the same reflector ids and each reflector "
        "stands within this distance of its namesake, m (a surveyed layout is good to a few "
        "cm; a moved wall or another hall is metres off).",
        unit="m", minimum=0.0, maximum=100.0)


@dataclass(frozen=True)
class Kpi:
    """One KPI: its path in the document (below an estimator for :data:`ESTIMATOR_KPIS`), its
    unit, which way is better, and its slack (in its unit)."""

    path: str
    unit: str
    better: Better
    slack: float = 0.0
    """Absolute worsening always allowed, in :attr:`unit` (the rounding of the document)."""


def _error(group: str, figure: str, unit: str, default: float) -> Kpi:
    """An error figure of an estimator (lower is better), with the slack ``evaluate
    --baseline`` gives it where it has one (:data:`lgvtool.evaluate.regress.BASELINE_FIGURES`)."""
    return Kpi(f"{group}.{figure}", unit, "lower", BASELINE_FIGURES.get((group, figure), default))


ESTIMATOR_KPIS: tuple[Kpi, ...] = (
    _error("circle", "rmse_mm", "mm", 1e-3),
    _error("circle", "variance_mm2", "mm^2", 1e-3),
    _error("circle", "max_abs_mm", "mm", 1e-3),
    Kpi("circle.improvement_pct", "%", "higher", 1e-3),
    _error("circle", "centre_offset_m", "m", 1e-6),
    _error("truth", "position_rmse_m", "m", 1e-6),
    _error("truth", "position_mean_m", "m", 1e-6),
    _error("truth", "position_p95_m", "m", 1e-6),
    _error("truth", "position_max_m", "m", 1e-6),
    _error("truth", "heading_rmse_deg", "deg", 1e-4),
    _error("truth", "position_rmse_rotations_m", "m", 1e-6),
)
"""The figures of each estimator of an evaluation document (``estimators.<name>``), named
``<name>.<path>``: the circle's (mm, mm^2; the improvement over the laser in %; the fitted
centre's offset in m) and the truth's (m, degrees). The signed mean radial error is left out:
neither way is better."""

AUDIT_KPIS: tuple[Kpi, ...] = (
    Kpi("counts.ok", "reflectors", "higher"),
    Kpi("counts.missing", "reflectors", "lower"),
    Kpi("counts.moved", "reflectors", "lower"),
    Kpi("counts.weak", "reflectors", "lower"),
    Kpi("counts.ambiguous", "reflectors", "lower"),
    Kpi("counts.unmapped", "objects", "lower"),
    Kpi("coverage.visible.min", "reflectors", "higher"),
    Kpi("coverage.visible.median", "reflectors", "higher"),
    Kpi("coverage.gdop.median", "", "lower", 1e-4),
    Kpi("coverage.gdop.p95", "", "lower", 1e-4),
    Kpi("coverage.position_sigma_m.median", "m", "lower", 1e-4),
    Kpi("coverage.position_sigma_m.p95", "m", "lower", 1e-4),
    Kpi("coverage.no_position_fraction", "", "lower", 1e-4),
    Kpi("coverage.below_min_fraction", "", "lower", 1e-4),
    Kpi("coverage.gdop_above_fraction", "", "lower", 1e-4),
    Kpi("coverage.reported_used.mean", "reflectors", "higher", 1e-3),
    Kpi("coverage.segments_total", "segments", "lower"),
    Kpi("coverage.poor_time_s", "s", "lower", 1e-3),
    Kpi("navigation.share_in_navigation", "", "higher", 1e-4),
    Kpi("navigation.dropouts", "dropouts", "lower"),
    Kpi("navigation.dropout_time_s", "s", "lower", 1e-3),
    Kpi("navigation.pose_jumps", "jumps", "lower"),
    Kpi("navigation.clock_jumps", "jumps", "lower"),
    *(k for role in ("truth", "laser", "estimator") for k in (
        Kpi(f"stations.summary.{role}.sigma_x_max_m", "m", "lower", 1e-6),
        Kpi(f"stations.summary.{role}.sigma_y_max_m", "m", "lower", 1e-6),
        Kpi(f"stations.summary.{role}.sigma_heading_max_deg", "deg", "lower", 1e-4),
        Kpi(f"stations.summary.{role}.stops_alone_sigma_x_max_m", "m", "lower", 1e-6),
        Kpi(f"stations.summary.{role}.stops_alone_sigma_y_max_m", "m", "lower", 1e-6),
        Kpi(f"stations.summary.{role}.radius95_max_m", "m", "lower", 1e-6),
        Kpi(f"stations.summary.{role}.passed", "stations", "higher"),
        Kpi(f"stations.summary.{role}.failed", "stations", "lower"))),
)
"""The site's figures in an ``audit.json``: reflectors per status and unmapped objects, the
coverage along the drive (reflectors visible, GDOP, the pose's position 1-sigma in m, the
share of poses without a position / below the minimum of reflectors / above the GDOP limit,
the reflectors the device reported using, the poor segments and their time in s) and the
navigation health over all logs (the share of time in navigation, the dropouts and their
time in s, the pose jumps, the device clock's jumps) and the stations per pose source (the
truth, the raw laser, the audit's estimator): the largest sigma x, y (m), sigma heading (deg)
and 95 % radius (m) over the stations, the largest sigma x, y (m) of the stops alone (the
source's own noise over each stop taken off), and with a stations file the stations that passed and
failed their tolerance. A KPI that neither document holds (an audit.json written before its
section existed, pass counts of stations found automatically) is left out."""


SEGMENT_KPIS: tuple[Kpi, ...] = (
    Kpi("overall.along.rms", "m", "lower", 1e-6),
    Kpi("overall.cross.rms", "m", "lower", 1e-6),
    Kpi("overall.heading.rms", "rad", "lower", 1e-7),
)
"""The error by segment of each pose source of an ``audit.json`` against its reference
(``segments.sources``), over the whole drive: the RMS along-track and cross-track error (m)
and heading error (rad). Compared per source and reference, named
``segments.<source>-vs-<reference>.<path>``: a pair that only one result holds (another
estimator, no truth) is named in a note."""


@dataclass(frozen=True)
class KpiRow:
    """One KPI of both results side by side (in its unit; None: not in that result)."""

    key: str
    unit: str
    better: Better
    a: float | None
    b: float | None
    worse_beyond_tolerance: bool

    @property
    def difference(self) -> float | None:
        """B - A, in :attr:`unit` (None unless both have it)."""
        return None if self.a is None or self.b is None else self.b - self.a

    @property
    def change_pct(self) -> float | None:
        """(B - A) / |A| in percent (None when A is zero or either is missing)."""
        d = self.difference
        return None if d is None or self.a == 0 or self.a is None else 100.0 * d / abs(self.a)

    @property
    def direction(self) -> str:
        """``better``, ``worse`` or ``same`` (equal values), ``-`` when a side lacks it."""
        d = self.difference
        if d is None:
            return "-"
        gain = -d if self.better == "lower" else d
        return "same" if gain == 0 else ("better" if gain > 0 else "worse")


@dataclass(frozen=True)
class Comparison:
    """What :func:`compare_documents` found."""

    kind: Kind
    rows: tuple[KpiRow, ...]
    checks: tuple[Check, ...]
    """The gate: failed checks one per KPI, else one passed check per group."""
    notes: tuple[str, ...]


def kind_of(doc: object, source: str) -> tuple[Kind, JSONRecord]:
    """Which result ``doc`` is, and the document itself.

    :raises InputError: (exit 2) neither an ``audit.json`` nor an evaluation document.
    """
    from lgvtool.evaluate.document import FORMAT

    if isinstance(doc, Mapping):
        if doc.get("format") == FORMAT:
            estimators = doc.get("estimators")
            if isinstance(estimators, Mapping) and all(
                    isinstance(v, Mapping) for v in estimators.values()):
                return "evaluation", doc
        elif all(k in doc for k in ("logs", "counts", "reflectors", "coverage")) \
                and isinstance(doc.get("counts"), Mapping):
            return "audit", doc
    raise InputError(f"{source}: neither an lgvtool audit.json nor an evaluation result "
                     f"(table1.json)")


def _layout(doc: JSONRecord) -> dict[str, tuple[float, float]]:
    """Reflector id -> (x, y) m of an audit's layout (``layout``, else the audited
    ``reflectors`` of an audit.json written before it carried ``layout``)."""
    items = doc.get("layout")
    if not isinstance(items, list):
        items = doc.get("reflectors")
    out: dict[str, tuple[float, float]] = {}
    for r in items if isinstance(items, list) else []:
        if isinstance(r, Mapping):
            x, y = r.get("x"), r.get("y")
            if isinstance(x, int | float) and isinstance(y, int | float):
                out[str(r.get("id"))] = (float(x), float(y))
    return out


def site_check(a: JSONRecord, b: JSONRecord, tolerance_m: float,
               names: tuple[str, str] = ("A", "B")) -> str | None:
    """Whether two audits are of one site (module doc): None when they are; a note when it
    cannot be told (a result without a layout).

    :raises InputError: (exit 2) the layouts differ: other ids, or a reflector more than
        ``tolerance_m`` (m) from its namesake.
    """
    la, lb = _layout(a), _layout(b)
    if not la or not lb:
        lacking = " and ".join(n for n, lay in zip(names, (la, lb), strict=True) if not lay)
        return f"site not checked: {lacking} holds no reflector layout"
    what = f"{names[0]} and {names[1]} are not of one site"
    only_a, only_b = sorted(set(la) - set(lb)), sorted(set(lb) - set(la))
    if only_a or only_b:
        parts = [f"ids only in {n}: {', '.join(ids[:5])}{' ...' if len(ids) > 5 else ''}"
                 for n, ids in zip(names, (only_a, only_b), strict=True) if ids]
        raise InputError(f"{what}: their layouts hold other reflectors ({'; '.join(parts)}); "
                         f"--any-site compares them anyway")
    far = max(la, key=lambda k: math.dist(la[k], lb[k]))
    gap = math.dist(la[far], lb[far])
    if gap > tolerance_m:
        raise InputError(f"{what}: reflector {far} stands {gap:.3f} m apart in their layouts "
                         f"(site tolerance {tolerance_m:g} m); --any-site compares them anyway")
    return None


def _number(node: JSON, path: str) -> float | None:
    for part in path.split("."):
        if not isinstance(node, Mapping):
            return None
        node = node.get(part)
    if isinstance(node, bool) or not isinstance(node, int | float) or not math.isfinite(node):
        return None
    return float(node)


def _worse(kpi: Kpi, a: float, b: float, tolerance: float) -> bool:
    if kpi.better == "lower":
        return b > a + tolerance * abs(a) + kpi.slack
    return b < a - tolerance * abs(a) - kpi.slack


def _groups(kind: Kind, a: JSONRecord, b: JSONRecord
            ) -> tuple[list[tuple[str, JSON, JSON, tuple[Kpi, ...]]], list[str]]:
    """(group name, A's node, B's node, its KPIs) to compare, and notes."""
    if kind == "audit":
        sa, sb = _segment_sources(a), _segment_sources(b)
        notes = [f"error by segment {n} of {which} is not in {other}"
                 for which, other, mine, theirs in (("A", "B", sa, sb), ("B", "A", sb, sa))
                 for n in mine if n not in theirs]
        return ([("audit", dict(a), dict(b), AUDIT_KPIS),
                 *((n, sa[n], sb[n], SEGMENT_KPIS) for n in sa if n in sb)], notes)
    ea, eb = a.get("estimators"), b.get("estimators")
    ea = ea if isinstance(ea, Mapping) else {}
    eb = eb if isinstance(eb, Mapping) else {}
    common = [n for n in ea if n in eb]
    if not common:
        raise InputError(f"A and B have no estimator in common (A: {', '.join(ea) or 'none'}; "
                         f"B: {', '.join(eb) or 'none'})")
    notes = [f"estimator '{n}' of A is not in B" for n in ea if n not in eb]
    notes += [f"estimator '{n}' of B is not in A" for n in eb if n not in ea]
    return [(n, ea[n], eb[n], ESTIMATOR_KPIS) for n in common], notes


def _segment_sources(doc: JSONRecord) -> dict[str, JSON]:
    """``segments.<source>-vs-<reference>`` -> that source's entry of the audit's error by
    segment (empty when the audit has none)."""
    seg = doc.get("segments")
    sources = seg.get("sources") if isinstance(seg, Mapping) else None
    out: dict[str, JSON] = {}
    for entry in sources if isinstance(sources, list) else []:
        if isinstance(entry, Mapping):
            src, ref = entry.get("source"), entry.get("reference")
            if isinstance(src, str) and isinstance(ref, str):
                out[f"segments.{src}-vs-{ref}"] = entry
    return out


def compare_documents(a: JSONRecord, b: JSONRecord, tolerance: float, *,
                      source: str = "A") -> Comparison:
    """Compare B with A (the baseline, named ``source`` in the checks' wording), each KPI
    allowed to worsen by ``tolerance`` (a fraction of A's value) plus its slack.

    :raises InputError: (exit 2) the two are not results of one kind, or two evaluations
        without an estimator in common.
    """
    kind, _ = kind_of(a, "A")
    kind_b, _ = kind_of(b, "B")
    if kind != kind_b:
        raise InputError(f"A is an {kind} result and B an {kind_b} result: compare two of one "
                         f"kind")
    groups, notes = _groups(kind, a, b)
    pct = f"{100.0 * tolerance:g}%"
    rows: list[KpiRow] = []
    checks: list[Check] = []
    for name, na, nb, kpis in groups:
        failed: list[Check] = []
        compared = 0
        worst: tuple[float, str] | None = None
        for kpi in kpis:
            va, vb = _number(na, kpi.path), _number(nb, kpi.path)
            key = kpi.path if kind == "audit" and name == "audit" else f"{name}.{kpi.path}"
            bad = False
            if va is not None:
                compared += 1
                if vb is None:
                    bad = True
                    failed.append(Check("baseline", key, None, va, False,
                                        f"{key} is no longer available (baseline {va:.4g})"))
                elif _worse(kpi, va, vb, tolerance):
                    bad = True
                    rel = abs(vb / va - 1.0) if va != 0 else 0.0
                    by = f"{100.0 * rel:.1f}% " if abs(va) > kpi.slack and va != 0 else ""
                    failed.append(Check("baseline", key, vb, va, False,
                                        f"{key} = {vb:.4g} is {by}worse than the baseline "
                                        f"{va:.4g} (tolerance {pct})"))
                elif va != 0 and abs(va) > kpi.slack:
                    change = 100.0 * (vb - va) / abs(va) * (1 if kpi.better == "lower" else -1)
                    if worst is None or change > worst[0]:
                        worst = (change, kpi.path)
            rows.append(KpiRow(key, kpi.unit, kpi.better, va, vb, bad))
        if failed:
            checks += failed
        elif compared:
            most = (f" (largest worsening {worst[1]} {worst[0]:+.1f}%)"
                    if worst is not None and worst[0] > 0 else "")
            checks.append(Check("baseline", name, None, None, True,
                                f"{name}: {compared} figures within {pct} of {source}"
                                f"{most}"))
    return Comparison(kind, tuple(rows), tuple(checks), tuple(notes))


def _fmt(v: float | None) -> str:
    return "-" if v is None else f"{v:.4g}"


def table_lines(c: Comparison, names: tuple[str, str] = ("A", "B")) -> list[str]:
    """The KPIs side by side, one line each: key, unit, which way is better, A, B, B - A, the
    change in percent and the direction (``WORSE`` beyond the tolerance)."""
    head = ("kpi", "unit", "better", names[0], names[1], "B - A", "change", "")
    body = [(r.key, r.unit or "-", r.better, _fmt(r.a), _fmt(r.b),
             "-" if r.difference is None else f"{r.difference:+.4g}",
             "-" if r.change_pct is None else f"{r.change_pct:+.1f}%",
             "WORSE" if r.worse_beyond_tolerance else r.direction)
            for r in c.rows if r.a is not None or r.b is not None]
    widths = [max(len(row[i]) for row in (head, *body)) for i in range(len(head))]
    lines = []
    for row in (head, *body):
        cells = [row[0].ljust(widths[0]), row[1].ljust(widths[1]), row[2].ljust(widths[2]),
                 *(cell.rjust(w) for cell, w in zip(row[3:7], widths[3:7], strict=True)),
                 row[7]]
        lines.append("  ".join(cells).rstrip())
    return lines


def comparison_dict(c: Comparison) -> JSONObject:
    """The rows that either result holds, and the notes, as JSON (units as in
    :attr:`KpiRow.unit`)."""
    return {"kind": c.kind,
            "kpis": [{"key": r.key, "unit": r.unit, "better": r.better, "a": r.a, "b": r.b,
                      "difference": r.difference, "change_pct": r.change_pct,
                      "direction": r.direction,
                      "worse_beyond_tolerance": r.worse_beyond_tolerance}
                     for r in c.rows if r.a is not None or r.b is not None],
            "notes": list(c.notes)}


def names_of(doc: JSONRecord) -> str:
    """What a result is of, for the header: the evaluated log's name, or the audited logs'
    file names."""
    log = doc.get("log")
    if isinstance(log, Mapping):
        return str(log.get("name"))
    logs = doc.get("logs")
    if isinstance(logs, list) and logs:
        return ", ".join(str(p).replace("\\", "/").rsplit("/", 1)[-1] for p in logs)
    return "?"
