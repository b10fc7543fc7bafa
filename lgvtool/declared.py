"""Declared settings: the one mechanism behind every parameter of the estimators and the simulator.

A group of settings is a frozen dataclass; each field is declared once with :func:`setting`: its
default (which also gives its type: bool, int, float or str), its unit, its range or choices, and
its documentation. Everything else reads those declarations:

* :func:`make` builds a group from overrides (``--set owner.key=value``, a configuration file's
  table, a Python ``settings=`` dict) and refuses, in one line naming ``owner.key``, an unknown
  key or a value of the wrong type or out of its range;
* :func:`as_dict` gives the values as JSON (what logs and reports record);
* :func:`declarations` and :func:`markdown_table` give the table that ``lgvtool config
  --parameters`` prints and that the docs hold (a test keeps them equal).

A setting may also hold a list (:func:`setting` with ``item=``): of integers (``item=int``,
``missing = [12]``) or of small tables, each a frozen dataclass of declared scalar fields
(``[[simulator.site.moved]]``), checked field by field and named by position
(``site.moved[0].dx``); its default is the empty tuple.

Numbers without a declared range are still bounded: an integer by
:data:`lgvtool.values.MAX_COUNT`, any number by :data:`MAGNITUDE` in size (no length, time or
noise level of a hall-sized run exceeds it). A float whose default is NaN means "not set" and
accepts NaN; one whose default is +infinity means "no limit" and accepts infinity.

Example::

    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Head:
    ...     rotation_hz: float = setting(8.0, "head revolutions per second", unit="Hz",
    ...                                  minimum=0.5, min_open=True, maximum=100.0)
    >>> make(Head, "nav", {"rotation_hz": "10"}).rotation_hz
    10.0
    >>> make(Head, "nav", {"rotation_hz": 0.5})
    Traceback (most recent call last):
    ...
    lgvtool.errors.ConfigError: nav.rotation_hz must be above 0.5, got 0.5

A list of tables::

    >>> @dataclass(frozen=True)
    ... class Shift:
    ...     id: int = setting(REQUIRED, "reflector id", unit="", minimum=0)
    ...     dx: float = setting(0.0, "shift, m", maximum=5.0)
    >>> @dataclass(frozen=True)
    ... class Site:
    ...     moved: tuple[Shift, ...] = setting((), "moved reflectors", item=Shift)
    >>> make(Site, "site", {"moved": [{"id": 7, "dx": 0.06}]}).moved
    (Shift(id=7, dx=0.06),)
    >>> make(Site, "site", {"moved": [{"id": 7, "dz": 0.1}]})
    Traceback (most recent call last):
    ...
    lgvtool.errors.ConfigError: unknown parameter 'site.moved[0].dz' (known: dx, id)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import MISSING, dataclass, field, fields, is_dataclass, replace
from typing import Any, TypeAlias, TypeVar

from lgvtool.errors import ConfigError
from lgvtool.suggest import unknown_tail
from lgvtool.values import MAX_COUNT, coerce

S = TypeVar("S")

JSONScalar = bool | int | float | str | None
"""A setting's value as JSON holds it (NaN and infinities as :func:`as_dict` writes them)."""

MAGNITUDE = 1e6
"""Largest size of a number whose declaration states no range (lengths in m, times in s, noise
levels: no hall-sized run comes near it)."""

REQUIRED: Any = MISSING
"""The ``default`` of a setting that has none: a table must give it (a reflector's ``x``)."""

_UNITS = ("m", "mm", "rad", "deg", "s", "ms", "Hz", "m/s", "rad/s", "deg/s", "m/s^2", "ppm",
          "baud", "mm/m", "rad/m", "m/m", "1/m", "px", "bytes", "rad/rad", "m/rad", "1/sqrt(m)",
          "1/sqrt(rad)")


def _unit_from_doc(doc: str) -> str:
    """The unit a documentation line ends with (``"range noise, m"`` -> ``m``), else ``""``."""
    tail = doc.rstrip(" .").rpartition(", ")[2]
    return tail if tail in _UNITS else ""


