"""Named types of JSON-shaped values: what a log's metadata, a result document (``table1.json``,
``audit.json``), a decode report and a configuration section hold once parsed.

Signatures name these instead of ``Any``, so a reader sees that a value is plain data (numbers,
strings, lists, objects) and nothing else.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, TypeAlias

if TYPE_CHECKING:
    import datetime

__all__ = ["JSON", "JSONObject", "JSONRecord", "SettingValue", "as_float", "as_int", "as_list",
           "as_number", "member", "member_or"]

#: A JSON value (a number, a string, a boolean, null, a list or an object of JSON values).
JSON: TypeAlias = "str | int | float | bool | list[JSON] | dict[str, JSON] | None"
#: A JSON object.
JSONObject: TypeAlias = "dict[str, JSON]"
#: A JSON object read, not built: any mapping of names to JSON values.
JSONRecord: TypeAlias = "Mapping[str, JSON]"
#: A setting's value as ``--set``/``--grid`` give it (:func:`lgvtool.values.parse_setting`): a
#: TOML value (number, boolean, quoted string, date, array, inline table), else the bare
#: string; its type and range are checked against the setting's own where it is used.
SettingValue: TypeAlias = ("str | int | float | bool | datetime.datetime | datetime.date | "
                           "datetime.time | list[SettingValue] | dict[str, SettingValue]")


# Reading a decoded value: the narrowing a reader of JSON needs, with the errors Python itself
# raises for the same operation on a value of another kind (a log's malformed message names
# them in its one-line error, :func:`lgvtool.errors.decoding_error`).


def as_float(value: JSON) -> float:
    """``float(value)``: a number (or a numeric string) as a float; the TypeError of
    :func:`float` for a list, an object or null."""
    if isinstance(value, list | dict) or value is None:
        raise TypeError(f"float() argument must be a string or a real number, not "
                        f"'{type(value).__name__}'")
    return float(value)


def as_int(value: JSON) -> int:
    """``int(value)``: a number (truncated) or an integer string as an int; the TypeError of
    :func:`int` for a list, an object or null."""
    if isinstance(value, list | dict) or value is None:
        raise TypeError(f"int() argument must be a string, a bytes-like object or a real "
                        f"number, not '{type(value).__name__}'")
    return int(value)


def as_number(value: JSON) -> float:
    """``value`` itself when it is a number (an int stays an int, a boolean is one); TypeError
    for anything else, as arithmetic on it raises."""
    if isinstance(value, int | float):
        return value
    raise TypeError(f"not a number: '{type(value).__name__}'")


def member(value: JSON, key: str) -> JSON:
    """``value[key]``: the member ``key`` of an object (KeyError when it has none); the
    TypeError of indexing a list, a string, a number or null by a name."""
    if isinstance(value, dict | Mapping):  # dict first: the decoded case, checked fastest
        return value[key]
    if isinstance(value, list):
        raise TypeError("list indices must be integers or slices, not str")
    if isinstance(value, str):
        raise TypeError("string indices must be integers, not 'str'")
    raise TypeError(f"'{type(value).__name__}' object is not subscriptable")


def member_or(value: JSON, key: str, default: JSON) -> JSON:
    """``value.get(key, default)``: the member ``key`` of an object, ``default`` when it has
    none; the AttributeError of ``.get`` on a list, a string, a number or null."""
    if isinstance(value, Mapping):
        return value.get(key, default)
    raise AttributeError(f"'{type(value).__name__}' object has no attribute 'get'")


def as_list(value: JSON) -> list[JSON]:
    """``value`` itself when it is a list (a JSON array); TypeError for anything else."""
    if isinstance(value, list):
        return value
    raise TypeError(f"not a list: '{type(value).__name__}'")
