"""Comparing two results (``lgvtool compare A B``): two ``audit.json`` or two evaluation
documents (``table1.json``), each given as the file or the folder that holds it, read here and
compared by :mod:`lgvtool.compare.result_comparison` (KPIs side by side, the gate of
``evaluate --baseline``). Reads results only: a log is refused with the command that makes a
result of it. Positions in m.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from lgvtool.compare.result_comparison import CompareSettings

if TYPE_CHECKING:
    from lgvtool.json_types import JSONObject

RESULT_FILES = ("audit.json", "table1.json")
"""The result a folder given to ``compare`` may hold (``audit -o DIR``, ``evaluate -o DIR``)."""

SITE_TOLERANCE_M = CompareSettings().site_tolerance_m
"""The declared default of :attr:`CompareOptions.site_tolerance_m`, m (``compare --help``)."""

_MCAP_MAGIC = b"\x89MCAP"


@dataclass(frozen=True, slots=True)
class CompareOptions:
    """What :func:`compare_results` compares (``lgvtool compare``)."""

    a: str
    """The baseline: an ``audit.json``, a ``table1.json`` or a folder holding one."""
    b: str
    """The result judged against :attr:`a`, of the same kind."""
    tolerance: float | None = None
    """Worsening allowed per KPI, a fraction of A's value (0.1: 10 %); None: 0."""
    site_tolerance_m: float | None = None
    """Largest distance between namesake reflectors of two layouts of one site, m; None: the
    declared default (:class:`lgvtool.compare.result_comparison.CompareSettings`)."""
    any_site: bool = False
    """Compare two audits whose layouts differ instead of refusing them."""


@dataclass
class CompareRun:
    """What :func:`compare_results` returns."""

    a: str
    """The file read for A."""
    b: str
    """The file read for B."""
    document: JSONObject
    """The comparison as JSON (``--json``): paths, tolerance, site, KPIs, checks, notes."""
    lines: list[str]
    """The text: a header, then the KPIs side by side."""
    notes: list[str] = field(default_factory=list)
    """What was not compared (the site, estimators of one side only), one line each."""
    check_lines: list[str] = field(default_factory=list)
    """The gate, one line per check and a count (``evaluate``'s wording)."""
    failures: list[str] = field(default_factory=list)
    """Every KPI worse beyond the tolerance (empty: the gate passes)."""


def _result_file(given: str) -> Path:
    """The result file that ``given`` names (itself, or the one its folder holds).

    :raises InputError: not found, a folder with none or both, or a log.
    """
    from lgvtool.errors import InputError

    path = Path(given)
    if path.is_dir():
        held = [path / n for n in RESULT_FILES if (path / n).is_file()]
        if len(held) != 1:
            which = "both" if held else "neither"
            raise InputError(f"{given}: a folder holding {which} of audit.json and table1.json; "
                             f"name the result file")
        return held[0]
    if not path.is_file():
        raise InputError(f"not found: {given}")
    with path.open("rb") as f:
        head = f.read(len(_MCAP_MAGIC))
    if head == _MCAP_MAGIC:
        raise InputError(f"{given} is a log; compare reads results: run 'lgvtool audit LOG -o DIR' "
                         f"or 'lgvtool evaluate LOG -o DIR' on each log first, then compare the "
                         f"DIRs")
    return path


def _read(path: Path) -> object:
    import json

    from lgvtool.errors import InputError

    try:
        parsed: object = json.loads(path.read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not JSON ({exc})") from None
    return parsed


def compare_results(options: CompareOptions) -> CompareRun:
    """Compare result B with result A (module doc).

    :raises InputError: (exit 2) a missing file, a log, a file that is no result, two
        results of different kinds or (unless :attr:`CompareOptions.any_site`) of different
        sites.
    """
    from lgvtool.compare import result_comparison as rc
    from lgvtool.declared import make
    from lgvtool.errors import ConfigError, InputError
    from lgvtool.evaluate.regress import check_dicts, check_lines

    o = options
    try:
        settings = make(CompareSettings, "compare",
                        {} if o.site_tolerance_m is None
                        else {"site_tolerance_m": o.site_tolerance_m})
    except ConfigError as exc:
        raise InputError(f"--site-tolerance: {exc}") from None
    tol = o.tolerance if o.tolerance is not None else 0.0
    fa, fb = _result_file(o.a), _result_file(o.b)
    kind_a, doc_a = rc.kind_of(_read(fa), str(fa))
    kind_b, doc_b = rc.kind_of(_read(fb), str(fb))
    if kind_a != kind_b:
        raise InputError(f"{fa} is an {kind_a} result and {fb} an {kind_b} result: compare two "
                         f"of one kind")
    notes: list[str] = []
    if kind_a == "audit":
        if o.any_site:
            notes.append("site not checked (--any-site)")
        else:
            note = rc.site_check(doc_a, doc_b, settings.site_tolerance_m)
            if note:
                notes.append(note)
    else:
        notes.append("site not checked: an evaluation result holds no reflector layout")
    comparison = rc.compare_documents(doc_a, doc_b, tol, source=str(fa))
    notes += comparison.notes
    lines = [f"compare ({kind_a}): A {fa} ({rc.names_of(doc_a)}) -> B {fb} "
             f"({rc.names_of(doc_b)}); tolerance {100.0 * tol:g}%",
             *rc.table_lines(comparison)]
    document: JSONObject = {
        "format": "lgvtool.comparison", "a": str(fa), "b": str(fb),
        "tolerance_pct": 100.0 * tol, "site_tolerance_m": settings.site_tolerance_m,
        "site_checked": kind_a == "audit" and not o.any_site and not any(
            n.startswith("site not checked") for n in notes),
        **rc.comparison_dict(comparison),
        "notes": list(notes),
        "checks": check_dicts(comparison.checks),
    }
    return CompareRun(str(fa), str(fb), document, lines, notes,
                      check_lines(comparison.checks),
                      [c.text for c in comparison.checks if not c.passed])

