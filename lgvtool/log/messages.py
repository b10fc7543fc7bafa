"""The one mapping from domain objects to the log's own messages: every message dict lgvtool
writes is built here (poses, the map and its scene, diagnostics, MCU frames, NAV200 and NAV350
poses, reflector scans).

Message dicts are plain JSON-able dicts laid out as the schemas in ``schemas/``; ``timestamp``
fields are ``{"sec", "nsec"}`` (:func:`lgvtool.timestamps.stamp`). The byte-template fast
paths of the replay's estimate channels (foxglove.PoseInFrame, lgvtool.PoseEstimate,
foxglove.PosesInFrame) are :mod:`lgvtool.log.foxglove`'s ``*_many`` encoders, which write the
same layouts as :func:`pose_in_frame` and :func:`poses_in_frame`.

The device types are imported for type checking only: this module depends on no device code.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Protocol, TypedDict

from lgvtool.angles import wrap_scalar
from lgvtool.config import Reflector, reflectors_from_tables
from lgvtool.errors import ConfigError
from lgvtool.json_types import JSON, JSONObject, JSONRecord, as_int
from lgvtool.timestamps import stamp

if TYPE_CHECKING:
    from lgvtool.devices.mcu.mcu_frame import McuFrame
    from lgvtool.devices.nav200.nav200_commands import Reply
    from lgvtool.devices.nav200.nav200_payloads import Pose
    from lgvtool.devices.nav350.nav350_telegrams import PoseData

# ------------------------------------------------------------------ messages as read back
# The layouts of decoded messages (``schemas/``) that readers take fields from; every field is
# optional here, as a reader meets it (a missing one is the reader's error or default).


class McuFrameFields(TypedDict, total=False):
    """The fields of a decoded ``lgvtool.McuFrame`` that the steering columns read:
    ``steering_angle`` (rad) and ``drive_speed`` (m/s)."""

    steering_angle: float
    drive_speed: float


class ObservationFields(TypedDict, total=False):
    """One observation of a decoded ``lgvtool.ReflectorScan``: ``range`` (m), ``bearing``
    (rad), ``time_in_scan`` (s) and the map ``id`` (-1: none)."""

    range: float
    bearing: float
    time_in_scan: float
    id: int


class ReflectorScanFields(TypedDict, total=False):
    """A decoded ``lgvtool.ReflectorScan``: its ``timestamp`` (``{sec, nsec}``), the
    ``scan_period`` (s) and its observations."""

    timestamp: JSONObject
    scan_period: float
    observations: list[ObservationFields]


class PoseFields(TypedDict, total=False):
    """A decoded foxglove.Pose: ``position`` ``{x, y, z}`` (m) and ``orientation``
    ``{x, y, z, w}`` (a unit quaternion)."""

    position: dict[str, float]
    orientation: dict[str, float]


class PoseInFrameFields(TypedDict, total=False):
    """A decoded foxglove.PoseInFrame: ``timestamp`` (``{sec, nsec}``), ``frame_id`` and
    ``pose``."""

    timestamp: JSONObject
    frame_id: str
    pose: PoseFields


class ScanObservation(Protocol):
    """One reflector seen in a scan: ``range`` (m), ``bearing`` (rad), ``time_in_scan`` (s
    after the scan's start) and the map ``id`` (-1: none)."""

    @property
    def range(self) -> float: ...
    @property
    def bearing(self) -> float: ...
    @property
    def time_in_scan(self) -> float: ...
    @property
    def id(self) -> int: ...


FRAME_ID = "map"
"""Frame of every map-frame pose in lgvtool logs."""


def quaternion_from_yaw(yaw: float) -> JSONObject:
    """Unit quaternion ``{x, y, z, w}`` of a rotation by ``yaw`` rad about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}


def steering_fields(docs: Sequence[McuFrameFields]) -> tuple[list[float], list[float]]:
    """Steering angle (rad, NaN where absent) and absolute drive speed (m/s, 0 where absent)
    of decoded MCU frames."""
    return ([float(d.get("steering_angle", math.nan)) for d in docs],
            [abs(float(d.get("drive_speed", 0.0))) for d in docs])


def yaw_from_quaternion(q: Mapping[str, float]) -> float:
    """Rotation about z, rad in (-pi, pi], of a quaternion ``{x, y, z, w}``."""
    x, y, z, w = (float(q.get(k, 0.0)) for k in ("x", "y", "z", "w"))
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose(x: float, y: float, heading: float, z: float = 0.0) -> JSONObject:
    """A foxglove.Pose of a 2-D pose: position in m, heading in rad."""
    return {"position": {"x": x, "y": y, "z": z}, "orientation": quaternion_from_yaw(heading)}


def pose_in_frame(ns: int, x: float, y: float, heading: float, frame_id: str = FRAME_ID) -> JSONObject:
    """A foxglove.PoseInFrame message: time in ns, position in m, heading in rad."""
    return {"timestamp": stamp(ns), "frame_id": frame_id, "pose": pose(x, y, heading)}


def poses_in_frame(
    ns: int, poses: Iterable[tuple[float, float, float]], frame_id: str = FRAME_ID
) -> JSONObject:
    """A foxglove.PosesInFrame message from (x m, y m, heading rad) triples."""
    return {"timestamp": stamp(ns), "frame_id": frame_id, "poses": [pose(*p) for p in poses]}


def reflector_map_message(ns: int, reflectors: Iterable[Reflector]) -> JSONObject:
    """A lgvtool.ReflectorMap message."""
    return {
        "timestamp": stamp(ns),
        "frame_id": FRAME_ID,
        "reflectors": [
            {"id": r.id, "x": r.x, "y": r.y, "radius": r.radius, "layer": r.layer}
            for r in reflectors
        ],
    }


def reflectors_from_message(msg: JSON) -> tuple[Reflector, ...]:
    """The reflectors of a lgvtool.ReflectorMap message, checked as a configuration's
    (:func:`lgvtool.config.reflectors_from_tables`; radius 0.05 m and layer 0 when absent).

    :raises ValueError: the message holds no such list (naming the topic and the entry).
    """
    try:
        items = msg["reflectors"] if isinstance(msg, Mapping) else None
        return reflectors_from_tables([{"radius": 0.05, "layer": 0, **r} if isinstance(r, dict)
                                       else r for r in items] if isinstance(items, list)
                                      else items)
    except ConfigError as exc:
        raise ValueError(f"topic /map/reflectors: {exc}") from None


def map_scene_message(ns: int, reflectors: Iterable[Reflector], height: float = 0.85) -> JSONObject:
    """A foxglove.SceneUpdate drawing each reflector as a cylinder ``height`` m tall, labelled."""
    entities: list[JSON] = []
    for r in reflectors:
        d = 2.0 * r.radius if r.radius > 0 else 0.1
        entities.append({
            "timestamp": stamp(ns),
            "frame_id": FRAME_ID,
            "id": f"reflector-{r.id}",
            "lifetime": {"sec": 0, "nsec": 0},
            "frame_locked": False,
            "metadata": [{"key": "layer", "value": str(r.layer)}],
            "arrows": [], "cubes": [], "spheres": [], "lines": [], "triangles": [], "models": [],
            "cylinders": [{
                "pose": pose(r.x, r.y, 0.0, z=height / 2.0),
                "size": {"x": d, "y": d, "z": height},
                "bottom_scale": 1.0, "top_scale": 1.0,
                "color": {"r": 0.9, "g": 0.9, "b": 0.2, "a": 1.0},
            }],
            "texts": [{
                "pose": pose(r.x, r.y, 0.0, z=height + 0.15),
                "billboard": True, "font_size": 14.0, "scale_invariant": True,
                "color": {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0}, "text": str(r.id),
            }],
        })
    return {"deletions": [], "entities": entities}


LEVELS = {"debug": 1, "info": 2, "warning": 3, "error": 4, "fatal": 5}
"""Severity names -> foxglove.Log level numbers."""


def diagnostic_message(
    ns: int, source: str, kind: str, message: str, *, level: int = 3, count: int = 1,
    details: JSONRecord | None = None,
) -> JSONObject:
    """A lgvtool.Diagnostic message."""
    return {
        "timestamp": stamp(ns), "level": int(level), "source": source, "kind": kind,
        "message": message, "count": int(count), "details": dict(details or {}),
    }


def log_message_of(diag: JSONRecord) -> JSONObject:
    """The foxglove.Log mirror of a lgvtool.Diagnostic message."""
    return {
        "timestamp": diag["timestamp"], "level": diag["level"],
        "message": f"[{diag['kind']}] {diag['message']}",
        "name": diag["source"], "file": "", "line": 0,
    }


def kind_of_log_message(msg: JSONRecord) -> str | None:
    """The diagnostic kind a foxglove.Log mirror (:func:`log_message_of`) was made from, read
    back from its text (``[kind] message``); None when the text is not of that form."""
    text = msg.get("message")
    if not isinstance(text, str) or not text.startswith("[") or "]" not in text:
        return None
    return text[1:text.index("]")]


# ---------------------------------------------------------------------------------- devices
def _stamp(timestamp: JSONRecord) -> JSONObject:
    return {"sec": as_int(timestamp["sec"]), "nsec": as_int(timestamp["nsec"])}


def mcu_frame_message(frame: McuFrame, timestamp: JSONRecord) -> JSONObject:
    """An ``lgvtool.McuFrame`` message: raw counts plus SI values.

    ``gyro_scale`` in deg/s per count, ``gyro_rate`` rad/s, ``steering_angle`` rad,
    ``drive_speed`` m/s.
    """
    return {
        "timestamp": _stamp(timestamp),
        "version": frame.version,
        "seq": frame.seq,
        "mcu_time_ms": frame.mcu_time_ms,
        "enc_left": frame.enc_left,
        "enc_right": frame.enc_right,
        "gyro_raw": frame.gyro_raw,
        "gyro_scale": frame.gyro_scale_deg_s,
        "gyro_rate": frame.gyro_rate,
        "steering_angle": frame.steering_angle,
        "drive_speed": frame.drive_speed,
        "status": frame.status,
    }


def nav_pose_message(pose: Pose | Reply, timestamp: JSONRecord) -> JSONObject:
    """An ``lgvtool.NavPose`` message from a NAV200 PP reply or its payload.

    x, y in m, heading in rad within (-pi, pi], ``valid`` False for quality 0xFE/0xFF.
    """
    from lgvtool.devices.nav200.nav200_commands import Reply
    from lgvtool.devices.nav200.nav200_payloads import Pose

    if isinstance(pose, Reply):
        if not isinstance(pose.payload, Pose):
            raise TypeError(f"NAV200 {pose.code} reply carries no pose")
        pose = pose.payload
    return {
        "timestamp": _stamp(timestamp),
        "x": pose.x,
        "y": pose.y,
        "heading": pose.heading,
        "quality": pose.quality,
        "reflectors_used": pose.reflectors_used,
        "valid": pose.valid,
    }


def reflector_scan_message(start_ns: int, period: float, observations: Iterable[ScanObservation]
                           ) -> JSONObject:
    """An ``lgvtool.ReflectorScan`` of one head revolution: start time in ns, ``period`` in s,
    observations with ``range`` (m), ``bearing`` (rad), ``time_in_scan`` (s) and ``id``."""
    return {
        "timestamp": stamp(start_ns),
        "scan_period": period,
        "observations": [{"range": o.range, "bearing": o.bearing,
                          "time_in_scan": o.time_in_scan, "id": o.id} for o in observations],
    }


# ---------------------------------------------------------------------------------- NAV350
# Both times are logged: ``timestamp`` of the pose is the host time the reply was received (as
# for the NAV200), ``device_time_ms`` the NAV350 tick, and ``device_stamp`` the host time of that
# tick by the online clock estimate (absent until the estimate exists). A scan's ``timestamp`` is
# the host time of its start tick (DIST1 ``timestampStart``, else the first landmark's tick) and
# each reflector's ``time_in_scan`` comes from its own tick, so the de-skew uses the device's
# landmark timestamps. Angles: the NAV350's mdeg, counter-clockwise, turned into rad in
# (-pi, pi].

#: ``quality`` of a NAV350 pose without a valid position (the NAV350 has no quality byte:
#: 0 otherwise, its own figures are ``mean_dev``, ``nav_mode`` and ``reflectors_used``).
NAV350_NO_POSITION = 0xFF
#: Head revolution period the NAV350 runs at (8 Hz), s.
NAV350_SCAN_PERIOD = 0.125


def _mdeg_angle(mdeg: int) -> float:
    a = math.radians(mdeg / 1000.0)
    return wrap_scalar(a)


def nav350_pose_message(data: PoseData, received_ns: int,
                 host_ns_of_tick: Callable[[int], int | None]) -> JSONObject | None:
    """The ``lgvtool.NavPose`` of a NAV350 pose-data reply (None when it has neither pose nor pose
    information). ``host_ns_of_tick`` maps a device tick to host ns (None: no estimate yet)."""
    if data.pose is None and data.info is None:
        return None
    info = data.info
    valid = data.pose is not None and data.error_code == 0
    x, y, phi = data.pose if data.pose is not None else (0, 0, 0)
    msg: JSONObject = {
        "timestamp": stamp(received_ns), "x": x / 1000.0, "y": y / 1000.0,
        "heading": _mdeg_angle(phi), "quality": 0 if valid else NAV350_NO_POSITION,
        "reflectors_used": 0 if info is None else info.used_reflectors, "valid": valid,
        "error_code": data.error_code,
    }
    if info is not None:
        msg.update(device_time_ms=info.timestamp_ms, mean_dev=info.mean_dev,
                   nav_mode=info.nav_mode, info_state=info.info_state,
                   output_mode=info.output_mode)
        ns = host_ns_of_tick(info.timestamp_ms)
        if ns is not None:
            msg["device_stamp"] = stamp(ns)
    return msg


def nav350_scan_message(data: PoseData, received_ns: int,
                 host_ns_of_tick: Callable[[int], int | None],
                 map_id: Mapping[int, int] | None = None) -> JSONObject | None:
    """The ``lgvtool.ReflectorScan`` of a reply's landmark block (None without one): every
    landmark with a polar measurement, and where the device sent its optional data, its local
    and global ids, quality, hit count, mean echo (device units) and tick (ms); ``map_id``
    turns the device's global ids into map ids (None: the same; a global id not in it: -1)."""
    block = data.landmarks
    if block is None:
        return None
    marks = [m for m in block.landmarks if m.polar is not None]
    ticks = [m.info.timestamp_ms for m in marks if m.info is not None]
    start_tick: int | None = None
    if data.scans:
        start_tick = data.scans[0].timestamp_ms
    elif ticks:
        start_tick = min(ticks, key=lambda t: (t - ticks[0] + 2**31) % 2**32)
    start_ns = None if start_tick is None else host_ns_of_tick(start_tick)
    if start_ns is None:
        start_ns = received_ns - round(NAV350_SCAN_PERIOD * 1e9)
    observations: list[JSON] = []
    for m in marks:
        assert m.polar is not None
        dist, phi = m.polar
        o: JSONObject = {"range": dist / 1000.0, "bearing": _mdeg_angle(phi),
                             "time_in_scan": 0.0, "id": -1}
        info = m.info
        if info is not None:
            gid = info.global_id
            o["id"] = (gid if gid != 0xFFFF else -1) if map_id is None else map_id.get(gid, -1)
            if start_tick is not None:
                dt = ((info.timestamp_ms - start_tick + 2**31) % 2**32 - 2**31) / 1000.0
                o["time_in_scan"] = max(0.0, dt)
            o.update(local_id=info.local_id, global_id=gid, quality=info.quality,
                     hit_count=info.hit_count, mean_echo=info.mean_echo,
                     device_time_ms=info.timestamp_ms)
        observations.append(o)
    msg: JSONObject = {"timestamp": stamp(start_ns), "scan_period": NAV350_SCAN_PERIOD,
                           "observations": observations}
    if start_tick is not None:
        msg["device_time_ms"] = start_tick
    return msg
