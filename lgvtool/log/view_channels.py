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
from array import array
from collections.abc import Iterator, Mapping
from typing import TYPE_CHECKING, Any

import orjson

from lgvtool.log import foxglove as fx
from lgvtool.log import topics as T
from lgvtool.log.windows import Source, constant, source
from lgvtool.timestamps import from_stamp

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.log.reader import LogReader


MOVING_SPEED = 0.01
"""Drive speed above which an MCU frame counts for the steering median, m/s."""


def _each(reader: LogReader, topic: str) -> Iterator[tuple[int, dict[str, Any]]]:
    """(log time ns, decoded message) of every message of ``topic``, one at a time (a long
    log's messages are never all decoded at once)."""
    if not reader.has_topic(topic):
        return
    loads = orjson.loads
    for m in reader.raw_messages([topic]):
        yield m.log_time_ns, loads(m.data)


def _num(d: dict[str, Any], key: str) -> float:
    v = d.get(key)
    return float(v) if isinstance(v, int | float) else math.nan


def _scan_rows(reader: LogReader) -> tuple[Any, ...]:
    """The reflector scans of the log as flat arrays: log time (ns), start (ns), row offsets,
    then per observation range (m), bearing (rad), id and time in scan (s)."""
    import numpy as np

    times, start, offsets = array("q"), array("q"), array("q", [0])
    rng, brg, ids, dts = array("d"), array("d"), array("q"), array("d")
    for t, d in _each(reader, T.NAV_REFLECTORS):
        times.append(t)
        start.append(from_stamp(d["timestamp"]))
        obs = d.get("observations", [])
        offsets.append(offsets[-1] + len(obs))
        for o in obs:
            rng.append(float(o["range"]))
            brg.append(float(o["bearing"]))
            ids.append(int(o.get("id", -1)))
            dts.append(float(o.get("time_in_scan", 0.0)))
    return (np.array(times, dtype=np.int64), np.array(start, dtype=np.int64),
            np.array(offsets, dtype=np.int64), np.array(rng, dtype=np.float64),
            np.array(brg, dtype=np.float64), np.array(ids, dtype=np.int64),
            np.array(dts, dtype=np.float64))


def _scan_encoder(t: NDArray[np.int64], rows: tuple[Any, ...], source_name: str) -> Any:
    start, offsets, rng, brg, ids, dts = rows

    def encode(idx: NDArray[np.intp]) -> tuple[list[int], list[bytes]]:
        scans = [(int(start[i]), rng[offsets[i]:offsets[i + 1]], brg[offsets[i]:offsets[i + 1]],
                  ids[offsets[i]:offsets[i + 1]], dts[offsets[i]:offsets[i + 1]])
                 for i in idx.tolist()]
        return t[idx].tolist(), fx.scan_scenes_many(scans, source_name)
    return encode


def _poses(t: NDArray[np.int64], x: Any, y: Any, h: Any) -> Any:
    return lambda idx: (t[idx].tolist(), fx.pose_in_frame_many(t[idx], x[idx], y[idx], h[idx]))


def _frames(name: str, t: NDArray[np.int64], x: Any, y: Any, h: Any, m: fx.Mounting) -> Any:
    return lambda idx: fx.frame_transforms_many(name, t[idx], x[idx], y[idx], h[idx], m)


def nav_streams(reader: LogReader, m: fx.Mounting, fallback: str = "truth") -> list[Source]:
    """/nav/head and /nav/tf of every valid NAV pose, /nav/scan of every reflector scan,
    drawn in the frame nav/head when the log has a valid NAV pose, else in the head frame of
    ``fallback`` (an imported dataset's sensor reports no pose: its scans ride on the head of
    the ground truth, or of an estimator)."""
    import numpy as np

    out: list[Source] = []
    rows = [(t, _num(d, "x"), _num(d, "y"), _num(d, "heading"), bool(d.get("valid")))
            for t, d in _each(reader, T.NAV_POSE)]
    if rows:
        x, y, h = (np.array([r[k] for r in rows], dtype=np.float64) for k in (1, 2, 3))
        ok = np.array([r[4] for r in rows]) & np.isfinite(x + y + h)
        t = np.array([r[0] for r in rows], dtype=np.int64)[ok]
        del rows
        x, y, h = x[ok], y[ok], h[ok]
        if len(t):
            out.append(source(T.NAV_HEAD, t, _poses(t, x, y, h)))
            ox, oy, oh = fx.o_from_head(x, y, h, m)
            out.append(source(T.NAV_TF, t, _frames("nav", t, ox, oy, oh, m)))
    t_scan, *scans = _scan_rows(reader)
    if len(t_scan):
        out.append(source(T.NAV_SCAN, t_scan,
                          _scan_encoder(t_scan, tuple(scans), "nav" if out else fallback)))
    return out


