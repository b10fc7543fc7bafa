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
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import orjson

from lgvtool.log import foxglove as fx
from lgvtool.log import topics as T
from lgvtool.log.windows import Source, constant, source

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.log.reader import LogReader


MOVING_SPEED = 0.01
"""Drive speed above which an MCU frame counts for the steering median, m/s."""


def _docs(reader: LogReader, topic: str) -> tuple[list[int], list[dict[str, Any]]]:
    cols = reader.raw_columns([topic]) if reader.has_topic(topic) else {}
    if topic not in cols:
        return [], []
    t, raw = cols[topic]
    loads = orjson.loads
    return [int(v) for v in t.tolist()], [loads(d) for d in raw]


def _floats(docs: list[dict[str, Any]], key: str) -> Any:
    import numpy as np

    return np.array([v if isinstance(v := d.get(key), int | float) else math.nan
                     for d in docs], dtype=np.float64)


def _scan_rows(docs: list[dict[str, Any]]) -> tuple[Any, ...]:
    """The reflector scans of ``docs`` as flat arrays: start (ns), row offsets, then per
    observation range (m), bearing (rad), id and time in scan (s)."""
    import numpy as np

    start = np.array([d["timestamp"]["sec"] * 1_000_000_000 + d["timestamp"]["nsec"]
                      for d in docs], dtype=np.int64)
    obs = [d.get("observations", []) for d in docs]
    offsets = np.zeros(len(obs) + 1, dtype=np.int64)
    np.cumsum([len(o) for o in obs], out=offsets[1:])
    flat = [o for row in obs for o in row]
    rng = np.array([float(o["range"]) for o in flat], dtype=np.float64)
    brg = np.array([float(o["bearing"]) for o in flat], dtype=np.float64)
    ids = np.array([int(o.get("id", -1)) for o in flat], dtype=np.int64)
    dts = np.array([float(o.get("time_in_scan", 0.0)) for o in flat], dtype=np.float64)
    return start, offsets, rng, brg, ids, dts


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
    times, docs = _docs(reader, T.NAV_POSE)
    if docs:
        x, y, h = (_floats(docs, k) for k in ("x", "y", "heading"))
        ok = np.array([bool(d.get("valid")) for d in docs]) & np.isfinite(x + y + h)
        del docs
        t = np.asarray(times, dtype=np.int64)[ok]
        x, y, h = x[ok], y[ok], h[ok]
        if len(t):
            out.append(source(T.NAV_HEAD, t, _poses(t, x, y, h)))
            ox, oy, oh = fx.o_from_head(x, y, h, m)
            out.append(source(T.NAV_TF, t, _frames("nav", t, ox, oy, oh, m)))
    times, docs = _docs(reader, T.NAV_REFLECTORS)
    if docs:
        rows = _scan_rows(docs)
        del docs
        t_scan = np.asarray(times, dtype=np.int64)
        out.append(source(T.NAV_SCAN, t_scan,
                          _scan_encoder(t_scan, rows, "nav" if out else fallback)))
    return out


def truth_stream(reader: LogReader, m: fx.Mounting) -> list[Source]:
    """/truth/tf of every ground-truth pose of O."""
    import numpy as np

    times, docs = _docs(reader, T.TRUTH)
    if not docs:
        return []
    a = np.array([(d["pose"]["position"]["x"], d["pose"]["position"]["y"],
                   d["pose"]["orientation"].get("z", 0.0), d["pose"]["orientation"].get("w", 1.0))
                  for d in docs], dtype=np.float64)
    del docs
    yaw = 2.0 * np.arctan2(a[:, 2], a[:, 3])
    t = np.asarray(times, dtype=np.int64)
    return [source(T.TRUTH_TF, t, _frames("truth", t, a[:, 0].copy(), a[:, 1].copy(), yaw, m))]


def steering_angle(reader: LogReader) -> float | None:
    """Median logged steering angle while driving, rad (None without MCU frames)."""
    import numpy as np

    _times, docs = _docs(reader, T.MCU_FRAME)
    angle = np.array([float(d.get("steering_angle", math.nan)) for d in docs])
    speed = np.array([abs(float(d.get("drive_speed", 0.0))) for d in docs])
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

    times, docs = _docs(reader, T.TRUTH)
    if docs:
        t0 = times[0]
        x = np.array([d["pose"]["position"]["x"] for d in docs], dtype=float)
        y = np.array([d["pose"]["position"]["y"] for d in docs], dtype=float)
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

