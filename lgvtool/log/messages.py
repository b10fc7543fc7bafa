"""Builders and helpers for message dicts: time stamps, poses, the map scene, diagnostics.

Message dicts are plain JSON-able dicts laid out as the schemas in ``schemas/``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

from lgvtool.config import Reflector
from lgvtool.timestamps import stamp

FRAME_ID = "map"
"""Frame of every map-frame pose in lgvtool logs."""








def quaternion_from_yaw(yaw: float) -> dict[str, float]:
    """Unit quaternion ``{x, y, z, w}`` of a rotation by ``yaw`` rad about z."""
    return {"x": 0.0, "y": 0.0, "z": math.sin(yaw / 2.0), "w": math.cos(yaw / 2.0)}


def yaw_from_quaternion(q: Mapping[str, float]) -> float:
    """Rotation about z, rad in (-pi, pi], of a quaternion ``{x, y, z, w}``."""
    x, y, z, w = (float(q.get(k, 0.0)) for k in ("x", "y", "z", "w"))
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose(x: float, y: float, heading: float, z: float = 0.0) -> dict[str, Any]:
    """A foxglove.Pose of a 2-D pose: position in m, heading in rad."""
    return {"position": {"x": x, "y": y, "z": z}, "orientation": quaternion_from_yaw(heading)}


def pose_in_frame(ns: int, x: float, y: float, heading: float, frame_id: str = FRAME_ID) -> dict[str, Any]:
    """A foxglove.PoseInFrame message: time in ns, position in m, heading in rad."""
    return {"timestamp": stamp(ns), "frame_id": frame_id, "pose": pose(x, y, heading)}


def poses_in_frame(
    ns: int, poses: Iterable[tuple[float, float, float]], frame_id: str = FRAME_ID
) -> dict[str, Any]:
    """A foxglove.PosesInFrame message from (x m, y m, heading rad) triples."""
    return {"timestamp": stamp(ns), "frame_id": frame_id, "poses": [pose(*p) for p in poses]}


def reflector_map_message(ns: int, reflectors: Iterable[Reflector]) -> dict[str, Any]:
    """A lgvtool.ReflectorMap message."""
    return {
        "timestamp": stamp(ns),
        "frame_id": FRAME_ID,
        "reflectors": [
            {"id": r.id, "x": r.x, "y": r.y, "radius": r.radius, "layer": r.layer}
            for r in reflectors
        ],
    }


def reflectors_from_message(msg: Mapping[str, Any]) -> tuple[Reflector, ...]:
    """The reflectors of a lgvtool.ReflectorMap message."""
    return tuple(
        Reflector(id=int(r["id"]), x=float(r["x"]), y=float(r["y"]),
                  radius=float(r.get("radius", 0.05)), layer=int(r.get("layer", 0)))
        for r in msg["reflectors"]
    )


def map_scene_message(ns: int, reflectors: Iterable[Reflector], height: float = 0.85) -> dict[str, Any]:
    """A foxglove.SceneUpdate drawing each reflector as a cylinder ``height`` m tall, labelled."""
    entities = []
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
    details: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """A lgvtool.Diagnostic message."""
    return {
        "timestamp": stamp(ns), "level": int(level), "source": source, "kind": kind,
        "message": message, "count": int(count), "details": dict(details or {}),
    }


def log_message_of(diag: Mapping[str, Any]) -> dict[str, Any]:
    """The foxglove.Log mirror of a lgvtool.Diagnostic message."""
    return {
        "timestamp": diag["timestamp"], "level": diag["level"],
        "message": f"[{diag['kind']}] {diag['message']}",
        "name": diag["source"], "file": "", "line": 0,
    }