def setting(default: Any, doc: str, *, unit: str | None = None,
            minimum: float | None = None, maximum: float | None = None,
            min_open: bool = False, max_open: bool = False,
            choices: Sequence[str] | None = None, item: type | None = None) -> Any:
    """A dataclass field declaring one setting.

    :param default: the default value (:data:`REQUIRED`: none, the value must be given).
    :param doc: what it means, ending with its unit (``"..., mm"``) when it has one.
    :param unit: the unit when the documentation does not end with it; ``""``: dimensionless.
    :param minimum: the smallest value (``min_open``: excluded), in the setting's unit.
    :param maximum: the largest value (``max_open``: excluded), in the setting's unit.
    :param choices: the allowed words of a string setting.
    :param item: the setting is a list (a tuple, default ``()``) of these: ``int`` (each
        checked against ``minimum``/``maximum``) or a frozen dataclass of declared scalar
        settings (each item a table, checked field by field).
    """
    meta: dict[str, Any] = {
        "item": item,
        "doc": doc, "unit": _unit_from_doc(doc) if unit is None else unit,
        "minimum": minimum, "maximum": maximum, "min_open": min_open, "max_open": max_open,
        "choices": tuple(choices) if choices is not None else None,
    }
    if default is REQUIRED:
        return field(metadata=meta)
    return field(default=default, metadata=meta)


#: a setting's default: a scalar, a tuple of them (a list setting), None (none, or not set)
Default: TypeAlias = "bool | int | float | str | tuple[Default, ...] | None"


