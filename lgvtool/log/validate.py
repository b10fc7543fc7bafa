"""Checks of what a log holds against the log contract (docs/log-format.md): the schema and
encodings of each lgvtool topic, and the range of decoded values.

Pure functions; the reader raises :class:`lgvtool.errors.LogFormatError` with their text.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from lgvtool.log import topics as T

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


def check_finite(topic: str, columns: Mapping[str, Sequence[float] | Any]) -> None:
    """Raise ValueError naming ``topic`` and the field when a value is NaN or infinite."""
    import numpy as np

    for name, values in columns.items():
        arr = np.asarray(values, dtype=np.float64)
        if arr.size and not bool(np.isfinite(arr).all()):
            bad = float(arr[~np.isfinite(arr)][0])
            raise ValueError(f"topic {topic}: field {name!r} holds {bad} (not a finite number)")
