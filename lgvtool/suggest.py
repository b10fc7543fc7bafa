""""Did you mean ...?" for a mistyped name, so that every unknown-name error (a command, an
estimator, a scenario, a ``--set`` key, a configuration key) offers the closest known names
first and stays one short line.

Only the standard library is imported here (the lazy command group uses it before any command
is loaded).
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

SHORT_LIST = 12
"""Lists of known names up to this long are shown in full in an error; longer ones are named by
their count and where to find them."""

_CUTOFF = 0.6
"""difflib's similarity ratio a known name needs to be offered."""


_MARGIN = 0.1
"""A known name is offered beside the closest one only when its ratio is within this of the
closest's (``partcles``: ``particles``, not also ``min_particles``)."""


def closest(name: str, known: Iterable[str], n: int = 3) -> list[str]:
    """Up to ``n`` names of ``known`` closest to ``name``, best first: difflib's similarity
    ratio at least 0.6 and within 0.1 of the best one's; letter case ignored when nothing
    matches as typed."""
    names = list(dict.fromkeys(known))
    for typed, pool in ((name, {k: k for k in names}),
                        (name.lower(), {k.lower(): k for k in reversed(names)})):
        scored = []
        for k in difflib.get_close_matches(typed, list(pool), n=n, cutoff=_CUTOFF):
            scored.append((difflib.SequenceMatcher(None, k, typed).ratio(), pool[k]))
        if scored:
            best = scored[0][0]  # get_close_matches: best first, by this same ratio
            return [k for ratio, k in scored if ratio >= best - _MARGIN]
    return []


def did_you_mean(name: str, known: Iterable[str], *, prefix: str = "") -> str:
    """``did you mean 'pf-paper'?`` (``'a' or 'b'`` for several) naming the known names closest
    to ``name``, each shown after ``prefix``; empty when none is close."""
    found = closest(name, known)
    if not found:
        return ""
    quoted = [f"'{prefix}{k}'" for k in found]
    shown = quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"
    return f"did you mean {shown}?"


def unknown_tail(name: str, known: Iterable[str], *, prefix: str = "", label: str = "known",
                 more: str | None = None) -> str:
    """What follows ``unknown <thing> '<name>'`` in an error: the suggestion, then the known
    names in parentheses, or, for a list longer than :data:`SHORT_LIST` and a ``more`` given
    (e.g. ``"57 parameters of pf; docs/filter.md lists them"``), ``more`` instead.

    >>> unknown_tail("pf-papr", ["laser", "pf-paper", "pf"])
    ": did you mean 'pf-paper'? (known: laser, pf-paper, pf)"
    """
    names = list(dict.fromkeys(known))
    hint = did_you_mean(name, names, prefix=prefix)
    listed = more if more is not None and len(names) > SHORT_LIST else f"{label}: {', '.join(names)}"
    return (f": {hint}" if hint else "") + f" ({listed})"
