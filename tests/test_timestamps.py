"""The one time-stamp module: ns <-> {sec, nsec}, for one value and for columns."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from lgvtool.timestamps import (
    from_stamp,
    message_stamp_ns,
    message_stamps_ns,
    seconds_to_ns,
    seconds_to_ns_array,
    stamp,
    stamp_columns,
    stamp_seconds,
)


def test_one_value_round_trips() -> None:
    for ns in (0, 1, 999_999_999, 1_704_067_200_076_765_800, -1):
        assert from_stamp(stamp(ns)) == ns
        nsec = stamp(ns)["nsec"]
        assert isinstance(nsec, int) and 0 <= nsec < 1_000_000_000
    assert stamp(1_500_000_000) == {"sec": 1, "nsec": 500_000_000}
    assert stamp_seconds({"sec": 2, "nsec": 250_000_000}) == 2.25
    assert math.isnan(stamp_seconds(None))
    assert seconds_to_ns(1.5) == 1_500_000_000


def test_columns_agree_with_one_value() -> None:
    t = [0, 1_999_999_999, 1_704_067_200_076_765_800]
    secs, nsecs = stamp_columns(t)
    assert [{"sec": s, "nsec": n} for s, n in zip(secs, nsecs, strict=True)] == [stamp(x) for x in t]
    s = np.array([0.25, 1.0000000004, 1248444175.000001])
    assert seconds_to_ns_array(s).tolist()[:2] == [seconds_to_ns(0.25), seconds_to_ns(1.0000000004)]
    # to the microsecond: exact for Unix times in float64
    assert seconds_to_ns_array(s, 1000).tolist()[2] == 1248444175000001000


def test_a_message_without_its_own_stamp_takes_its_log_time() -> None:
    docs: list[dict[str, Any]] = [{"timestamp": {"sec": 3, "nsec": 7}}, {"x": 1.0},
                                  {"timestamp": None}]
    log_ns = np.array([10, 20, 30], dtype=np.int64)
    assert message_stamps_ns(docs, log_ns).tolist() == [3_000_000_007, 20, 30]
    assert message_stamps_ns(docs[:1], log_ns[:1]).tolist() == [3_000_000_007]
    assert [message_stamp_ns(d, int(n)) for d, n in zip(docs, log_ns, strict=True)] == \
        [3_000_000_007, 20, 30]
    assert message_stamp_ns({"timestamp": {"sec": "x", "nsec": 0}}, 5) == 5
