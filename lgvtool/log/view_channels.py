"""The channels ``replay`` adds so that Foxglove shows a log in full (docs/log-format.md).

From the log's own data: the NAV's head pose and frames (/nav/head, /nav/tf), each reflector
scan in the head's frame (/nav/scan), the ground truth's frames (/truth/tf) and the reference
circle (/reference/circle); from each estimator's output: its frames and covariance ellipse
(/estimate/NAME/tf, /estimate/NAME/covariance). The messages themselves are built by
:mod:`lgvtool.log.foxglove`, a window of log time at a time (:mod:`lgvtool.log.windows`):
each stream keeps only its numeric rows until then. Times in integer ns since the Unix epoch.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, Protocol

import orjson

from lgvtool.errors import decoding_error
from lgvtool.json_types import JSON, JSONRecord
from lgvtool.log import foxglove as fx
from lgvtool.log import topics as T
from lgvtool.log.messages import (
    PoseInFrameFields,
    ReflectorScanFields,
    steering_fields,
)
from lgvtool.log.validate import check_magnitude, flags, plausible_poses
from lgvtool.log.windows import Source, constant, source
from lgvtool.timestamps import from_stamp

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

    from lgvtool.config import Config
    from lgvtool.log.reader import LogReader, RawBlock
    from lgvtool.log.windows import Encoder

#: the columns of one topic's messages decoded by a ``*_fields`` function (numbers, counts,
#: ids, flags as read: numpy makes them arrays), one list per field
Fields = tuple[Sequence[JSON], ...]


class EstimateTable(Protocol):
    """An estimator's output as the view draws it: ``t_ns`` (ns since the epoch), the pose
    of O (``x``, ``y`` m, ``heading`` rad) and the row-major 3x3 ``covariance`` per row."""

    @property
    def t_ns(self) -> NDArray[np.int64]: ...
    @property
    def x(self) -> NDArray[np.float64]: ...
    @property
    def y(self) -> NDArray[np.float64]: ...
    @property
    def heading(self) -> NDArray[np.float64]: ...
    @property
    def covariance(self) -> NDArray[np.float64]: ...


def nav_fields(docs: Sequence[JSONRecord]
               ) -> tuple[list[float], list[float], list[float], list[bool]]:
    """x, y, heading (m, m, rad; NaN when not a number) and the valid flag of NAV poses
    (TypeError when one is not a boolean, :func:`lgvtool.log.validate.flags`)."""
    return ([_num(d, "x") for d in docs], [_num(d, "y") for d in docs],
            [_num(d, "heading") for d in docs], flags(docs, "valid"))


def scan_fields(docs: Sequence[ReflectorScanFields]
                ) -> tuple[list[int], list[int], list[float], list[float], list[int], list[float]]:
    """Per scan its start (ns) and count; per observation range (m), bearing (rad), id and time
    in scan (s); ValueError for a range beyond :data:`~lgvtool.log.validate.MAX_MAGNITUDE`."""
    obs = [d.get("observations", []) for d in docs]
    flat = [o for os in obs for o in os]
    ranges = [float(o["range"]) for o in flat]
    check_magnitude({"range": ranges})
    return ([from_stamp(d["timestamp"]) for d in docs],
            [len(os) for os in obs], ranges,
            [float(o["bearing"]) for o in flat], [int(o.get("id", -1)) for o in flat],
            [float(o.get("time_in_scan", 0.0)) for o in flat])


def truth_fields(docs: Sequence[PoseInFrameFields]
                 ) -> tuple[list[float], list[float], list[float], list[float]]:
    """x, y (m) and the quaternion's z and w of ground-truth poses; ValueError for a position
    beyond :data:`~lgvtool.log.validate.MAX_MAGNITUDE`."""
    poses = [d["pose"] for d in docs]
    x, y = [p["position"]["x"] for p in poses], [p["position"]["y"] for p in poses]
    check_magnitude({"x": x, "y": y})
    return (x, y, [p["orientation"].get("z", 0.0) for p in poses],
            [p["orientation"].get("w", 1.0) for p in poses])


#: per topic: the function that reads its decoded messages' fields, and each field's column
#: type (d float64, q int64, ? bool)
_FIELDS: dict[str, tuple[Callable[..., Fields], tuple[str, ...]]] = {
    T.NAV_POSE: (nav_fields, ("d", "d", "d", "?")),
    T.NAV_REFLECTORS: (scan_fields, ("q", "q", "d", "d", "q", "d")),
    T.TRUTH: (truth_fields, ("d", "d", "d", "d")),
    T.MCU_FRAME: (steering_fields, ("d", "d"))}


class RowCollector:
    """The raw material of :class:`LogRows`, gathered a chunk at a time (:meth:`add`, one
    chunk's undecoded messages of :attr:`topics`): a tap of
    :func:`lgvtool.localize.logdata.load_log`, so that ``replay`` reads the log once for its
    estimators and its view. ``skip_scans``: the scans come decoded from elsewhere."""

    def __init__(self, reader: LogReader, skip_scans: bool = False) -> None:
        self._path = reader.path
        #: the topics to read (those of the log)
        self.topics = [t for t in _FIELDS if reader.has_topic(t)
                       and not (skip_scans and t == T.NAV_REFLECTORS)]
        self.parts: dict[str, tuple[list[NDArray[np.int64]], list[Fields]]] = {
            t: ([], []) for t in self.topics}

    def add(self, block: RawBlock) -> None:
        """Take one chunk's messages (other topics are passed over), decoded to the
        ``*_fields`` lists; a message that does not match its schema is a
        :class:`~lgvtool.errors.LogFormatError` naming its topic and schema."""
        loads = orjson.loads
        for topic, (times, parts) in self.parts.items():
            found = block.get(topic)
            if found is None:
                continue
            try:
                fields = _FIELDS[topic][0]([loads(d) for d in found[1]])
            except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
                raise decoding_error(self._path, topic, T.schema_for_topic(topic) or "?",
                                     exc) from None
            times.append(found[0])
            parts.append(fields)

    def read(self, reader: LogReader, topics: list[str]) -> None:
        """Read ``topics`` of the log (among those of the view) and gather them."""
        for t in topics:
            self.parts.setdefault(t, ([], []))
        for block in reader.raw_column_chunks(topics) if topics else ():
            self.add(block)


class LogRows:
    """The numeric rows of the log that the view channels draw, read in one pass over the
    log's chunks and decoded a chunk at a time: per topic the log times (ns) and its columns
    (see the ``_*_fields`` functions), in log-time order; topics the log lacks are empty.
    ``scans``: the reflector scans' log times and columns already decoded, in log-time order
    (:meth:`lgvtool.localize.logdata.LazyScans.decoded_columns`), which are then not read
    again; ``collected``: the rows gathered while the log was read for something else (its
    parts are handed over; the scans are read here if neither gives them), else they are read
    here."""

    def __init__(self, reader: LogReader, scans: tuple[Any, ...] | None = None,
                 collected: RowCollector | None = None) -> None:
        import numpy as np

        if collected is None:
            collected = RowCollector(reader, skip_scans=scans is not None)
            collected.read(reader, collected.topics)
        elif scans is None and reader.has_topic(T.NAV_REFLECTORS) and \
                T.NAV_REFLECTORS not in collected.parts:
            # gathered without the scans, which no estimator decoded: read them alone
            collected.read(reader, [T.NAV_REFLECTORS])
        acc, collected.parts = collected.parts, {}
        self._cols: dict[str, tuple[Any, list[Any]]] = {}
        for topic, (_fields, codes) in _FIELDS.items():
            times, parts = acc.pop(topic, ([], []))
            t = np.concatenate(times).astype(np.int64) if times else np.zeros(0, np.int64)
            cols = [np.array([v for p in parts for v in p[c]],
                             dtype=np.int64 if code == "q" else bool if code == "?"
                             else np.float64) for c, code in enumerate(codes)]
            if len(t) > 1 and not bool(np.all(t[1:] >= t[:-1])):
                order = np.argsort(t, kind="stable")
                t = t[order]
                if topic == T.NAV_REFLECTORS:  # per scan columns, then per observation
                    counts = cols[1]
                    offsets = np.concatenate([[0], np.cumsum(counts)])
                    flat = np.concatenate([np.arange(offsets[i], offsets[i + 1])
                                           for i in order.tolist()]).astype(np.intp)
                    cols = [cols[0][order], counts[order]] + [c[flat] for c in cols[2:]]
                else:
                    cols = [c[order] for c in cols]
            self._cols[topic] = (t, cols)
        if scans is not None:
            self._cols[T.NAV_REFLECTORS] = (scans[0], list(scans[1:]))

    def columns(self, topic: str) -> tuple[Any, list[Any]]:
        """Log times (ns) and columns of ``topic``."""
        return self._cols[topic]


def _num(d: JSONRecord, key: str) -> float:
    v = d.get(key)
    return float(v) if isinstance(v, int | float) else math.nan


Track = tuple["NDArray[np.int64]", "NDArray[np.float64]", "NDArray[np.float64]",
              "NDArray[np.float64]"]
"""Poses of a head in the map: times (ns), x, y (m), heading (rad), finite, in time order."""


def head_track(t: ArrayLike, x: ArrayLike, y: ArrayLike, heading: ArrayLike, m: fx.Mounting
               ) -> Track:
    """The head's poses of the poses (t ns, x, y m, heading rad) of O, the rows with a finite
    pose, in time order."""
    import numpy as np

    ta = np.asarray(t, dtype=np.int64)
    xa, ya, ha = (np.asarray(v, dtype=np.float64) for v in (x, y, heading))
    ok = np.isfinite(xa) & np.isfinite(ya) & np.isfinite(ha)
    order = np.argsort(ta[ok], kind="stable")
    ta = ta[ok][order]
    xa, ya, ha = (v[ok][order] for v in (xa, ya, ha))
    c, s = np.cos(ha), np.sin(ha)
    return ta, xa + c * m.x - s * m.y, ya + s * m.x + c * m.y, ha + m.yaw


def carry_to_start(t_start: ArrayLike, t_obs: ArrayLike, px: ArrayLike, py: ArrayLike,
                   track: Track
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Points (px, py m) measured in the head frame at ``t_obs`` (ns), expressed in the head
    frame as it was at ``t_start`` (ns), with the head's ``track`` interpolated linearly
    (the heading unwrapped; held at the track's ends), as Foxglove's 3D panel carries a
    frame between two of its transforms. Unchanged without a track."""
    return Carrier(track)(t_start, t_obs, px, py)


class Carrier:
    """:func:`carry_to_start` along one ``track``, prepared once (its heading unwrapped, its
    time grid) for many calls, e.g. one per window of scans."""

    def __init__(self, track: Track) -> None:
        import numpy as np

        tt, x, y, h = track
        self._t0 = int(tt[0]) if len(tt) else 0
        self._grid = (np.asarray(tt, dtype=np.int64) - self._t0).astype(np.float64)
        self._x, self._y = x, y
        self._h = np.unwrap(h) if len(tt) else h

    def _at(self, t: ArrayLike
            ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The head's pose (x, y m, unwrapped heading rad) at ``t`` (ns)."""
        import numpy as np

        rel = (np.asarray(t, dtype=np.int64) - self._t0).astype(np.float64)
        return (np.interp(rel, self._grid, self._x), np.interp(rel, self._grid, self._y),
                np.interp(rel, self._grid, self._h))

    def __call__(self, t_start: ArrayLike, t_obs: ArrayLike, px: ArrayLike, py: ArrayLike
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """See :func:`carry_to_start`."""
        import numpy as np

        px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
        if not len(self._grid):
            return px, py
        xs, ys, hs = self._at(t_start)
        xo, yo, ho = self._at(t_obs)
        co, so = np.cos(ho), np.sin(ho)
        dx, dy = xo + co * px - so * py - xs, yo + so * px + co * py - ys
        cs, ss = np.cos(hs), np.sin(hs)
        return cs * dx + ss * dy, cs * dy - ss * dx


def _scan_encoder(rows: LogRows, track: Track, source_name: str) -> Encoder:
    """The encoder of /nav/scan: each scan one foxglove.PointCloud in the head frame at its
    start, every observation carried there from its own instant along ``track``. The points
    are computed for the scans of each call only (one window), never for the whole log."""
    import numpy as np

    from lgvtool.timestamps import seconds_to_ns_array

    times, (start, counts, rng, brg, ids, dts) = rows.columns(T.NAV_REFLECTORS)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    carry = Carrier(track)

    def encode(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        n = offsets[idx + 1] - offsets[idx]
        sub = np.concatenate([[0], np.cumsum(n)]).astype(np.int64)
        flat = np.repeat(offsets[idx] - sub[:-1], n) + np.arange(sub[-1])
        first = np.repeat(start[idx], n)
        r, b = rng[flat], brg[flat]
        qx, qy = carry(first, first + seconds_to_ns_array(dts[flat]), r * np.cos(b),
                       r * np.sin(b))
        return times[idx].tolist(), fx.scan_clouds_many(start[idx], sub, qx, qy, ids[flat],
                                                      source_name)
    return encode


def _poses(t: NDArray[np.int64], x: NDArray[np.float64], y: NDArray[np.float64],
           h: NDArray[np.float64]) -> Encoder:
    return lambda idx: (t[idx].tolist(), fx.pose_in_frame_many(t[idx], x[idx], y[idx], h[idx]))


def _frames(name: str, t: NDArray[np.int64], x: NDArray[np.float64], y: NDArray[np.float64],
            h: NDArray[np.float64], m: fx.Mounting) -> Encoder:
    return lambda idx: fx.frame_transforms_many(name, t[idx], x[idx], y[idx], h[idx], m)


def nav_streams(rows: LogRows, m: fx.Mounting, fallback: str = "truth",
                fallback_track: Track | None = None) -> list[Source]:
    """/nav/head and /nav/tf of every valid NAV pose, /nav/scan of every reflector scan,
    drawn in the frame nav/head when the log has a valid NAV pose, else in the head frame of
    ``fallback`` (an imported dataset's sensor reports no pose: its scans ride on the head of
    the ground truth, or of an estimator), whose head poses ``fallback_track`` carries the
    observations to their scan's start."""
    out: list[Source] = []
    t, (x, y, h, valid) = rows.columns(T.NAV_POSE)
    track = fallback_track if fallback_track is not None else head_track([], [], [], [], m)
    if len(t):
        ok = valid & plausible_poses(x, y, h)
        t, x, y, h = t[ok], x[ok], y[ok], h[ok]
        if len(t):
            out.append(source(T.NAV_HEAD, t, _poses(t, x, y, h)))
            ox, oy, oh = fx.o_from_head(x, y, h, m)
            out.append(source(T.NAV_TF, t, _frames("nav", t, ox, oy, oh, m)))
            track = head_track(t, x, y, h, fx.Mounting(0.0, 0.0))  # the NAV reports its head
    t_scan = rows.columns(T.NAV_REFLECTORS)[0]
    if len(t_scan):
        out.append(source(T.NAV_SCAN, t_scan,
                          _scan_encoder(rows, track, "nav" if out else fallback)))
    return out


def _truth_rows(rows: LogRows) -> tuple[NDArray[np.int64], NDArray[np.float64],
                                        NDArray[np.float64], NDArray[np.float64]]:
    """Log times (ns), x, y (m) and yaw (rad) of every ground-truth pose of O."""
    import numpy as np

    t, (x, y, qz, qw) = rows.columns(T.TRUTH)
    return t, x, y, 2.0 * np.arctan2(qz, qw)


def truth_stream(rows: LogRows, m: fx.Mounting) -> list[Source]:
    """/truth/tf of every ground-truth pose of O."""
    t, x, y, yaw = _truth_rows(rows)
    if not len(t):
        return []
    return [source(T.TRUTH_TF, t, _frames("truth", t, x, y, yaw, m))]


def steering_angle(rows: LogRows) -> float | None:
    """Median logged steering angle while driving, rad (None without MCU frames)."""
    from lgvtool.circle import median_steering

    _t, (angle, speed) = rows.columns(T.MCU_FRAME)
    return median_steering(angle, speed)


CIRCLE_COVERAGE = 1.5 * math.pi
"""How far round its circle a drive must go for the circle to be drawn, rad (3/4 of a turn)."""


def reference_stream(rows: LogRows, config: Config,
                     tables: Mapping[str, EstimateTable]) -> list[Source]:
    """/reference/circle: the circle the drive follows, once at the start of the trajectory it
    is fitted to (the ground truth, else the laser estimate, else the first estimator's),
    with the kinematic radius R = h / tan(steering) when the steering is known (logged, else
    configured), free otherwise. None when the drive is not a circle."""
    import numpy as np

    t_truth, x, y, _yaw = _truth_rows(rows)
    if len(t_truth):
        t0 = int(t_truth[0])
        label = "reference (truth)"
    else:
        name = "laser" if "laser" in tables else next(iter(tables), None)
        if name is None or len(tables[name].x) == 0:
            return []
        tab = tables[name]
        t0, x, y = int(tab.t_ns[0]), np.asarray(tab.x), np.asarray(tab.y)
        label = f"reference ({name})"
    delta = steering_angle(rows)
    if delta is None and config.reference.steering_angle_deg is not None:
        delta = math.radians(config.reference.steering_angle_deg)
    msg = reference_message(t0, x, y, label, config.vehicle.h, delta)
    return [] if msg is None else [constant(T.REFERENCE, [t0], [msg])]


def reference_message(t_ns: int, x: ArrayLike, y: ArrayLike, label: str, h: float,
                      steering: float | None) -> bytes | None:
    """The /reference/circle message (JSON, stamped ``t_ns``) of the circle fitted to the
    positions ``x``, ``y`` (m; non-finite ones left out): of the kinematic radius
    R = ``h`` / tan(``steering``) (m, rad) when the steering is known, free when None. None
    when fewer than 3 positions are left, no circle fits, they do not follow one
    (:func:`lgvtool.circle.follows_circle`) or do not go :data:`CIRCLE_COVERAGE` round it."""
    import numpy as np

    from lgvtool.circle import TRIM, fit_circle, follows_circle, kinematic_radius
    from lgvtool.errors import InputError

    xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    ok = np.isfinite(xa) & np.isfinite(ya)
    if ok.sum() < 3:
        return None
    radius = kinematic_radius(h, steering) if steering is not None else None
    if radius is not None and not math.isfinite(radius):
        return None
    try:
        c = fit_circle(xa[ok], ya[ok], radius, trim=TRIM)
    except (InputError, ValueError, ArithmeticError):  # no circle fits: none is drawn
        return None
    rmse = float(np.sqrt(np.mean(c.radial_error(xa[ok], ya[ok]) ** 2)))
    if not math.isfinite(c.r) or not follows_circle(rmse, c.r):
        return None
    # the positions go round the circle: no angular gap about its centre wider than the
    # circle's part they may leave out (a gentle curve fits a circle of kilometres)
    around = np.sort(np.arctan2(ya[ok] - c.cy, xa[ok] - c.cx))
    gap = max(float(np.diff(around).max(initial=0.0)), float(around[0] + math.tau - around[-1]))
    if gap > math.tau - CIRCLE_COVERAGE:
        return None
    return orjson.dumps(fx.reference_circle(t_ns, c.cx, c.cy, c.r, label=label))


def estimate_streams(name: str, tab: EstimateTable, m: fx.Mounting) -> list[Source]:
    """/estimate/NAME/tf and /estimate/NAME/covariance of an estimate table (rows with a
    finite pose; covariance ellipses also need a finite covariance)."""
    import numpy as np

    t = np.asarray(tab.t_ns, dtype=np.int64)
    x, y = np.asarray(tab.x, dtype=np.float64), np.asarray(tab.y, dtype=np.float64)
    h = np.asarray(tab.heading, dtype=np.float64)
    cov = np.asarray(tab.covariance, dtype=np.float64).reshape(len(t), 9)
    return [source(T.estimate_tf(name), t, _frames(name, t, x, y, h, m)),
            source(T.estimate_covariance(name), t,
                   lambda idx: fx.covariance_ellipse_many(name, t[idx], x[idx], y[idx],
                                                          cov[idx]))]


def view_streams(reader: LogReader, config: Config, tables: Mapping[str, EstimateTable],
                 rows: LogRows | None = None) -> list[Source]:
    """Every Foxglove view channel of a replayed log: from the log (NAV, truth, reference
    circle) and from the estimators' ``tables`` (frames and covariance ellipses); ``rows``:
    the log's rows already gathered (else they are read here)."""
    m = fx.mounting_of(config.vehicle)
    rows = rows if rows is not None else LogRows(reader)
    track: Track | None = None
    if reader.has_topic(T.TRUTH):
        fallback, track = "truth", head_track(*_truth_rows(rows), m)
    else:
        fallback = next(iter(tables), "nav")
        if fallback in tables:
            tab = tables[fallback]
            track = head_track(tab.t_ns, tab.x, tab.y, tab.heading, m)
    out = (nav_streams(rows, m, fallback, track) + truth_stream(rows, m)
           + reference_stream(rows, config, tables))
    for name, tab in tables.items():
        out += estimate_streams(name, tab, m)
    return out
