"""Estimator parameters: typed dataclasses with documented defaults, and ``--set`` handling.

Every estimator declares its parameters as a frozen dataclass whose fields carry ``doc`` (with
the unit) and optionally ``choices`` or ``minimum`` metadata. :func:`make_params` builds an
instance from overrides given as ``{param: value}``, with one clear error for a mistake.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import MISSING, Field, field, fields, replace
from typing import Any, TypeVar

from lgvtool.errors import InputError
from lgvtool.suggest import unknown_tail
from lgvtool.values import coerce

P = TypeVar("P")


def param(default: Any, doc: str, *, choices: tuple[str, ...] | None = None,
          minimum: float | None = None, maximum: float | None = None) -> Any:
    """A dataclass field with its documentation and limits."""
    meta: dict[str, Any] = {"doc": doc}
    if choices is not None:
        meta["choices"] = choices
    if minimum is not None:
        meta["minimum"] = minimum
    if maximum is not None:
        meta["maximum"] = maximum
    return field(default=default, metadata=meta)


def _coerce(owner: str, f: Field[Any], value: Any) -> Any:
    kind = type(f.default) if f.default is not MISSING else str
    where = f"{owner}.{f.name}"
    if kind is str:
        return coerce(where, str(value), str, choices=f.metadata.get("choices"))
    default_inf = isinstance(f.default, float) and math.isinf(f.default)
    return coerce(where, value, kind, minimum=f.metadata.get("minimum"),
                  maximum=f.metadata.get("maximum"), allow_inf=default_inf)


def make_params(cls: type[P], owner: str, overrides: Mapping[str, Any] | None = None,
                base: P | None = None) -> P:
    """``cls`` with ``overrides`` applied over ``base`` (or the defaults).

    Raises :class:`lgvtool.errors.InputError` naming ``owner.param`` for an unknown parameter or
    a value of the wrong type or range.
    """
    known = {f.name: f for f in fields(cls)}  # type: ignore[arg-type]
    out = base if base is not None else cls()
    changes: dict[str, Any] = {}
    for key, value in (overrides or {}).items():
        if key not in known:
            raise InputError(f"unknown parameter '{owner}.{key}'"
                             + unknown_tail(key, sorted(known), prefix=f"{owner}.", more=(
                                 f"{len(known)} parameters of {owner}; docs/filter.md#parameters"
                                 " lists them")))
        changes[key] = _coerce(owner, known[key], value)
    return replace(out, **changes) if changes else out  # type: ignore[type-var]


def params_dict(params: Any) -> dict[str, Any]:
    """The parameters as a plain JSON-able dict (infinities as strings)."""
    out: dict[str, Any] = {}
    for f in fields(params):
        v = getattr(params, f.name)
        if isinstance(v, float) and not math.isfinite(v):
            v = "inf" if v > 0 else "-inf"
        out[f.name] = v
    return out


def describe(cls: type) -> list[tuple[str, Any, str]]:
    """``(name, default, doc)`` for every parameter of ``cls``, in declaration order."""
    return [(f.name, f.default, f.metadata.get("doc", "")) for f in fields(cls)]
