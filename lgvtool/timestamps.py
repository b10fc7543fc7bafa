"""Time stamps: integer ns since the Unix epoch, and the ``{sec, nsec}`` form of the log's
messages (Foxglove's time layout). The one place lgvtool converts between them, for one value
and for columns of values (numpy is imported only by the column functions)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from operator import itemgetter
from typing import TYPE_CHECKING, TypedDict

from lgvtool.json_types import JSON, JSONObject, JSONRecord, as_int, as_number, member

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

__all__ = ["Stamp", "from_stamp", "message_stamp_ns", "message_stamps_ns", "seconds_to_ns",
           "seconds_to_ns_array", "stamp", "stamp_columns", "stamp_seconds"]

NS_PER_S = 1_000_000_000
"""Nanoseconds in a second."""


def stamp(ns: int) -> JSONObject:
    """``{sec, nsec}`` of a time in integer ns since the Unix epoch."""
    sec, nsec = divmod(int(ns), NS_PER_S)
    return {"sec": sec, "nsec": nsec}


def from_stamp(t: JSON) -> int:
    """Integer ns since the Unix epoch of a ``{sec, nsec}`` dict."""
    return as_int(member(t, "sec")) * NS_PER_S + as_int(member(t, "nsec"))


class Stamp(TypedDict):
    """A ``{sec, nsec}`` time as a decoded message holds it: whole seconds and nanoseconds
    since the Unix epoch."""

    sec: int
    nsec: int


def stamp_seconds(t: Stamp | None) -> float:
    """Seconds since the Unix epoch (float) of a ``{sec, nsec}`` dict; NaN for none."""
    return t["sec"] + t["nsec"] * 1e-9 if t else math.nan


def seconds_to_ns(t: float) -> int:
    """Integer ns of a time in s (rounded to the nearest ns)."""
    return round(t * 1e9)


def message_stamp_ns(doc: JSONRecord, log_ns: int) -> int:
    """A message's own ``timestamp`` (ns), else (none, or not a ``{sec, nsec}``) ``log_ns``."""
    ts = doc.get("timestamp")
    if isinstance(ts, Mapping):
        try:
            return from_stamp(ts)
        except (KeyError, TypeError, ValueError):
            pass
    return int(log_ns)


def message_stamps_ns(docs: Sequence[JSONRecord], log_ns: NDArray[np.int64]
                      ) -> NDArray[np.int64]:
    """Each message's own ``timestamp`` (ns since the epoch), else its log time (``log_ns``,
    one per message)."""
    import numpy as np

    try:
        return np.array([ts["sec"] * 1_000_000_000 + ts["nsec"]
                         for ts in map(itemgetter("timestamp"), docs)], dtype=np.int64)
    except (KeyError, TypeError):
        out = log_ns.copy()
        for i, d in enumerate(docs):
            ts = d.get("timestamp")
            if ts:
                out[i] = as_number(member(ts, "sec")) * NS_PER_S + as_number(member(ts, "nsec"))
        return out


def stamp_columns(t_ns: ArrayLike) -> tuple[list[int], list[int]]:
    """The ``sec`` and ``nsec`` columns of integer ns since the epoch."""
    import numpy as np

    sec, nsec = np.divmod(np.asarray(t_ns, dtype=np.int64), NS_PER_S)
    return sec.tolist(), nsec.tolist()


def seconds_to_ns_array(t: ArrayLike, resolution_ns: int = 1) -> NDArray[np.int64]:
    """Times in s (float) to int64 ns, rounded to the nearest multiple of ``resolution_ns``
    (1000: to the microsecond, exact for float64 Unix times of today)."""
    import numpy as np

    per_s = 1e9 / resolution_ns
    return np.rint(np.asarray(t, dtype=np.float64) * per_s).astype(np.int64) * resolution_ns
