"""What ``replay`` draws from a log's own data (docs/log-format.md), drawn message by message
for the live feed: a recording as it arrives, or a raw log played back.

:class:`LiveDrawing` takes the log's ``/nav/pose``, ``/nav/reflectors`` and ``/truth/pose``
messages in arrival order and returns, for each valid NAV pose, the head's pose and frames
(``/nav/head``, ``/nav/tf``); for each ground-truth pose its frames (``/truth/tf``); and for each
scan its reflector observations as one point cloud in the head frame of its source at the
scan's start (``/nav/scan``): ``nav/head``, or, for a log without NAV poses such as an imported
dataset, ``truth/head``, as replay chooses. The messages come from the builders ``replay``
uses (:mod:`lgvtool.log.foxglove`). What a live view cannot know: the head's poses after the
last one received. Each observation is carried to its scan's start along the head poses
received so far (:func:`lgvtool.log.view_channels.carry_to_start`), continued past the last
one at the speed and turn rate of the last two; replay carries it along the poses on both
sides. Times in integer ns since the Unix epoch.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import orjson

from lgvtool.log import foxglove as fx
from lgvtool.log import topics as T
from lgvtool.log.view_channels import (
    Track,
    carry_to_start,
    head_track,
    nav_fields,
    scan_fields,
    truth_fields,
)

#: head poses kept for carrying the observations (at the NAV200's 2-8 Hz, several seconds)
TRACK_POSES = 32

TOPICS: dict[str, str] = {t: T.FIXED[t] for t in (T.NAV_HEAD, T.NAV_TF, T.NAV_SCAN, T.TRUTH_TF)}
"""The channels a :class:`LiveDrawing` publishes: topic -> schema name."""

INPUTS = frozenset({T.NAV_POSE, T.NAV_REFLECTORS, T.TRUTH})
"""The topics it draws from."""


class LiveDrawing:
    """The drawing of the messages fed one at a time (see the module docstring).

    :param mounting: the NAV head's mounting on the vehicle (``vehicle.nav_x``, ``nav_y``,
        ``nav_yaw``).
    :param scans_on: whose head the scans are drawn on: ``"nav"`` (a log with NAV poses) or
        ``"truth"`` (one without, with a ground truth).
    """

    def __init__(self, mounting: fx.Mounting, scans_on: str = "nav") -> None:
        if scans_on not in ("nav", "truth"):
            raise ValueError(f"scans_on must be 'nav' or 'truth', not {scans_on!r}")
        self._m = mounting
        self._scans_on = scans_on
        # the head poses of the source the scans are drawn on (the NAV reports its head;
        # the truth's head is O's pose moved by the mounting)
        self._track: deque[tuple[int, float, float, float]] = deque(maxlen=TRACK_POSES)

    def feed(self, topic: str, data: bytes, log_time_ns: int) -> list[fx.Encoded]:
        """The drawing of one log message (JSON bytes) received at ``log_time_ns``; nothing
        for other topics, an invalid or non-finite pose or a scan without observations."""
        if topic == T.NAV_POSE:
            return self._nav_pose(orjson.loads(data), log_time_ns)
        if topic == T.TRUTH:
            return self._truth_pose(orjson.loads(data), log_time_ns)
        if topic == T.NAV_REFLECTORS:
            return self._scan(orjson.loads(data))
        return []

    def _nav_pose(self, doc: dict[str, Any], log_time_ns: int) -> list[fx.Encoded]:
        (x,), (y,), (h,), (valid,) = nav_fields([doc])
        if not (valid and math.isfinite(x + y + h)):
            return []
        if self._scans_on == "nav":
            self._track.append((log_time_ns, x, y, h))
        return fx.nav_pose_messages(log_time_ns, x, y, h, self._m)

    def _truth_pose(self, doc: dict[str, Any], log_time_ns: int) -> list[fx.Encoded]:
        (x,), (y,), (qz,), (qw,) = truth_fields([doc])
        yaw = 2.0 * math.atan2(qz, qw)
        if not math.isfinite(x + y + yaw):
            return []
        if self._scans_on == "truth":
            (t,), (hx,), (hy,), (hh,) = head_track([log_time_ns], [x], [y], [yaw], self._m)
            self._track.append((int(t), float(hx), float(hy), float(hh)))
        return [fx.encoded(T.TRUTH_TF, fx.frame_transforms(log_time_ns, "truth", x, y, yaw,
                                                           self._m))]

    def _extended(self, until_ns: int) -> Track:
        """The head's poses received so far, continued to ``until_ns`` at the speed and turn
        rate of the last two (the poses after the last one have not arrived yet)."""
        rows = list(self._track)
        if len(rows) >= 2 and until_ns > rows[-1][0] > rows[-2][0]:
            (t0, x0, y0, h0), (t1, x1, y1, h1) = rows[-2], rows[-1]
            f = (until_ns - t1) / (t1 - t0)
            dh = math.remainder(h1 - h0, math.tau)
            rows.append((until_ns, x1 + f * (x1 - x0), y1 + f * (y1 - y0), h1 + f * dh))
        t, x, y, h = (list(c) for c in zip(*rows, strict=True)) if rows else ([], [], [], [])
        return head_track(t, x, y, h, fx.Mounting(0.0, 0.0))  # already the head's poses

    def _scan(self, doc: dict[str, Any]) -> list[fx.Encoded]:
        import numpy as np

        from lgvtool.timestamps import seconds_to_ns_array

        (start,), (count,), *cols = scan_fields([doc])
        if not count:
            return []
        rng, brg, dts = (np.array(cols[k], dtype=np.float64) for k in (0, 1, 3))
        ids = np.array(cols[2], dtype=np.int64)
        firsts = np.full(count, start, dtype=np.int64)
        instants = firsts + seconds_to_ns_array(dts)
        qx, qy = carry_to_start(firsts, instants, rng * np.cos(brg), rng * np.sin(brg),
                                self._extended(int(instants.max())))
        return [fx.encoded(T.NAV_SCAN, fx.scan_cloud(start, qx, qy, ids, self._scans_on))]