def _truth_rows(reader: LogReader) -> tuple[Any, Any, Any, Any]:
    """Log times (ns), x, y (m) and yaw (rad) of every ground-truth pose of O."""
    import numpy as np

    t, x, y, qz, qw = array("q"), array("d"), array("d"), array("d"), array("d")
    for ns, d in _each(reader, T.TRUTH):
        pose = d["pose"]
        t.append(ns)
        x.append(pose["position"]["x"])
        y.append(pose["position"]["y"])
        qz.append(pose["orientation"].get("z", 0.0))
        qw.append(pose["orientation"].get("w", 1.0))
    yaw = 2.0 * np.arctan2(np.array(qz, dtype=np.float64), np.array(qw, dtype=np.float64))
    return (np.array(t, dtype=np.int64), np.array(x, dtype=np.float64),
            np.array(y, dtype=np.float64), yaw)


def truth_stream(reader: LogReader, m: fx.Mounting) -> list[Source]:
    """/truth/tf of every ground-truth pose of O."""
    t, x, y, yaw = _truth_rows(reader)
    if not len(t):
        return []
    return [source(T.TRUTH_TF, t, _frames("truth", t, x, y, yaw, m))]


def steering_angle(reader: LogReader) -> float | None:
    """Median logged steering angle while driving, rad (None without MCU frames)."""
    import numpy as np

    angles, speeds = array("d"), array("d")
    for _t, d in _each(reader, T.MCU_FRAME):
        angles.append(float(d.get("steering_angle", math.nan)))
        speeds.append(abs(float(d.get("drive_speed", 0.0))))
    angle, speed = np.array(angles, dtype=np.float64), np.array(speeds, dtype=np.float64)
    ok = np.isfinite(angle)
    if (ok & (speed > MOVING_SPEED)).any():
        ok &= speed > MOVING_SPEED
    return float(np.median(angle[ok])) if ok.any() else None


def reference_stream(reader: LogReader, config: Any,
                     tables: Mapping[str, Any]) -> list[Source]:
    """/reference/circle: the circle the drive follows, once at the start of the trajectory it
    is fitted to (the ground truth, else the laser estimate, else the first estimator's),
    with the kinematic radius R = h / tan(steering) when the steering is known (logged, else
    configured), free otherwise. None when the drive is not a circle."""
    import numpy as np

    from lgvtool.errors import InputError
    from lgvtool.evaluate.circle import fit_circle
    from lgvtool.evaluate.reference import NOT_A_CIRCLE, TRIM, kinematic_radius

    t_truth, x, y, _yaw = _truth_rows(reader)
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
    ok = np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 3:
        return []
    delta = steering_angle(reader)
    if delta is None and config.reference.steering_angle_deg is not None:
        delta = math.radians(config.reference.steering_angle_deg)
    radius = kinematic_radius(config.vehicle.h, delta) if delta is not None else None
    if radius is not None and not math.isfinite(radius):
        return []
    try:
        c = fit_circle(x[ok], y[ok], radius, trim=TRIM)
    except (InputError, ValueError, ArithmeticError):  # no circle fits: none is drawn
        return []
    rmse = float(np.sqrt(np.mean(c.radial_error(x[ok], y[ok]) ** 2)))
    if not math.isfinite(c.r) or rmse > max(NOT_A_CIRCLE * c.r, 0.1):
        return []
    msg = fx.reference_circle(t0, c.cx, c.cy, c.r, label=label)
    return [constant(T.REFERENCE, [t0], [orjson.dumps(msg)])]


def estimate_streams(name: str, tab: Any, m: fx.Mounting) -> list[Source]:
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


def view_streams(reader: LogReader, config: Any, tables: Mapping[str, Any]) -> list[Source]:
    """Every Foxglove view channel of a replayed log: from the log (NAV, truth, reference
    circle) and from the estimators' ``tables`` (frames and covariance ellipses)."""
    m = fx.mounting_of(config.vehicle)
    fallback = "truth" if reader.has_topic(T.TRUTH) else next(iter(tables), "nav")
    out = (nav_streams(reader, m, fallback) + truth_stream(reader, m)
           + reference_stream(reader, config, tables))
    for name, tab in tables.items():
        out += estimate_streams(name, tab, m)
    return out

