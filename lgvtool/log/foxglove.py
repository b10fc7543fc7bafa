"""Domain values -> the messages Foxglove draws: the one mapping of lgvtool's poses, scans,
covariances and reference circle to Foxglove's published schemas.

Frames: ``map`` is the world; each pose source (``nav`` for the NAV's reported pose, ``truth``,
and every estimator by name) has the frame ``SOURCE/O`` of its point O and, below it,
``SOURCE/head`` of the NAV head at the mounting (``vehicle.nav_x``, ``nav_y``). Lengths in m,
angles in rad, times in integer ns since the Unix epoch.

Each builder returns a message dict laid out as Foxglove's schema; :func:`encoded` turns one
into ``(topic, schema name, JSON bytes)`` for a log writer or a live server. The ``*_many``
functions are the fast paths for arrays of values (what ``replay`` writes): one JSON text per
row, the same message as the builder's for that row (their equality is tested).
"""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, NamedTuple, Protocol

import orjson

from lgvtool import colours
from lgvtool.angles import wrap_angle
from lgvtool.json_types import JSON, JSONObject
from lgvtool.log import topics
from lgvtool.log.messages import FRAME_ID, pose, quaternion_from_yaw
from lgvtool.timestamps import stamp, stamp_columns

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import ArrayLike, NDArray

MAP_FRAME = FRAME_ID
"""The world frame: the reflector map's."""

SIGMAS = 2.0
"""Half-axes of a drawn covariance ellipse, in standard deviations (2: about 86 % of the
positions of a 2-D Gaussian fall inside)."""

ELLIPSE_HEIGHT = 0.02
"""Thickness of a drawn covariance ellipse (a flattened sphere), m."""

