"""The one validation layer for every value a user gives: command-line options, ``--set``,
``--grid`` and configuration files all go through :func:`coerce`.

A value is checked for its type (booleans, integers, numbers, strings, choices), for being
finite (NaN and infinity are refused unless a setting says that infinity means "no limit"),
and against its range. Ranges without a stated upper end get the machine-derived maxima
below, so no input can ask for more memory, processes or time than this machine can give.

The maxima (documented in docs/config.md):

* :data:`MAX_COUNT` particles (or any other count an estimator takes): a particle filter keeps
  about 1.3 kB of working arrays per particle (171 MB peak for 10^5 particles, 46 MB for 10^3),
  so 10^6 particles need about 1.3 GB;
* :data:`MAX_SIM_DURATION_S` of simulated time and :data:`MAX_SIM_STEPS` integration steps
  (rate x duration): the simulator holds its whole run in memory, about 0.6 kB per step with
  the messages it writes (154 MB peak for 1000 s at 200 Hz), so 5e6 steps need about 3 GB;
* :data:`MAX_RATE_HZ` for any rate;
* :data:`MAX_WALL_S` for a wall-clock time (recording length, timeouts, poll periods);
* :data:`MAX_BYTES` for a byte count (split size, injected garbage);
* :func:`max_workers` worker processes: one per 200 MB of the machine's memory, at most 256;
* :data:`MAX_SEEDS` seeds of a sweep and :data:`MAX_SEED` for one seed.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Sequence
from typing import overload

from lgvtool.errors import ConfigError
from lgvtool.json_types import SettingValue

MAX_COUNT = 1_000_000
"""Most particles (and any count an estimator or a command takes)."""
MAX_SIM_DURATION_S = 86_400.0
"""Longest simulated run, s (one day)."""
MAX_SIM_STEPS = 5_000_000
"""Most integration steps of one simulated run (rate x duration): about 7 h at 200 Hz, 3 GB."""
MAX_RATE_HZ = 10_000.0
"""Highest rate of any setting, Hz."""
MAX_WALL_S = 366 * 86_400.0
"""Longest wall-clock time (a recording, a timeout, a period), s: one year."""
MAX_BYTES = 10**12
"""Largest byte count (a split size); 1 TB."""
MAX_GARBAGE_BYTES = 100_000_000
"""Largest burst of injected garbage bytes (held in memory once), 100 MB."""
MAX_SEEDS = 100_000
"""Most seeds per log and setting of a sweep."""
MAX_SEED = 2**63 - 1
"""Largest seed (seeds are non-negative)."""
MAX_WORKERS_CAP = 256
"""Most worker processes, whatever the memory."""
MAX_THREADS = 256
"""Most threads the estimators of one log run on."""
WORKER_MEMORY_BYTES = 200_000_000
"""Memory one worker process needs at least (a Python process with numpy, pandas, a log)."""


def max_workers() -> int:
    """Most worker processes this machine can hold: one per 200 MB of memory, 1 to 256."""
    try:
        memory = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return MAX_WORKERS_CAP
    return max(1, min(MAX_WORKERS_CAP, int(memory // WORKER_MEMORY_BYTES)))


def _number_text(value: float) -> str:
    """``value`` as a message shows it: short (``%g``) unless that rounds it to another
    number (a bound of 0.999999999 is not "1")."""
    if not isinstance(value, float):
        return str(value)
    short = f"{value:g}"
    return short if float(short) == value else repr(value)


def parse_scalar(text: str, kind: type) -> bool | int | float | str:
    """A command-line word as ``kind`` (int, float, bool or str); ValueError when it is not."""
    word = text.strip()
    if kind is bool:
        if word.lower() in ("true", "yes", "1"):
            return True
        if word.lower() in ("false", "no", "0"):
            return False
        raise ValueError(word)
    if kind is int:
        try:
            return int(word, 10)
        except ValueError:
            number = float(word)  # 1e3 is an integer too; 1.5 is refused by coerce
            return int(number) if number.is_integer() else number
    if kind is float:
        return float(word)
    return word


def split_assignment(item: str, option: str = "--set", form: str = "key=value") -> tuple[str, str]:
    """``KEY=VALUE`` of ``option`` (``--set``, ``--grid``) as (key, raw value), the key
    stripped; ConfigError (exit 2) ``<option> expects <form>, got '<item>'`` without a key."""
    key, sep, raw = item.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"{option} expects {form}, got '{item}'")
    return key, raw


def parse_setting(raw: str) -> SettingValue:
    """A setting's value as given on the command line (``--set``, each ``--grid`` value): a
    TOML scalar (number, boolean, quoted string), else the bare string, stripped. The type is
    checked later, by :func:`coerce` against the setting's own type."""
    try:
        value: SettingValue = tomllib.loads(f"v = {raw.strip()}")["v"]
        return value
    except tomllib.TOMLDecodeError:
        return raw.strip()


