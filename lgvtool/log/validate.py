"""Checks of what a log holds against the log contract (docs/log-format.md): the schema and
encodings of each lgvtool topic, and the range of decoded values.

Pure functions; the reader raises :class:`lgvtool.errors.LogFormatError` with their text.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, cast

from lgvtool.json_types import JSON, JSONRecord
from lgvtool.log import topics as T

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

#: message encoding and schema encoding of every lgvtool topic
MESSAGE_ENCODING = "json"
SCHEMA_ENCODING = "jsonschema"

#: plausible log and message times: from 1990-01-01 to 2100-01-01, ns since the Unix epoch
MIN_TIME_NS = 631_152_000 * 1_000_000_000
MAX_TIME_NS = 4_102_444_800 * 1_000_000_000


def check_channel(topic: str, message_encoding: str, schema: str, schema_encoding: str
                  ) -> str | None:
    """Why a channel on ``topic`` is not what the log contract says, or None when it is (or
    the topic is not an lgvtool topic)."""
    expected = T.schema_for_topic(topic)
    if expected is None:
        return None
    if (schema, message_encoding, schema_encoding) == (expected, MESSAGE_ENCODING,
                                                       SCHEMA_ENCODING):
        return None
    return (f"topic {topic} carries schema {schema or '(none)'!r} "
            f"(schema encoding {schema_encoding or '(none)'!r}, message encoding "
            f"{message_encoding or '(none)'!r}); lgvtool reads it only as {expected!r} "
            f"({SCHEMA_ENCODING}, {MESSAGE_ENCODING})")


def check_times(topic: str, ns: Iterable[int]) -> None:
    """Raise ValueError naming ``topic`` when a time (ns since the epoch) is implausible."""
    for t in ns:
        if not MIN_TIME_NS <= t <= MAX_TIME_NS:
            raise ValueError(f"topic {topic}: time {t / 1e9:.3f} s since the epoch is outside "
                             "1990..2100")


#: the largest magnitude of a decoded position, speed, angle or range, in its SI unit (m,
#: m/s, rad, rad/s, s): the configuration's bound on every number (docs/config.md); beyond it
#: a value is a corrupt message, and the filters' and fits' arithmetic would overflow
MAX_MAGNITUDE = 1e6


def plausible_poses(x: ArrayLike, y: ArrayLike, heading: ArrayLike
                    ) -> NDArray[np.bool_] | np.bool_:
    """Which poses (x, y in m, heading in rad; arrays or numbers) are finite and at most
    :data:`MAX_MAGNITUDE` in magnitude: a NAV pose that is not is a corrupt reply, taken as
    not valid by the estimators and not drawn by the views. A boolean array (a numpy bool for
    numbers)."""
    import numpy as np

    a = np.abs(np.asarray([x, y, heading], dtype=np.float64))
    ok: NDArray[np.bool_] | np.bool_ = np.all(a <= MAX_MAGNITUDE, axis=0)  # NaN compares false
    return ok


def flags(docs: Sequence[JSONRecord], key: str) -> list[bool]:
    """The boolean field ``key`` of every message; TypeError when one is not a JSON boolean (a
    string "false" would otherwise read as true), KeyError when one lacks it."""
    values = [d[key] for d in docs]
    if not all(v is True or v is False for v in values):
        bad = next(v for v in values if v is not True and v is not False)
        raise TypeError(f"field {key!r} holds {bad!r}, not true or false")
    return cast("list[bool]", values)  # each one True or False, as checked above


def check_magnitude(columns: Mapping[str, ArrayLike | Sequence[JSON]], topic: str = "") -> None:
    """Raise ValueError naming the field (and ``topic`` if given) when a value is larger in
    magnitude than :data:`MAX_MAGNITUDE` (NaN passes)."""
    import numpy as np

    for name, values in columns.items():
        arr = np.abs(np.asarray(values, dtype=np.float64))
        beyond = arr > MAX_MAGNITUDE
        if arr.size and bool(beyond.any()):
            where = f"topic {topic}: " if topic else ""
            raise ValueError(f"{where}field {name!r} holds {float(arr[beyond][0]):g} in "
                             f"magnitude (beyond {MAX_MAGNITUDE:g}: not a plausible value)")


def check_finite(topic: str, columns: Mapping[str, ArrayLike | Sequence[JSON]]) -> None:
    """Raise ValueError naming ``topic`` and the field when a value is NaN, infinite or larger
    in magnitude than :data:`MAX_MAGNITUDE`."""
    import numpy as np

    for name, values in columns.items():
        arr = np.asarray(values, dtype=np.float64)
        if arr.size and not bool(np.isfinite(arr).all()):
            bad = float(arr[~np.isfinite(arr)][0])
            raise ValueError(f"topic {topic}: field {name!r} holds {bad} (not a finite number)")
    check_magnitude(columns, topic)