@dataclass(frozen=True, slots=True)
class Declaration:
    """One declared setting, as :func:`setting` declared it."""

    name: str
    """The key within its group (``particles``)."""
    kind: type
    """bool, int, float or str."""
    default: Default
    """The default value; None: none (:attr:`required`) or not set (:attr:`optional`); a
    tuple for a list setting (:attr:`item`)."""
    unit: str
    """The unit (``m``, ``deg``, ``Hz``); ``""``: dimensionless or not a number."""
    doc: str
    """What it means."""
    minimum: float | None = None
    """The smallest value, in ``unit``; None: -:data:`MAGNITUDE`."""
    maximum: float | None = None
    """The largest value, in ``unit``; None: :data:`MAGNITUDE` (integers:
    :data:`lgvtool.values.MAX_COUNT`)."""
    min_open: bool = False
    """The minimum itself is excluded."""
    max_open: bool = False
    """The maximum itself is excluded."""
    choices: tuple[str, ...] | None = None
    """The allowed words of a string setting."""
    required: bool = False
    """The setting has no default: a table must give it."""
    optional: bool = False
    """None (``false`` in TOML, which has no null) means "not set"."""
    item: type | None = None
    """A list setting's item: ``int`` or a dataclass of declared settings; None: a scalar."""

    def check(self, owner: str, value: object) -> object:
        """``value`` converted to the setting's type and checked against its range.

        :raises ConfigError: (exit 2) naming ``owner.name``, the value and what was expected.
        """
        where = f"{owner}.{self.name}" if owner else self.name
        if self.item is not None:
            return self._check_list(where, value)
        if self.optional and (value is None or value is False):
            return None
        unset = isinstance(self.default, float) and math.isnan(self.default)
        if unset and (value is None or (isinstance(value, str) and value.lower() == "nan")):
            return math.nan
        if value is None:
            raise ConfigError(f"missing value for {where}")
        if self.kind is str:
            return coerce(where, value if isinstance(value, str) else str(value), str,
                          choices=self.choices)
        if self.kind is bool:
            return coerce(where, value, bool)
        if isinstance(value, str) and self.kind in (int, float):
            try:
                value = float(value) if self.kind is float else int(value, 10)
            except ValueError:
                noun = "an integer" if self.kind is int else "a number"
                raise ConfigError(f"{where} must be {noun}, got {value!r}") from None
        no_limit = isinstance(self.default, float) and math.isinf(self.default)
        top = self.maximum
        if top is None and not no_limit:
            top = MAX_COUNT if self.kind is int else MAGNITUDE
        bottom = -MAGNITUDE if self.minimum is None else self.minimum
        return coerce(where, value, self.kind, minimum=bottom, maximum=top,
                      min_open=self.min_open, max_open=self.max_open,
                      allow_inf=no_limit, allow_nan=unset)

    def _check_list(self, where: str, value: object) -> tuple[object, ...]:
        """A list setting's value (a list, tuple, or for integers ``"12, 13"``) as a tuple of
        checked items: integers in range, or tables checked field by field (``where[i].key``)
        with every required field given."""
        item = self.item
        if item is int and isinstance(value, str | int) and not isinstance(value, bool):
            text = str(value).strip().strip("[]")
            value = [v.strip() for v in text.split(",") if v.strip()]
        if isinstance(value, str | bytes | Mapping) or not isinstance(value, Sequence):
            raise ConfigError(f"{where} must be a list, got {value!r}")
        if item is int:
            return tuple(replace(self, name=f"{where}[{i}]", kind=int, default=0, item=None)
                         .check("", v) for i, v in enumerate(value))
        assert item is not None and is_dataclass(item)
        out = []
        for i, v in enumerate(value):
            if isinstance(v, item):
                out.append(v)
                continue
            table = check_table(item, f"{where}[{i}]", v)
            for d in declarations(item):
                if d.required and d.name not in table:
                    raise ConfigError(f"missing value for {where}[{i}].{d.name}")
            out.append(item(**table))
        return tuple(out)

    def range_text(self) -> str:
        """The allowed values as a table shows them (``[0, 1]``, ``(0.5, 100]``, ``> 0``,
        ``a | b``, ``list of {id, dx, dy}``; ``""`` when the declaration states none)."""
        if self.item is not None:
            if self.item is int:
                return "list of int"
            return "list of {" + ", ".join(d.name for d in declarations(self.item)) + "}"
        if self.choices is not None:
            return " | ".join(self.choices)
        if self.kind is bool:
            return "true | false"
        if self.kind is str or (self.minimum is None and self.maximum is None):
            return ""
        if self.maximum is None:
            return f"{'>' if self.min_open else '>='} {_bound(self.minimum)}"
        if self.minimum is None:
            return f"{'<' if self.max_open else '<='} {_bound(self.maximum)}"
        left = "(" if self.min_open else "["
        right = ")" if self.max_open else "]"
        return f"{left}{_bound(self.minimum)}, {_bound(self.maximum)}{right}"


def _bound(value: float | None) -> str:
    """A range's end as a table shows it (``0``, ``0.5``, ``65535``)."""
    if value is not None and float(value).is_integer() and abs(value) < 1e15:
        return str(int(value))
    return _number(value)


def _number(value: float | None) -> str:
    """A bound or default as a table shows it: integers whole, other numbers short unless
    that would round them."""
    if value is None:
        return ""
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    if float(value).is_integer() and abs(value) < 1e15:
        return str(int(value)) if isinstance(value, int) else f"{value:.1f}"
    text = f"{value:g}"
    return text if float(text) == value else repr(value)


_KINDS: dict[str, type] = {"bool": bool, "int": int, "float": float, "str": str}


def declarations(cls: type) -> tuple[Declaration, ...]:
    """Every setting of the group ``cls`` (a dataclass), in declaration order."""
    out: list[Declaration] = []
    for f in fields(cls):
        annotation = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", "")
        words = annotation.replace("|", " ").split()
        kind = next((_KINDS[w] for w in words if w in _KINDS), type(f.default))
        meta = f.metadata
        required = f.default is MISSING
        default = (f.default if isinstance(f.default, bool | int | float | str | tuple)
                   else None)
        out.append(Declaration(
            name=f.name, kind=kind, default=default,
            required=required, optional="None" in words, unit=meta.get("unit", ""),
            doc=meta.get("doc", ""), minimum=meta.get("minimum"), maximum=meta.get("maximum"),
            min_open=meta.get("min_open", False), max_open=meta.get("max_open", False),
            choices=meta.get("choices"), item=meta.get("item")))
    return tuple(out)