@overload
def coerce(where: str, value: object, kind: type[bool], *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> bool: ...


@overload
def coerce(where: str, value: object, kind: type[int], *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> int: ...


@overload
def coerce(where: str, value: object, kind: type[float], *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> float: ...


@overload
def coerce(where: str, value: object, kind: type[str], *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> str: ...


@overload
def coerce(where: str, value: object, kind: type, *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> bool | int | float | str: ...


def coerce(where: str, value: object, kind: type, *, minimum: float | None = None,
           maximum: float | None = None, min_open: bool = False, max_open: bool = False,
           choices: Sequence[str] | None = None, allow_inf: bool = False,
           allow_nan: bool = False) -> bool | int | float | str:
    """``value`` checked and converted to ``kind`` (bool, int, float or str).

    ``where`` names the setting in the error (``pf.particles``, ``--duration``). Numbers must be
    finite (``allow_inf``: +infinity is accepted, meaning "no limit"; ``allow_nan``: NaN is
    accepted, meaning "not set") and within ``minimum``/``maximum`` (``*_open``: the bound
    itself is excluded). An integer setting without a stated maximum is at most
    :data:`MAX_COUNT`. Integral floats (``1e3``) are accepted for integers.

    :raises ConfigError: (exit 2) naming ``where``, the value and what was expected.
    """
    if kind is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.strip().lower() in ("true", "false", "yes", "no"):
            return value.strip().lower() in ("true", "yes")
        if isinstance(value, int) and value in (0, 1):
            return bool(value)
        raise ConfigError(f"{where} must be true or false, got {value!r}")
    if kind is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where} must be a string, got {value!r}")
        if choices is not None and value not in choices:
            raise ConfigError(f"{where} must be one of {', '.join(choices)}, got {value!r}")
        return value
    if kind not in (int, float):
        raise ConfigError(f"{where}: unsupported setting type {kind.__name__}")
    if isinstance(value, bool) or not isinstance(value, int | float):
        noun = "an integer" if kind is int else "a number"
        raise ConfigError(f"{where} must be {noun}, got {value!r}")
    if isinstance(value, float) and math.isnan(value):
        if allow_nan and kind is float:
            return value
        raise ConfigError(f"{where} must be a number, got nan")
    if isinstance(value, float) and math.isinf(value):
        if not (allow_inf and value > 0 and kind is float):
            raise ConfigError(f"{where} must be finite, got {value}")
        if maximum is None or math.isinf(maximum):
            return value
        raise ConfigError(f"{where} must be at most {_number_text(maximum)}, got inf")
    if kind is int:
        if isinstance(value, float):
            if not value.is_integer():
                raise ConfigError(f"{where} must be an integer, got {value!r}")
            if abs(value) > 2**63:
                raise ConfigError(f"{where} is too large, got {value:g}")
            value = int(value)
        if maximum is None:
            maximum = MAX_COUNT
    else:
        value = float(value)
    if minimum is not None and (value < minimum or (min_open and value == minimum)):
        word = "above" if min_open else "at least"
        raise ConfigError(f"{where} must be {word} {_number_text(minimum)}, got "
                          f"{_number_text(value)}")
    if maximum is not None and (value > maximum or (max_open and value == maximum)):
        word = "below" if max_open else "at most"
        raise ConfigError(f"{where} must be {word} {_number_text(maximum)}, got "
                          f"{_number_text(value)}")
    return value
