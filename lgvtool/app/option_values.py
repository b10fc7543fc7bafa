"""The command line's texts made the typed values that the jobs' options hold.

Every job (``lgvtool.app.<verb>_job``) takes one frozen options dataclass of parsed values; a
command turns what was typed (``--set KEY=VALUE``, ``--grid KEY=V1,V2``, ``--max KEY=VALUE``,
``--tolerance 10%``, ``--odometry-delay auto``, ``--live [HOST:]PORT``, ...) into those values
with the functions here, which refuse a bad text in the one line (exit 2) it always had.
Nothing is imported at module level but the standard library and :mod:`lgvtool.json_types`
(``lgvtool --help`` stays light).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, TypeAlias

from lgvtool.json_types import SettingValue

if TYPE_CHECKING:
    from lgvtool.live.live_server import LiveAddress

__all__ = ["Bound", "SettingValue", "parse_bounds", "parse_grid", "parse_live_address",
           "parse_odometry_delay", "parse_settings", "parse_tolerance", "parse_topics",
           "parse_trajectories"]

#: A ``--max``/``--min`` bound: (figure key such as ``pf.circle.rmse_mm``, the bound in the
#: unit the key's suffix names).
Bound: TypeAlias = "tuple[str, float]"


def parse_settings(items: Sequence[str]) -> dict[str, SettingValue]:
    """``--set KEY=VALUE`` options -> {key: value} (:func:`lgvtool.config.parse_set_options`).

    :raises ConfigError: (exit 2) an item without ``=`` or without a key.
    """
    from lgvtool.config import parse_set_options

    return parse_set_options(list(items))


def parse_grid(items: Sequence[str]) -> dict[str, tuple[SettingValue, ...]]:
    """``--grid KEY=V1,V2,...`` options -> {key: values} (:func:`lgvtool.fleet.tasks.parse_grid`).

    :raises InputError: (exit 2) no key, an empty value, a key or a value given twice.
    """
    from lgvtool.fleet.tasks import parse_grid as grid

    return {key: tuple(values) for key, values in grid(items).items()}


def parse_bounds(items: Sequence[str], option: str) -> tuple[Bound, ...]:
    """``--max``/``--min`` ``KEY=VALUE`` options (``option``: the one named in messages) ->
    (key, bound) pairs in order (:func:`lgvtool.evaluate.regress.parse_bound`).

    :raises InputError: (exit 2) no key, a value that is not a finite number.
    """
    from lgvtool.evaluate.regress import parse_bound

    return tuple(parse_bound(item, option) for item in items)


def parse_tolerance(text: str | None) -> float | None:
    """``--tolerance`` (``10%`` or ``10``) -> a fraction (0.1); None when not given
    (:func:`lgvtool.evaluate.regress.parse_tolerance`).

    :raises InputError: (exit 2) not a number, a negative or infinite percentage.
    """
    if text is None:
        return None
    from lgvtool.evaluate.regress import parse_tolerance as tolerance

    return tolerance(text)


def parse_trajectories(items: Sequence[str]) -> dict[str, str]:
    """``--trajectory NAME=FILE`` options -> {name: file}
    (:func:`lgvtool.interop.foreign_trajectories.parse_trajectory_options`).

    :raises InputError: (exit 2) no ``=``, an empty or unusable name, a name given twice.
    """
    from lgvtool.interop.foreign_trajectories import parse_trajectory_options

    return parse_trajectory_options(items)


def parse_topics(items: Sequence[str]) -> dict[str, str]:
    """``import ros2 --topic ROLE=/name`` options -> {role: topic, or ``none``: leave the role
    out} (:func:`lgvtool.interop.ros2_roles.parse_topic_options`).

    :raises InputError: (exit 2) no ``=``, a role that does not exist, a role given twice.
    """
    from lgvtool.interop.ros2_roles import parse_topic_options

    return parse_topic_options(items)


def parse_odometry_delay(text: str) -> float | None:
    """``import mrclam --odometry-delay``: None for ``auto`` (measured per robot), else s in
    [0, 5].

    :raises InputError: (exit 2) neither a number nor auto, a number outside 0 to 5.
    """
    from lgvtool.errors import InputError

    if text.strip().lower() == "auto":
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--odometry-delay expects seconds or auto, got '{text}'") from None
    if not 0.0 <= value <= 5.0:
        raise InputError(f"--odometry-delay must be within 0 to 5 s, got '{text}'")
    return value


def parse_live_address(text: str) -> LiveAddress:
    """``--live [HOST:]PORT`` -> the live server's address (host 127.0.0.1 unless given)
    (:func:`lgvtool.live.live_server.parse_address`).

    :raises InputError: (exit 2) not ``[HOST:]PORT``, a port outside 0-65535.
    """
    from lgvtool.live.live_server import parse_address

    return parse_address(text)