def check_table(cls: type, owner: str, table: object, *, what: str = "parameter",
                more: str = "") -> dict[str, object]:
    """``table`` (``{key: value}``) with each value checked by its declaration in the group
    ``cls``.

    :param owner: the group's name in messages (``pf``, ``nav``, ``reflectors[3]``).
    :param what: the noun of an unknown key's message (``parameter``, ``setting``).
    :param more: the tail of an unknown key's message (``{n}``: the number of keys), e.g.
        where they are listed.
    :raises ConfigError: (exit 2) for an unknown key or a bad value, naming ``owner.key``.
    """
    if not isinstance(table, Mapping):
        raise ConfigError(f"[{owner}] must be a table")
    known = {d.name: d for d in declarations(cls)}
    out: dict[str, object] = {}
    for key, value in table.items():
        decl = known.get(key)
        if decl is None:
            raise ConfigError(f"unknown {what} '{owner}.{key}'" + unknown_tail(
                key, sorted(known), prefix=f"{owner}.",
                more=(more or "{n} " + what + "s of " + owner).replace("{n}", str(len(known)))))
        out[key] = decl.check(owner, value)
    return out


def make(cls: type[S], owner: str, overrides: Mapping[str, object] | None = None,
         base: S | None = None, *, what: str = "parameter", more: str = "") -> S:
    """The group ``cls`` with ``overrides`` (``{key: value}``) applied over ``base`` (or the
    defaults), each value checked by its declaration (:func:`check_table`, whose arguments
    ``what`` and ``more`` are).

    :raises ConfigError: (exit 2) for an unknown key or a bad value, naming ``owner.key``.
    """
    out = base if base is not None else cls()
    changes = check_table(cls, owner, overrides or {}, what=what, more=more)
    return replace(out, **changes) if changes else out  # type: ignore[type-var]


def json_value(value: Any) -> Any:
    """A setting's value as JSON holds it: NaN as None, infinities as ``"inf"``/``"-inf"``; a
    list setting as a list (of integers, or of tables: :func:`as_dict` of each)."""
    if isinstance(value, tuple | list):
        return [as_dict(v) if is_dataclass(v) else json_value(v) for v in value]
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, float) and math.isinf(value):
        return "inf" if value > 0 else "-inf"
    return value


def as_dict(group: object) -> dict[str, Any]:
    """The values of a group as JSON (:func:`json_value`)."""
    if not is_dataclass(group):
        raise TypeError(f"{type(group).__name__} is not a settings group")
    return {f.name: json_value(getattr(group, f.name)) for f in fields(group)}


def default_text(value: Default) -> str:
    """A default as TOML writes it (``true``, ``0.05``, ``inf``, ``"auto"``, ``[]``; not set:
    ``nan``)."""
    if isinstance(value, tuple):
        return "[" + ", ".join(default_text(v) for v in value) + "]"
    if value is None:
        return "nan"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, float):
        return _number(value)
    if isinstance(value, str):
        return f'"{value}"'
    return str(value)


def markdown_table(cls: type, prefix: str = "") -> str:
    """The declarations of ``cls`` as a Markdown table: key, default, unit, range, meaning
    (``prefix`` before each key, e.g. ``nav.``)."""
    lines = ["| key | default | unit | range | meaning |", "|---|---:|---|---|---|"]
    for d in declarations(cls):
        doc = d.doc.replace("|", "\\|").replace("\n", " ")
        lines.append(f"| `{prefix}{d.name}` | {default_text(d.default)} | {d.unit or '-'} | "
                     f"{d.range_text().replace('|', '&#124;') or '-'} | {doc} |")
    return "\n".join(lines)
