"""The stations file of ``lgvtool audit --stations FILE``: TOML, one ``[[stations]]`` table per
station with exactly the keys ``name`` (text), ``x``, ``y`` (m: the pose of the vehicle's
reference point O when it stands at the station), ``heading`` (deg), ``tolerance_xy_m`` (m,
> 0) and ``tolerance_deg`` (deg, > 0)::

    [[stations]]
    name = "pick"
    x = 16.0
    y = 7.0
    heading = 90.0
    tolerance_xy_m = 0.03
    tolerance_deg = 1.0

:func:`parse_stations` is pure (text in, stations out); :func:`read_stations` reads the file.
Every fault (not TOML, no station, a missing or unknown key, a value of the wrong type, a
tolerance not above zero, a name twice) is a :class:`~lgvtool.errors.ConfigError` of one line
naming the file and the station.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Mapping
from pathlib import Path

from lgvtool.audit.stations import NamedStation
from lgvtool.errors import ConfigError

__all__ = ["KEYS", "parse_stations", "read_stations"]

KEYS = ("name", "x", "y", "heading", "tolerance_xy_m", "tolerance_deg")
"""The keys of a ``[[stations]]`` table, every one required."""


def _number(table: Mapping[str, object], key: str, where: str) -> float:
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ConfigError(f"{where}: {key} must be a finite number, not {value!r}")
    return float(value)


def parse_stations(text: str, where: str = "stations file") -> tuple[NamedStation, ...]:
    """The stations of a stations file's ``text`` (module doc); ``where`` names it in errors.

    :raises ConfigError: (exit 2) anything but a list of complete, valid stations.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{where}: not TOML ({exc})") from None
    extra = sorted(k for k in data if k != "stations")
    if extra:
        raise ConfigError(f"{where}: unknown table or key {extra[0]!r} (a stations file holds "
                          "[[stations]] tables only)")
    tables = data.get("stations")
    if not isinstance(tables, list) or not tables:
        raise ConfigError(f"{where}: no [[stations]] tables (each with {', '.join(KEYS)})")
    out: list[NamedStation] = []
    seen: set[str] = set()
    for i, table in enumerate(tables, 1):
        if not isinstance(table, dict):
            raise ConfigError(f"{where}: station {i} is not a table")
        label = f"station {i}" + (f" ({table['name']!r})" if isinstance(table.get("name"), str)
                                  else "")
        at = f"{where}: {label}"
        unknown = sorted(k for k in table if k not in KEYS)
        if unknown:
            raise ConfigError(f"{at}: unknown key {unknown[0]!r} (the keys: {', '.join(KEYS)})")
        missing = [k for k in KEYS if k not in table]
        if missing:
            raise ConfigError(f"{at}: missing {', '.join(missing)}")
        name = table["name"]
        if not isinstance(name, str) or not name.strip():
            raise ConfigError(f"{at}: name must be a non-empty text")
        if name in seen:
            raise ConfigError(f"{at}: the name {name!r} is given twice")
        seen.add(name)
        x, y = _number(table, "x", at), _number(table, "y", at)
        heading = _number(table, "heading", at)
        tol_m = _number(table, "tolerance_xy_m", at)
        tol_deg = _number(table, "tolerance_deg", at)
        for key, value in (("tolerance_xy_m", tol_m), ("tolerance_deg", tol_deg)):
            if value <= 0:
                raise ConfigError(f"{at}: {key} must be above 0, not {value:g}")
        out.append(NamedStation(name, x, y, math.radians(heading), tol_m,
                                math.radians(tol_deg)))
    return tuple(out)


def read_stations(path: str | Path) -> tuple[NamedStation, ...]:
    """The stations of the stations file at ``path`` (:func:`parse_stations`).

    :raises ConfigError: (exit 2) unreadable, or not a valid stations file.
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise ConfigError(f"{p}: cannot read the stations file: {reason}") from None
    return parse_stations(text, str(p))