SCAN_POINT_FIELDS: tuple[tuple[str, int, int], ...] = (
    ("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("red", 12, 1), ("green", 13, 1), ("blue", 14, 1),
    ("alpha", 15, 1), ("id", 16, 6))
"""The fields of a /nav/scan point: name, byte offset and foxglove.NumericType (7 FLOAT32,
1 UINT8, 6 INT32); x, y, z in m in the head frame, the colour 0..255, the reflector id or -1."""
SCAN_POINT_STRIDE = 20
"""Bytes per /nav/scan point."""
_SCAN_DTYPE = [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgba", "u1", (4,)), ("id", "<i4")]

PALETTE: dict[str, tuple[float, float, float]] = {
    "truth": colours.rgb(colours.TRUTH_ON_DARK),
    **{source: colours.rgb(c) for source, c in colours.SOURCE_COLOURS.items()},
}
"""RGB (0..1) of each known source, from lgvtool's one colour table (:mod:`lgvtool.colours`,
shared with the report and docs/foxglove-layout.json); others take :data:`OTHER`."""
OTHER = colours.rgb(colours.OTHER_COLOUR)


class Mounting(NamedTuple):
    """Where the NAV head sits in the vehicle frame of O: x forward, y left (m), yaw (rad)."""

    x: float
    y: float
    yaw: float = 0.0


class Encoded(NamedTuple):
    """One message ready for a writer or a live server."""

    topic: str
    schema: str
    data: bytes


class HeadMounted(Protocol):
    """A vehicle whose NAV head sits at (``nav_x``, ``nav_y``) m in the frame of O (a
    :class:`lgvtool.config.Vehicle`); a ``nav_yaw`` (rad) attribute is read when it has one."""

    @property
    def nav_x(self) -> float: ...
    @property
    def nav_y(self) -> float: ...


def mounting_of(vehicle: HeadMounted) -> Mounting:
    """The head mounting of a :class:`lgvtool.config.Vehicle` (``nav_yaw`` if it has one)."""
    return Mounting(float(vehicle.nav_x), float(vehicle.nav_y),
                    float(getattr(vehicle, "nav_yaw", 0.0)))


def o_frame(source: str) -> str:
    """Frame of the point O of ``source`` ('nav', 'truth' or an estimator name)."""
    return f"{source}/O"


def head_frame(source: str) -> str:
    """Frame of the NAV head on the vehicle of ``source``."""
    return f"{source}/head"


def color(source: str, alpha: float = 1.0) -> JSONObject:
    """foxglove.Color of ``source``."""
    r, g, b = PALETTE.get(source, OTHER)
    return {"r": r, "g": g, "b": b, "a": alpha}


def o_from_head(x: ArrayLike, y: ArrayLike, heading: ArrayLike, m: Mounting
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Pose of O (m, m, rad in (-pi, pi]) of a vehicle whose head is at (x, y, heading):
    scalars or arrays (numpy's)."""
    import numpy as np

    th = np.asarray(heading, dtype=np.float64) - m.yaw
    c, s = np.cos(th), np.sin(th)
    return (np.asarray(x) - c * m.x + s * m.y, np.asarray(y) - s * m.x - c * m.y,
            wrap_angle(th))


def encoded(topic: str, message: Mapping[str, object]) -> Encoded:
    """``(topic, schema, JSON)`` of a message on a topic of the log contract."""
    schema = topics.schema_for_topic(topic)
    if schema is None:
        raise ValueError(f"topic {topic!r} is not part of the lgvtool log contract")
    return Encoded(topic, schema, orjson.dumps(message))


# ---------------------------------------------------------------------- builders


def transform(ns: int, parent: str, child: str, x: float, y: float, yaw: float
              ) -> JSONObject:
    """A foxglove.FrameTransform: ``child`` at (x, y) m, rotated ``yaw`` rad, in ``parent``."""
    return {"timestamp": stamp(ns), "parent_frame_id": parent, "child_frame_id": child,
            "translation": {"x": x, "y": y, "z": 0.0}, "rotation": quaternion_from_yaw(yaw)}


def frame_transforms(ns: int, source: str, x: float, y: float, heading: float, m: Mounting
                     ) -> JSONObject:
    """A foxglove.FrameTransforms: map -> ``source``/O at the pose of O, and O -> head."""
    return {"transforms": [transform(ns, MAP_FRAME, o_frame(source), x, y, heading),
                           transform(ns, o_frame(source), head_frame(source), m.x, m.y,
                                     m.yaw)]}


def _entity(ns: int, frame: str, entity_id: str, **shapes: list[JSON]
            ) -> JSONObject:
    """A foxglove.SceneEntity that lasts until replaced (same id) and holds ``shapes``."""
    e: JSONObject = {"timestamp": stamp(ns), "frame_id": frame, "id": entity_id,
                         "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False,
                         "metadata": []}
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts",
                 "models"):
        e[kind] = shapes.get(kind, [])
    return e


def scene(*entities: JSONObject) -> JSONObject:
    """A foxglove.SceneUpdate adding or replacing ``entities``."""
    return {"deletions": [], "entities": list(entities)}


def ellipse_axes(sxx: float, sxy: float, syy: float) -> tuple[float, float, float]:
    """Standard deviations along the major and minor axes (m) and the major axis' angle (rad)
    of the 2-D covariance [[sxx, sxy], [sxy, syy]] (m^2)."""
    mid, half = 0.5 * (sxx + syy), 0.5 * (sxx - syy)
    rad = math.hypot(half, sxy)
    return (math.sqrt(max(mid + rad, 0.0)), math.sqrt(max(mid - rad, 0.0)),
            0.5 * math.atan2(2.0 * sxy, sxx - syy))


def covariance_ellipse(ns: int, source: str, x: float, y: float, covariance: Sequence[float]
                       ) -> JSONObject:
    """A foxglove.SceneUpdate drawing the position covariance of ``source``'s O at (x, y) as a
    flat ellipse of :data:`SIGMAS` standard deviations in the map frame. ``covariance``: the
    row-major 3x3 of (x, y, heading) (m^2, m*rad, rad^2)."""
    a, b, angle = ellipse_axes(float(covariance[0]), float(covariance[1]),
                               float(covariance[4]))
    sphere: JSONObject = {"pose": {"position": {"x": x, "y": y, "z": 0.0},
                       "orientation": quaternion_from_yaw(angle)},
              "size": {"x": 2.0 * SIGMAS * a, "y": 2.0 * SIGMAS * b, "z": ELLIPSE_HEIGHT},
              "color": color(source, 0.35)}
    return scene(_entity(ns, MAP_FRAME, f"{source}/covariance", spheres=[sphere]))


def _rgba8(source: str, known: bool) -> tuple[int, int, int, int]:
    """RGBA (0..255) of a scan point: ``source``'s colour when the reflector is known, grey
    otherwise."""
    r, g, b = PALETTE.get(source if known else "deadreckoning", OTHER)  # as color(), alpha 1
    return round(255 * r), round(255 * g), round(255 * b), 255


def scan_points(x: ArrayLike, y: ArrayLike, ids: ArrayLike, source: str = "nav") -> bytes:
    """The packed points of :data:`SCAN_POINT_FIELDS` (``SCAN_POINT_STRIDE`` bytes each, little
    endian) of reflector observations at (x, y) m in the head frame, with their ids (or -1)."""
    import numpy as np

    ida = np.asarray(ids, dtype=np.int64)
    pts = np.zeros(len(ida), dtype=_SCAN_DTYPE)
    pts["x"], pts["y"], pts["id"] = x, y, ida
    pts["rgba"] = np.where((ida >= 0)[:, None], _rgba8(source, True), _rgba8(source, False))
    return pts.tobytes()


def scan_cloud(ns: int, x: ArrayLike, y: ArrayLike, ids: ArrayLike, source: str = "nav"
               ) -> JSONObject:
    """A foxglove.PointCloud of one reflector scan starting at ``ns``: each observation a point
    at (x, y) m in ``source``'s head frame as it was at ``ns`` (the caller carries each
    observation there from the instant it was measured), known reflectors in the source's
    colour, unknown ones grey, with the reflector id (-1 unknown) as the field ``id``."""
    return {"timestamp": stamp(ns), "frame_id": head_frame(source), "pose": pose(0.0, 0.0, 0.0),
            "point_stride": SCAN_POINT_STRIDE,
            "fields": [{"name": n, "offset": o, "type": t} for n, o, t in SCAN_POINT_FIELDS],
            "data": base64.b64encode(scan_points(x, y, ids, source)).decode("ascii")}


def reference_circle(ns: int, cx: float, cy: float, r: float, n: int = 180,
                     label: str = "reference") -> JSONObject:
    """A foxglove.SceneUpdate drawing the reference circle (centre m, radius m) in the map
    frame as a closed line of ``n`` points, with its radius as a label."""
    pts: list[JSON] = [{"x": cx + r * math.cos(2 * math.pi * k / n),
                        "y": cy + r * math.sin(2 * math.pi * k / n), "z": 0.0} for k in range(n)]
    line: JSONObject = {"type": 1, "pose": pose(0.0, 0.0, 0.0), "thickness": 2.0,
                        "scale_invariant": True, "points": pts, "color": color("truth", 0.8),
                        "colors": [], "indices": []}
    text: JSONObject = {"pose": pose(cx, cy + r, 0.0, z=0.3), "billboard": True, "font_size": 14.0,
            "scale_invariant": True, "color": color("truth"),
            "text": f"{label}: R = {r:.3f} m"}
    return scene(_entity(ns, MAP_FRAME, "reference-circle", lines=[line], texts=[text]))


# ---------------------------------------------------------------------- per event (live view)


def nav_pose_messages(ns: int, x: float, y: float, heading: float, m: Mounting
                      ) -> list[Encoded]:
    """The Foxglove messages of one valid NAV head pose: the head as a pose in the map and
    the frames map -> nav/O -> nav/head."""
    ox, oy, oh = (float(v) for v in o_from_head(x, y, heading, m))
    return [encoded(topics.NAV_HEAD, {"timestamp": stamp(ns), "frame_id": MAP_FRAME,
                                      "pose": pose(x, y, heading)}),
            encoded(topics.NAV_TF, frame_transforms(ns, "nav", ox, oy, oh, m))]


def pose_estimate(ns: int, name: str, x: float, y: float, heading: float,
                  covariance: Sequence[float], particles: int = 0, ess: float = 0.0
                  ) -> JSONObject:
    """A lgvtool.PoseEstimate (the exact estimate): pose of O (m, m, rad), row-major 3x3
    covariance of (x, y, heading), particle count and effective sample size."""
    return {"timestamp": stamp(ns), "estimator": name, "x": x, "y": y, "heading": heading,
            "covariance": [float(v) for v in covariance], "particles": int(particles),
            "ess": float(ess)}


def estimate_messages(name: str, ns: int, x: float, y: float, heading: float,
                      covariance: Sequence[float], m: Mounting, *, particles: int = 0,
                      ess: float = 0.0) -> list[Encoded]:
    """Every message of one estimate of O by ``name``: its pose (foxglove.PoseInFrame), the
    exact estimate (lgvtool.PoseEstimate), the frames map -> NAME/O -> NAME/head and the
    covariance ellipse."""
    return [encoded(topics.estimate_pose(name), {"timestamp": stamp(ns), "frame_id": MAP_FRAME,
                                                 "pose": pose(x, y, heading)}),
            encoded(topics.estimate_state(name), pose_estimate(ns, name, x, y, heading,
                                                               covariance, particles, ess)),
            encoded(topics.estimate_tf(name), frame_transforms(ns, name, x, y, heading, m)),
            encoded(topics.estimate_covariance(name),
                    covariance_ellipse(ns, name, x, y, covariance))]


# ---------------------------------------------------------------------- fast paths


def numbers(values: ArrayLike) -> list[bytes]:
    """JSON texts of the numbers of a 1-D array (orjson's formatting, as in whole messages)."""
    import numpy as np

    text = orjson.dumps(np.ascontiguousarray(values, dtype=np.float64),
                        option=orjson.OPT_SERIALIZE_NUMPY)
    return text[1:-1].split(b",") if len(text) > 2 else []


def _finite(*cols: NDArray[np.float64]) -> NDArray[np.bool_]:
    import numpy as np

    ok = np.ones(len(cols[0]), dtype=bool)
    for c in cols:
        ok &= np.isfinite(c)
    return ok


def _lit(text: bytes) -> bytes:
    """``text`` as a literal part of a %-template."""
    return text.replace(b"%", b"%%")


_STAMP = b'{"sec":%d,"nsec":%d}'
_POSE = (b'{"position":{"x":%b,"y":%b,"z":0.0},"orientation":'
         b'{"x":0.0,"y":0.0,"z":%b,"w":%b}}')


def pose_in_frame_many(t_ns: ArrayLike, x: ArrayLike, y: ArrayLike, heading: ArrayLike,
                       frame_id: str = MAP_FRAME) -> list[bytes]:
    """foxglove.PoseInFrame messages (JSON), one per row."""
    import numpy as np

    template = (b'{"timestamp":' + _STAMP + _lit(b',"frame_id":' + orjson.dumps(frame_id))
                + b',"pose":' + _POSE + b"}")
    half = 0.5 * np.asarray(heading, dtype=np.float64)
    return [template % row for row in zip(*stamp_columns(t_ns), numbers(x), numbers(y),
                                          numbers(np.sin(half)), numbers(np.cos(half)),
                                          strict=True)]


def pose_estimate_many(name: str, t_ns: ArrayLike, x: ArrayLike, y: ArrayLike,
                       heading: ArrayLike, covariance: ArrayLike, particles: ArrayLike,
                       ess: ArrayLike) -> list[bytes]:
    """lgvtool.PoseEstimate messages (JSON), one per row; ``covariance``: (n, 3, 3) or (n, 9)."""
    import numpy as np

    template = (b'{"timestamp":' + _STAMP + _lit(b',"estimator":' + orjson.dumps(name))
                + b',"x":%b,"y":%b,"heading":%b,"covariance":[%b],"particles":%d,"ess":%b}')
    cov = numbers(np.asarray(covariance, dtype=np.float64).ravel())
    rows = [b",".join(cov[i:i + 9]) for i in range(0, len(cov), 9)]
    return [template % row for row in zip(
        *stamp_columns(t_ns), numbers(x), numbers(y), numbers(heading), rows,
        np.asarray(particles, dtype=np.int64).tolist(), numbers(ess), strict=True)]


def poses_in_frame_many(clouds: Sequence[tuple[int, ArrayLike, ArrayLike, ArrayLike]],
                        frame_id: str = MAP_FRAME) -> list[bytes]:
    """foxglove.PosesInFrame messages (JSON) of particle clouds ``(t_ns, x, y, heading)``."""
    import numpy as np

    if not clouds:
        return []
    head = (b'{"timestamp":' + _STAMP + _lit(b',"frame_id":' + orjson.dumps(frame_id))
            + b',"poses":[')
    xs = [np.asarray(c[1], dtype=np.float64) for c in clouds]
    sizes = [len(v) for v in xs]
    half = 0.5 * np.concatenate([np.asarray(c[3], dtype=np.float64) for c in clouds])
    cols = (numbers(np.concatenate(xs)),
            numbers(np.concatenate([np.asarray(c[2], dtype=np.float64) for c in clouds])),
            numbers(np.sin(half)), numbers(np.cos(half)))
    # one pose: {"position":{"x":X,"y":Y,"z":0.0},"orientation":{"x":0.0,"y":0.0,"z":Z,"w":W}}
    glue = (b'{"position":{"x":', b',"y":', b',"z":0.0},"orientation":{"x":0.0,"y":0.0,"z":',
            b',"w":', b'}},')
    n = len(cols[0])
    parts: list[bytes] = [b""] * (9 * n)
    for j in range(4):
        parts[2 * j::9] = [glue[j]] * n
        parts[2 * j + 1::9] = cols[j]
    parts[8::9] = [glue[4]] * n
    secs, nsecs = stamp_columns([c[0] for c in clouds])
    out: list[bytes] = []
    at = 0
    for sec, nsec, k in zip(secs, nsecs, sizes, strict=True):
        body = b"".join(parts[9 * at:9 * (at + k)])[:-1] if k else b""
        out.append(head % (sec, nsec) + body + b"]}")
        at += k
    return out


def frame_transforms_many(source: str, t_ns: ArrayLike, x: ArrayLike, y: ArrayLike,
                          heading: ArrayLike, m: Mounting) -> tuple[list[int], list[bytes]]:
    """foxglove.FrameTransforms messages (JSON) of the rows with a finite pose, as
    :func:`frame_transforms`; returns (times in ns, messages) of those rows."""
    import numpy as np

    t = np.asarray(t_ns, dtype=np.int64)
    xa, ya, ha = (np.asarray(v, dtype=np.float64) for v in (x, y, heading))
    ok = _finite(xa, ya, ha)
    t, xa, ya, ha = t[ok], xa[ok], ya[ok], ha[ok]
    mount = orjson.dumps(transform(0, o_frame(source), head_frame(source), m.x, m.y, m.yaw))
    mount = mount[mount.index(b',"parent_frame_id"'):]
    template = (b'{"transforms":[{"timestamp":' + _STAMP
                + _lit(b',"parent_frame_id":' + orjson.dumps(MAP_FRAME) + b',"child_frame_id":'
                       + orjson.dumps(o_frame(source)))
                + b',"translation":{"x":%b,"y":%b,"z":0.0},"rotation":'
                b'{"x":0.0,"y":0.0,"z":%b,"w":%b}},{"timestamp":' + _STAMP + _lit(mount)
                + b"]}")
    half = 0.5 * ha
    secs, nsecs = stamp_columns(t)
    return t.tolist(), [template % (s, n, px, py, qz, qw, s, n) for s, n, px, py, qz, qw in zip(
        secs, nsecs, numbers(xa), numbers(ya), numbers(np.sin(half)), numbers(np.cos(half)),
        strict=True)]


def covariance_ellipse_many(source: str, t_ns: ArrayLike, x: ArrayLike, y: ArrayLike,
                            covariance: ArrayLike) -> tuple[list[int], list[bytes]]:
    """foxglove.SceneUpdate messages (JSON) of the rows with a finite pose and covariance, as
    :func:`covariance_ellipse`; returns (times in ns, messages) of those rows."""
    import numpy as np

    t = np.asarray(t_ns, dtype=np.int64)
    xa, ya = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    cov = np.asarray(covariance, dtype=np.float64).reshape(len(t), 9)
    sxx, sxy, syy = cov[:, 0], cov[:, 1], cov[:, 4]
    ok = _finite(xa, ya, sxx, sxy, syy)
    t, xa, ya, sxx, sxy, syy = t[ok], xa[ok], ya[ok], sxx[ok], sxy[ok], syy[ok]
    mid, half = 0.5 * (sxx + syy), 0.5 * (sxx - syy)
    rad = np.hypot(half, sxy)
    a = np.sqrt(np.maximum(mid + rad, 0.0))
    b = np.sqrt(np.maximum(mid - rad, 0.0))
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    sample = orjson.dumps(covariance_ellipse(0, source, 0.0, 0.0, [0.0] * 9))
    # the message with its numbers cut out: entity stamp, position, orientation, size
    pre, rest = sample.split(b'"timestamp":{"sec":0,"nsec":0}', 1)
    mid_part, rest = rest.split(b'"spheres":[', 1)
    tail = rest[rest.index(b',"color":'):]
    template = (_lit(pre) + b'"timestamp":' + _STAMP + _lit(mid_part) + b'"spheres":[{"pose":'
                + _POSE + b',"size":{"x":%b,"y":%b,"z":' + orjson.dumps(ELLIPSE_HEIGHT) + b"}"
                + _lit(tail))
    h = 0.5 * angle
    secs, nsecs = stamp_columns(t)
    return t.tolist(), [template % row for row in zip(
        secs, nsecs, numbers(xa), numbers(ya), numbers(np.sin(h)), numbers(np.cos(h)),
        numbers(2.0 * SIGMAS * a), numbers(2.0 * SIGMAS * b), strict=True)]


def _template(sample: bytes, slots: Sequence[tuple[bytes, bytes]]) -> bytes:
    """A %-template of the JSON ``sample``: each sentinel text replaced by its format code."""
    out = _lit(sample)
    for sentinel, code in slots:
        assert sentinel in out, sentinel
        out = out.replace(sentinel, code)
    return out


_SEC, _NSEC = 1111111111, 222222222


def scan_clouds_many(start_ns: ArrayLike, offsets: ArrayLike, x: ArrayLike, y: ArrayLike,
                     ids: ArrayLike, source: str = "nav") -> list[bytes]:
    """foxglove.PointCloud messages (JSON) of reflector scans, as :func:`scan_cloud`: scan ``k``
    starts at ``start_ns[k]`` (ns) and holds the points ``offsets[k]:offsets[k + 1]`` of the
    flat columns ``x``, ``y`` (m, head frame at the scan start) and ``ids``."""
    import numpy as np

    starts = np.asarray(start_ns, dtype=np.int64)
    if not len(starts):
        return []
    sample = scan_cloud(_SEC * 1_000_000_000 + _NSEC, [], [], [], source)
    sample["data"] = "@DATA@"
    template = _template(orjson.dumps(sample), [(b'{"sec":%d,"nsec":%d}' % (_SEC, _NSEC),
                                                 _STAMP), (b"@DATA@", b"%b")])
    data = scan_points(x, y, ids, source)
    at = (np.asarray(offsets, dtype=np.int64) * SCAN_POINT_STRIDE).tolist()
    b64 = base64.b64encode
    return [template % (sec, nsec, b64(data[at[k]:at[k + 1]]))
            for k, (sec, nsec) in enumerate(zip(*stamp_columns(starts), strict=True))]
