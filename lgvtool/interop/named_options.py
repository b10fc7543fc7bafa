"""``KEY=VALUE`` options that name things (``--trajectory NAME=FILE``, ``--topic ROLE=/name``)."""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

from lgvtool.errors import InputError

SAFE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")
"""A trajectory name that can name a file and a Table 1 column."""


def parse_pairs(items: Sequence[str], option: str, form: str,
                check: Callable[[str], None] | None = None) -> dict[str, str]:
    """``KEY=VALUE`` items of ``option`` (spelled ``form`` in messages) -> ``{KEY: VALUE}``;
    ``check`` vets each key.

    :raises InputError: no ``=``, an empty key or value, a key given twice, a key ``check``
        refuses.
    """
    out: dict[str, str] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise InputError(f"{option} expects {form}, got '{item}'")
        if check is not None:
            check(key)
        if key in out:
            raise InputError(f"{option} {key} is given twice")
        out[key] = value
    return out
