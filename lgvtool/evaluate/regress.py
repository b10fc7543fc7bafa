"""Regression checks on an evaluation document: fixed bounds and a baseline.

A figure is named by its path in the document (docs/evaluation.md), starting with an estimator
name: ``pf.circle.rmse_mm``, ``laser.truth.position_rmse_m``. Paths from the document root
(``rotations.complete``, ``truth_path.rmse_mm``) work too.

- ``--max K=V`` fails when the figure exceeds V, ``--min K=V`` when it is below V, and either
  fails when the figure is not available (e.g. no complete rotation).
- ``--baseline FILE --tolerance P``: every error figure of :data:`BASELINE_FIGURES` of every
  estimator in the baseline must not exceed its baseline value by more than P percent.

Malformed keys and baselines raise :class:`~lgvtool.errors.InputError` (exit 2). Every check
is a :class:`Check` (:func:`bound_checks`, :func:`baseline_checks`), passed or failed, which
``evaluate`` lists one line each (:func:`check_lines`) and puts in the document (``checks``);
:func:`check_bounds` and :func:`check_baseline` return the failed ones as messages, one per
figure, for :class:`~lgvtool.errors.ThresholdError` (exit 1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from lgvtool.errors import InputError, ThresholdError
from lgvtool.json_types import JSON, JSONRecord, member_or

BASELINE_FIGURES: dict[tuple[str, str], float] = {
    ("circle", "rmse_mm"): 1e-3,
    ("circle", "variance_mm2"): 1e-3,
    ("circle", "max_abs_mm"): 1e-3,
    ("truth", "position_rmse_m"): 1e-6,
    ("truth", "position_p95_m"): 1e-6,
    ("truth", "heading_rmse_deg"): 1e-4,
}
"""Figures compared with a baseline (all are errors, so larger is worse), each with an
absolute slack in its own unit (1 micrometre, 1e-4 degree) that absorbs rounding when the
baseline value is close to zero."""

_MISSING = object()


def parse_bound(text: str, option: str = "--max") -> tuple[str, float]:
    """Parse ``KEY=VALUE`` (VALUE a number) into (KEY, VALUE)."""
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise InputError(f"{option} expects KEY=VALUE (e.g. pf.circle.rmse_mm=25), got '{text}'")
    try:
        value = float(raw.strip())
    except ValueError:
        raise InputError(f"{option} {key}: '{raw.strip()}' is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{option} {key}: the bound must be finite, got '{raw.strip()}'")
    return key, value


def parse_tolerance(text: str) -> float:
    """Parse a tolerance in percent (``10%`` or ``10``) into a fraction (0.10)."""
    raw = text.strip().removesuffix("%").strip()
    try:
        value = float(raw)
    except ValueError:
        raise InputError(f"--tolerance expects a percentage such as 10%, got '{text}'") from None
    if not (math.isfinite(value) and value >= 0):
        raise InputError(f"--tolerance must be a non-negative percentage, got '{text}'")
    return value / 100.0


def _estimator_table(doc: JSONRecord) -> JSONRecord:
    """The ``estimators`` table of an evaluation document (empty when it has none)."""
    estimators = doc.get("estimators") or {}
    return estimators if isinstance(estimators, Mapping) else {}


def _walk(node: JSON | JSONRecord, parts: Sequence[str], key: str) -> JSON | JSONRecord:
    for i, part in enumerate(parts):
        if node is None:
            return None
        if not isinstance(node, Mapping):
            raise InputError(f"unknown figure '{key}': '{'.'.join(parts[:i])}' is a value")
        if part not in node:
            known = ", ".join(sorted(k for k in node if not isinstance(node[k], list)))
            where = ".".join(parts[:i]) or "the document root"
            raise InputError(f"unknown figure '{key}': no '{part}' in {where} (known: {known})")
        node = node[part]
    return node


def lookup(doc: JSONRecord, key: str) -> float | None:
    """The value of figure ``key`` in ``doc``; None when the figure is not available.

    Raises :class:`~lgvtool.errors.InputError` when ``key`` names nothing in the layout.
    """
    estimators = _estimator_table(doc)
    parts = key.split(".")
    node: JSON | object = _MISSING
    for cut in range(len(parts), 0, -1):  # longest estimator name first (names may hold '.')
        name = ".".join(parts[:cut])
        if name in estimators:
            node = _walk(estimators[name], parts[cut:], key)
            break
    if node is _MISSING:
        if parts[0] not in doc:
            known = ", ".join(estimators) or "none"
            raise InputError(f"unknown figure '{key}': no estimator '{parts[0]}' "
                             f"(estimators: {known})")
        node = _walk(doc, parts, key)
    if node is None:
        return None
    if isinstance(node, Mapping):
        known = ", ".join(sorted(k for k in node if not isinstance(node[k], list)))
        raise InputError(f"figure '{key}' is a group, not a number: name one of its figures "
                         f"({key}.KEY, KEY one of: {known})")
    if isinstance(node, bool) or not isinstance(node, int | float):
        raise InputError(f"figure '{key}' is not a number")
    return float(node)


@dataclass(frozen=True)
class Check:
    """One check and its outcome. ``kind``: "max", "min" or "baseline"; ``key``: the figure
    (``pf.circle.rmse_mm``; for a baseline that all of an estimator's figures held, the
    estimator's name); ``value``: the figure now (its unit: the key's suffix; None: not
    available); ``limit``: the bound, or the baseline value; ``text``: one line saying what
    was checked and found."""

    kind: str
    key: str
    value: float | None
    limit: float | None
    passed: bool
    text: str


def bound_checks(
    doc: JSONRecord,
    maxima: Sequence[tuple[str, float]] = (),
    minima: Sequence[tuple[str, float]] = (),
) -> list[Check]:
    """Every bound as a :class:`Check`, passed or failed, ``--max`` ones first."""
    checks: list[Check] = []
    for bounds, word in ((maxima, "max"), (minima, "min")):
        for key, limit in bounds:
            value = lookup(doc, key)
            if value is None:
                checks.append(Check(word, key, None, limit, False,
                                    f"{key} is not available (needed for --{word} {limit:g})"))
            elif word == "max":
                ok = value <= limit
                text = (f"{key} = {value:.4g}, at most {limit:g}" if ok
                        else f"{key} = {value:.4g} exceeds the maximum {limit:g}")
                checks.append(Check(word, key, value, limit, ok, text))
            else:
                ok = value >= limit
                text = (f"{key} = {value:.4g}, at least {limit:g}" if ok
                        else f"{key} = {value:.4g} is below the minimum {limit:g}")
                checks.append(Check(word, key, value, limit, ok, text))
    return checks


def check_bounds(
    doc: JSONRecord,
    maxima: Sequence[tuple[str, float]] = (),
    minima: Sequence[tuple[str, float]] = (),
) -> list[str]:
    """Messages for every bound that fails (empty: all hold)."""
    return [c.text for c in bound_checks(doc, maxima, minima) if not c.passed]


def validate_baseline(obj: object, source: str = "baseline") -> JSONRecord:
    """Check that ``obj`` is an evaluation document; return it."""
    from lgvtool.evaluate.document import FORMAT

    if not isinstance(obj, Mapping) or obj.get("format") != FORMAT:
        raise InputError(f"{source}: not an lgvtool evaluation JSON (no \"format\": \"{FORMAT}\")")
    estimators = obj.get("estimators")
    if not isinstance(estimators, Mapping) or not all(
        isinstance(v, Mapping) for v in estimators.values()
    ):
        raise InputError(f"{source}: not an lgvtool evaluation JSON ('estimators' is not a "
                         "table of estimators)")
    return obj


def baseline_checks(
    doc: JSONRecord, baseline: JSONRecord, tolerance: float,
    *, source: str = "baseline",
) -> tuple[list[Check], list[str]]:
    """Compare ``doc`` with ``baseline``: (checks, notes). Per estimator both documents have,
    one passed :class:`Check` when all its figures of :data:`BASELINE_FIGURES` hold, else one
    failed Check per figure that exceeds the baseline by more than ``tolerance`` (a fraction)
    or is no longer available; notes name the estimators of the baseline that this
    evaluation lacks."""
    validate_baseline(baseline, source)
    current = _estimator_table(doc)
    base = _estimator_table(baseline)  # a table of tables (validate_baseline)
    common = [n for n in base if n in current]
    if not common:
        raise InputError(f"{source}: no estimator in common with this evaluation "
                         f"(baseline: {', '.join(base) or 'none'}; now: {', '.join(current)})")
    notes = [f"estimator '{n}' of the {source} is not in this evaluation" for n in base
             if n not in current]
    checks: list[Check] = []
    pct = f"{100.0 * tolerance:g}%"
    for n in common:
        failed: list[Check] = []
        compared = 0
        worst: tuple[float, str] | None = None
        for (group, figure), slack in BASELINE_FIGURES.items():
            b = _figure(base[n], group, figure)
            if b is None:
                continue
            compared += 1
            now = _figure(current[n], group, figure)
            key = f"{n}.{group}.{figure}"
            if now is None:
                failed.append(Check("baseline", key, None, b, False,
                                    f"{key} is no longer available (baseline {b:.4g})"))
            elif now > b * (1.0 + tolerance) + slack:
                worse = f"{100.0 * (now / b - 1.0):.1f}% " if b > slack else ""
                failed.append(Check("baseline", key, now, b, False,
                                    f"{key} = {now:.4g} is {worse}worse than the baseline "
                                    f"{b:.4g} (tolerance {pct})"))
            elif b > slack:
                change = 100.0 * (now / b - 1.0)
                if worst is None or change > worst[0]:
                    worst = (change, f"{group}.{figure}")
        if failed:
            checks += failed
        elif compared:
            most = f" (largest change {worst[1]} {worst[0]:+.1f}%)" if worst else ""
            checks.append(Check("baseline", n, None, None, True,
                                f"{n}: {compared} error figures within {pct} of {source}{most}"))
    return checks, notes


def check_baseline(
    doc: JSONRecord, baseline: JSONRecord, tolerance: float,
    *, source: str = "baseline",
) -> tuple[list[str], list[str]]:
    """Compare ``doc`` with ``baseline``: (failures, notes). A figure fails when it exceeds the
    baseline by more than ``tolerance`` (a fraction) or is no longer available; notes name the
    estimators of the baseline that this evaluation lacks."""
    checks, notes = baseline_checks(doc, baseline, tolerance, source=source)
    return [c.text for c in checks if not c.passed], notes


def check_lines(checks: Sequence[Check]) -> list[str]:
    """One line per check, ``check  pass  ...`` or ``check  FAIL  ...``, then a count."""
    lines = [f"check  {'pass' if c.passed else 'FAIL'}  {c.text}" for c in checks]
    failed = sum(not c.passed for c in checks)
    n = len(checks)
    if failed:
        lines.append(f"checks: {failed} of {n} FAILED")
    elif n:
        lines.append(f"checks: all {n} passed" if n > 1 else "checks: the one check passed")
    return lines


def check_dicts(checks: Sequence[Check]) -> list[JSON]:
    """The checks as JSON-ready dicts (the document's ``checks``)."""
    return [{"kind": c.kind, "key": c.key, "value": c.value, "limit": c.limit,
             "passed": c.passed, "text": c.text} for c in checks]


def _figure(block: JSON, group: str, figure: str) -> float | None:
    section = member_or(block, group, None)
    if not isinstance(section, Mapping):
        return None
    v = section.get(figure)
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        return None
    return float(v)


def raise_failures(failures: Sequence[str]) -> None:
    """Raise :class:`~lgvtool.errors.ThresholdError` naming every failed figure, if any."""
    if failures:
        n = len(failures)
        raise ThresholdError(f"{n} check{'s' if n > 1 else ''} failed: " + "; ".join(failures))
