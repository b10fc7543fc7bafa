"""Access to the JSON Schemas of ``schemas/`` (shipped inside the package when installed)."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

from lgvtool.json_types import JSONObject


def schema_dir() -> Path:
    """The folder that holds the ``*.json`` schemas: the installed copy or the source tree's."""
    here = Path(__file__).resolve().parent.parent
    installed = here / "_schemas"
    if installed.is_dir():
        return installed
    return here.parent / "schemas"


@cache
def schema_names() -> tuple[str, ...]:
    """Every schema name available, sorted."""
    return tuple(sorted(p.stem for p in schema_dir().glob("*.json")))


@cache
def schema_bytes(name: str) -> bytes:
    """The schema document of ``name`` as bytes, exactly as embedded in logs."""
    path = schema_dir() / f"{name}.json"
    if not path.is_file():
        raise KeyError(f"no schema named {name!r}")
    return path.read_bytes()


def schema_json(name: str) -> JSONObject:
    """The parsed schema document of ``name``."""
    data: JSONObject = json.loads(schema_bytes(name))
    return data
