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
sides.

Given the vehicle's steering geometry, it also draws the reference circle
(``/reference/circle``) as replay does (:func:`lgvtool.log.view_channels.reference_message`),
fitted every :data:`CIRCLE_PERIOD_NS` of log time to the drive so far: to the ground truth's
positions when the log has them, else to O's positions from the NAV poses (replay fits the
laser estimate, which is those positions), with the kinematic radius from the median logged
steering angle (``/mcu/frame``), else the configured one. Replay fits the whole drive once;
live, the circle is refined as the drive goes on, and one that does not follow a circle (yet)
is not drawn (the last one drawn stays). Times in integer ns since the Unix epoch.
"""

from __future__ import annotations

import math
from array import array
from collections import deque
from typing import TYPE_CHECKING

import orjson

from lgvtool.json_types import JSONRecord
from lgvtool.log import foxglove as fx
from lgvtool.log import topics as T
from lgvtool.log.messages import PoseInFrameFields, ReflectorScanFields, steering_fields
from lgvtool.log.validate import plausible_poses
from lgvtool.log.view_channels import (
    Track,
    carry_to_start,
    head_track,
    nav_fields,
    reference_message,
    scan_fields,
    truth_fields,
)

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.config import Config

#: head poses kept for carrying the observations (at the NAV200's 2-8 Hz, several seconds)
TRACK_POSES = 32

#: log time between two fits of the reference circle, ns
CIRCLE_PERIOD_NS = 5_000_000_000

#: positions (and steering samples) kept for the circle's fit: beyond, every other one is
#: dropped (a fit of 2000 positions takes about 1 ms)
CIRCLE_SAMPLES = 2000

TOPICS: dict[str, str] = {t: T.FIXED[t] for t in (T.NAV_HEAD, T.NAV_TF, T.NAV_SCAN, T.TRUTH_TF,
                                                  T.REFERENCE)}
"""The channels a :class:`LiveDrawing` publishes: topic -> schema name."""

INPUTS = frozenset({T.NAV_POSE, T.NAV_REFLECTORS, T.TRUTH, T.MCU_FRAME})
"""The topics it draws from."""


class Thinned:
    """Samples of a few columns, at most ``limit`` kept, spread evenly over all offered: the
    ones whose number (from 0) is a multiple of a stride, which doubles (every other kept one
    dropped) whenever ``limit`` are held."""

    def __init__(self, columns: int, limit: int = CIRCLE_SAMPLES) -> None:
        if limit < 2:
            raise ValueError("limit must be at least 2")
        self._cols = [array("d") for _ in range(columns)]
        self._limit = limit
        self._stride = 1
        self._offered = 0

    def offer(self, *values: float) -> None:
        """One sample (one value per column)."""
        n = self._offered
        self._offered += 1
        if n % self._stride:
            return
        for col, v in zip(self._cols, values, strict=True):
            col.append(v)
        if len(self._cols[0]) >= self._limit:
            self._cols = [col[::2] for col in self._cols]
            self._stride *= 2

    def __len__(self) -> int:
        return len(self._cols[0])

    def columns(self) -> list[NDArray[np.float64]]:
        """The kept samples, one float64 array per column."""
        import numpy as np

        return [np.array(col, dtype=np.float64) for col in self._cols]


class LiveDrawing:
    """The drawing of the messages fed one at a time (see the module docstring).

    :param mounting: the NAV head's mounting on the vehicle (``vehicle.nav_x``, ``nav_y``,
        ``nav_yaw``).
    :param scans_on: whose head the scans are drawn on: ``"nav"`` (a log with NAV poses) or
        ``"truth"`` (one without, with a ground truth).
    :param h: the distance from the rotation centre O to the steered wheel (``vehicle.h``,
        m): the reference circle is drawn when given.
    :param steering: the configured steering angle (rad; ``reference.steering_angle_deg``),
        used while no MCU frame with a steering angle has arrived; None: the circle's radius is
        then fitted freely.
    """

    def __init__(self, mounting: fx.Mounting, scans_on: str = "nav", *,
                 h: float | None = None, steering: float | None = None) -> None:
        if scans_on not in ("nav", "truth"):
            raise ValueError(f"scans_on must be 'nav' or 'truth', not {scans_on!r}")
        self._m = mounting
        self._scans_on = scans_on
        self._h = h
        self._steering = steering
        # positions (x, y of O, m) for the circle, of the truth and of the NAV poses
        self._positions = {"truth": Thinned(2), "nav": Thinned(2)}
        self._steer = Thinned(2)  # steering angle (rad) and drive speed (m/s) of MCU frames
        self._fitted_ns: int | None = None  # the last fit's log time
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
        if topic == T.MCU_FRAME and self._h is not None:
            (angle,), (speed,) = steering_fields([orjson.loads(data)])
            if math.isfinite(angle):
                self._steer.offer(angle, speed)
        return []

    def _circle(self, source: str, x: float, y: float, log_time_ns: int) -> list[fx.Encoded]:
        """Note the position ``x``, ``y`` of O (m) of ``source`` ("truth" or "nav"); the
        reference circle when a fit is due."""
        if self._h is None:
            return []
        self._positions[source].offer(x, y)
        if self._fitted_ns is not None and log_time_ns - self._fitted_ns < CIRCLE_PERIOD_NS:
            return []
        source = "truth" if len(self._positions["truth"]) else "nav"
        if len(self._positions[source]) < 3:
            return []
        self._fitted_ns = log_time_ns
        px, py = self._positions[source].columns()
        steering = self._steering
        if len(self._steer):
            from lgvtool.circle import median_steering

            angle, speed = self._steer.columns()
            steering = median_steering(angle, speed)
        msg = reference_message(log_time_ns, px, py, f"reference ({source})", self._h, steering)
        return [] if msg is None else [fx.Encoded(T.REFERENCE, T.FIXED[T.REFERENCE], msg)]

    def _nav_pose(self, doc: JSONRecord, log_time_ns: int) -> list[fx.Encoded]:
        (x,), (y,), (h,), (valid,) = nav_fields([doc])
        if not (valid and plausible_poses(x, y, h)):
            return []
        if self._scans_on == "nav":
            self._track.append((log_time_ns, x, y, h))
        out = fx.nav_pose_messages(log_time_ns, x, y, h, self._m)
        if self._h is not None:
            ox, oy, _oh = fx.o_from_head(x, y, h, self._m)
            out += self._circle("nav", float(ox), float(oy), log_time_ns)
        return out

    def _truth_pose(self, doc: PoseInFrameFields, log_time_ns: int) -> list[fx.Encoded]:
        (x,), (y,), (qz,), (qw,) = truth_fields([doc])
        yaw = 2.0 * math.atan2(qz, qw)
        if not math.isfinite(x + y + yaw):
            return []
        if self._scans_on == "truth":
            (t,), (hx,), (hy,), (hh,) = head_track([log_time_ns], [x], [y], [yaw], self._m)
            self._track.append((int(t), float(hx), float(hy), float(hh)))
        return [fx.encoded(T.TRUTH_TF, fx.frame_transforms(log_time_ns, "truth", x, y, yaw,
                                                           self._m)),
                *self._circle("truth", x, y, log_time_ns)]

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

    def _scan(self, doc: ReflectorScanFields) -> list[fx.Encoded]:
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


def drawing_of(config: Config, scans_on: str = "nav") -> LiveDrawing:
    """The :class:`LiveDrawing` of a vehicle's configuration (:class:`lgvtool.config.Config`):
    its NAV mounting, and its steering geometry for the reference circle."""
    d = config.reference.steering_angle_deg
    return LiveDrawing(fx.mounting_of(config.vehicle), scans_on, h=float(config.vehicle.h),
                       steering=None if d is None else math.radians(d))
