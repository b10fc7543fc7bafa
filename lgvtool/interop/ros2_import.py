"""``lgvtool import ros2``: a rosbag2 bag (MCAP or SQLite storage) into an lgvtool log.

The bag is read with rosbags (a bag folder with ``metadata.yaml``, or a single ``.mcap`` or
``.db3`` file). Topics play roles (:mod:`lgvtool.interop.ros2_roles`) and are written as the
log contract's channels (docs/log-format.md), in SI units:

- odometry (``nav_msgs/Odometry``, ``geometry_msgs/TwistStamped``): forward speed
  ``twist.linear.x`` (m/s) and yaw rate ``twist.angular.z`` (rad/s) of the vehicle frame's
  origin, taken as O, on ``/odom/twist``; with a gyro (``sensor_msgs/Imu``) the yaw rate of each
  odometry interval is the mean ``angular_velocity.z`` of the gyro samples in it instead;
- NAV pose: ``sick_scan_xd/NAVPoseData`` (the telegram's own ``x``, ``y`` in mm and ``phi`` in
  mdeg, in the device's map frame; ``pose_valid`` > 0 is a valid pose) or a
  ``geometry_msgs`` pose of the navigation head, on ``/nav/pose``;
- reflectors: ``sick_scan_xd/NAVLandmarkData``, each reflector with polar data as range
  ``dist`` mm and bearing ``phi`` mdeg (counter-clockwise from the head's x axis), id its
  ``global_id`` when the optional block is present, else -1, on ``/nav/reflectors``;
- truth: a ``geometry_msgs`` pose or ``nav_msgs/Odometry`` pose of O on ``/truth/pose``;
- ``/tf``, ``/tf_static``: the transform chain from the vehicle frame (the odometry's
  ``child_frame_id``, else ``base_link``) to the sensor frame (``--sensor-frame``, else the
  NAV350 messages' ``header.frame_id``, else ``nav``) gives the mounting ``vehicle.nav_x``,
  ``vehicle.nav_y``.

Log times are the messages' header stamps (the bag's receive time where a stamp is zero), so
every channel shares the clock the estimators compare. The vehicle geometry and the reflector
map come from ``--config``; without it the log has no reflector map, no reference circle and a
work area around the poses.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from lgvtool.angles import wrap_scalar
from lgvtool.config import Area, Config, Reference, default_config, load_config
from lgvtool.errors import InputError, MissingDataError
from lgvtool.interop import ros2_roles as R
from lgvtool.interop.ros2_bag import BagContent, frame_name, open_bag, read_content
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.outputs import atomic_output, guard_output
from lgvtool.timestamps import stamp

AREA_MARGIN_M = 2.0
"""Margin of the work area around the poses when no --config gives one, m."""
VALID_QUALITY, INVALID_QUALITY = 100, 255
"""/nav/pose quality written for a valid and an invalid pose (ROS poses carry no quality)."""
DEFAULT_VEHICLE_FRAME = "base_link"
DEFAULT_SENSOR_FRAME = "nav"


@dataclass(frozen=True)
class Ros2ImportSummary:
    """What :func:`import_bag` wrote."""

    path: str
    bag: str
    topics: dict[str, dict[str, Any]]
    """role -> {topic, type, messages}."""
    counts: dict[str, int]
    mounting: dict[str, Any]
    yaw_rate: str
    messages: int
    start_s: float
    end_s: float
    elapsed_s: float
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (stable keys)."""
        d = asdict(self)
        d["notes"] = list(self.notes)
        return d

    def format_text(self) -> str:
        """A short summary: output, one line per role, the mounting."""
        lines = [f"{self.bag} -> {self.path} ({self.messages} messages, "
                 f"{self.end_s - self.start_s:.1f} s of data, imported in {self.elapsed_s:.2f} s)"]
        for role, info in self.topics.items():
            lines.append(f"  {role:<10} {info['topic']} ({info['type']}, {info['messages']} "
                         f"messages)")
        m = self.mounting
        lines.append(f"  mounting   nav_x {m['nav_x']:.4f} m, nav_y {m['nav_y']:.4f} m "
                     f"({m['source']})")
        lines.append(f"  yaw rate   from the {self.yaw_rate}")
        lines.extend(f"  note       {n}" for n in self.notes)
        return "\n".join(lines)


# ------------------------------------------------------------------------ derived facts


def fused_yaw_rate(odom_t: np.ndarray, odom_w: np.ndarray, gyro_t: np.ndarray,
                   gyro_w: np.ndarray) -> np.ndarray:
    """The yaw rate of each odometry interval [t_k, t_k+1) from the gyro (rad/s): the mean of
    its samples in the interval, else the gyro interpolated at the interval's middle, else the
    odometry's own. The last interval is as long as the median one."""
    n = len(odom_t)
    if n == 0 or len(gyro_t) == 0:
        return odom_w.copy()
    step = float(np.median(np.diff(odom_t))) if n > 1 else 0.0
    ends = np.append(odom_t[1:], odom_t[-1] + step)
    csum = np.concatenate([[0.0], np.cumsum(gyro_w)])
    a = np.searchsorted(gyro_t, odom_t, side="left")
    b = np.searchsorted(gyro_t, ends, side="left")
    count = b - a
    mean = (csum[b] - csum[a]) / np.maximum(count, 1)
    mid = 0.5 * (odom_t + ends)
    covered = (mid >= gyro_t[0]) & (mid <= gyro_t[-1])
    interp = np.interp(mid, gyro_t, gyro_w)
    return np.where(count > 0, mean, np.where(covered, interp, odom_w))


def mounting(content: BagContent, sensor_frame: str | None
             ) -> tuple[float, float, float, str] | None:
    """The sensor's pose in the vehicle frame (x m, y m, yaw rad, 'vehicle->sensor') from the
    bag's transforms, or None when no chain joins the two frames."""
    vehicles = content.vehicle_frames or [DEFAULT_VEHICLE_FRAME]
    sensors = [sensor_frame] if sensor_frame else [*content.sensor_frames, DEFAULT_SENSOR_FRAME]
    for sensor in sensors:
        chain: list[tuple[float, float, float]] = []
        frame = frame_name(sensor)
        for _ in range(32):
            if frame in vehicles:
                x = y = yaw = 0.0
                for dx, dy, dth in reversed(chain):
                    c, s = math.cos(yaw), math.sin(yaw)
                    x, y, yaw = x + c * dx - s * dy, y + s * dx + c * dy, yaw + dth
                if chain:
                    return x, y, wrap_scalar(yaw), f"{frame}->{frame_name(sensor)}"
                break
            edge = content.transforms.get(frame)
            if edge is None:
                break
            chain.append(edge[1:])
            frame = edge[0]
    return None


def _data_area(content: BagContent) -> Area:
    xs = [p[1] for p in content.nav] + [p[1] for p in content.truth]
    ys = [p[2] for p in content.nav] + [p[2] for p in content.truth]
    if not xs:
        return Area()
    m = AREA_MARGIN_M
    return Area(x_min=min(xs) - m, x_max=max(xs) + m, y_min=min(ys) - m, y_max=max(ys) + m)


# ----------------------------------------------------------------------------- writing


def _records(content: BagContent, fused: np.ndarray | None) -> list[tuple[int, int, str, Any]]:
    """(log time ns, stream, topic, message) of every message, unsorted."""
    out: list[tuple[int, int, str, Any]] = []
    for t, x, y, h in content.truth:
        out.append((t, 0, topics.TRUTH, pose_in_frame(t, x, y, h)))
    for k, (t, v, w) in enumerate(content.odom):
        omega = float(fused[k]) if fused is not None else w
        out.append((t, 1, topics.ODOM, {"timestamp": stamp(t), "v": v, "omega": omega}))
    for t, x, y, h, used, valid in content.nav:
        out.append((t, 2, topics.NAV_POSE, {
            "timestamp": stamp(t), "x": x, "y": y, "heading": h,
            "quality": VALID_QUALITY if valid else INVALID_QUALITY, "reflectors_used": used,
            "valid": valid}))
    for t, period, obs in content.scans:
        out.append((t, 3, topics.NAV_REFLECTORS,
                    {"timestamp": stamp(t), "scan_period": period, "observations": obs}))
    return out


def _config(config: Config | str | Path | None, content: BagContent,
            mount: tuple[float, float, float, str] | None, notes: list[str]
            ) -> tuple[Config, dict[str, Any]]:
    if config is None:
        cfg = replace(default_config(), reflectors=(), area=_data_area(content),
                      reference=Reference(steering_angle_deg=None))
        notes.append("no --config: no reflector map, no reference circle, the work area around "
                     "the poses, lgvtool's default vehicle")
    else:
        cfg = config if isinstance(config, Config) else load_config(config)
    if mount is None:
        return cfg, {"source": "config", "nav_x": cfg.vehicle.nav_x, "nav_y": cfg.vehicle.nav_y}
    x, y, yaw, chain = mount
    if abs(yaw) > 1e-3:
        notes.append(f"the sensor is mounted turned by {math.degrees(yaw):.2f} deg in the "
                     f"transforms; only its position is used")
    cfg = replace(cfg, vehicle=replace(cfg.vehicle, nav_x=x, nav_y=y))
    return cfg, {"source": f"tf {chain}", "nav_x": x, "nav_y": y, "yaw_rad": yaw}


def import_bag(bag: str | Path, out: str | Path, *, topic_options: Sequence[str] = (),
               config: Config | str | Path | None = None, sensor_frame: str | None = None,
               compression: str = "zstd", force: bool = False) -> Ros2ImportSummary:
    """Import the rosbag2 bag ``bag`` into the log ``out`` (replaced atomically).

    :param topic_options: ``ROLE=/name`` choices (``ROLE=none`` leaves a role out).
    :param config: a configuration (or its TOML file) for the vehicle and the reflector map.
    :param sensor_frame: the frame of the navigation sensor in the bag's transforms.
    :raises InputError: not a bag; no odometry or no observation topic; a bad ``--topic``; a
        message that does not decode; an output that is the bag or exists without ``force``.
    """
    started = time.perf_counter()
    source = Path(bag)
    overrides = R.parse_topic_options(topic_options)
    target = guard_output(out, [source], force=force)
    if not target.parent.is_dir():
        raise InputError(f"{target}: folder {target.parent} does not exist")
    if isinstance(config, str | Path):
        config = load_config(config)
    reader = open_bag(source)
    try:
        types = {c.topic: c.msgtype for c in reader.connections}
        chosen = R.choose_topics(types, overrides)
        content = read_content(reader, chosen)
        storage = "sqlite3" if source.suffix == ".db3" or any(
            p.suffix == ".db3" for p in (source.iterdir() if source.is_dir() else [])) else "mcap"
        distro = getattr(reader, "ros_distro", None)
    finally:
        reader.close()
    if len(content.odom) < 2:
        raise MissingDataError(f"{source}: no usable odometry: {chosen['odom'][0]} holds "
                               f"{len(content.odom)} message(s)")
    if not content.nav and not content.scans:
        raise MissingDataError(f"{source}: no observation: the NAV pose and reflector topics "
                               f"hold no message")
    notes: list[str] = []
    fused = None
    yaw_rate = "odometry"
    content.odom.sort()
    if content.gyro:
        g = sorted(content.gyro)
        o = np.array([t for t, _, _ in content.odom], dtype=np.int64)
        fused = fused_yaw_rate(o * 1e-9, np.array([w for _, _, w in content.odom]),
                               np.array([t for t, _ in g], dtype=np.int64) * 1e-9,
                               np.array([w for _, w in g]))
        yaw_rate = "gyro"
    cfg, mount_info = _config(config, content, mounting(content, sensor_frame), notes)
    records = sorted(_records(content, fused), key=lambda r: (r[0], r[1]))
    role_info = {role: {"topic": ts[0], "type": R.short(types[ts[0]]),
                        "messages": content.counts.get(role, 0)}
                 for role, ts in chosen.items() if ts and role != "tf"}
    if chosen["tf"]:
        role_info["tf"] = {"topic": ", ".join(chosen["tf"]), "type": R.short(R.TF),
                           "messages": content.counts.get("tf", 0)}
    start_ns = records[0][0]
    with atomic_output(target) as tmp, LogWriter(tmp, chunk_seconds=None, compression=compression,
                   source="import ros2") as w:
        w.add_metadata("importer", {
            "importer": "ros2", "bag": source.name, "storage": storage,
            "ros_distro": distro, "topics": role_info, "mounting": mount_info,
            "yaw_rate": yaw_rate, "counts": dict(content.counts), "notes": notes,
            "time_unit": "log times are the messages' header stamps in ns (the bag's "
                         "receive time where a stamp is zero)",
        })
        w.write_config(cfg)
        if cfg.reflectors:
            w.write_map(cfg.reflectors, start_ns)
        for t, _, topic, message in records:
            w.write(topic, message, t)
        messages = w.message_count
    return Ros2ImportSummary(
        path=str(target), bag=str(source), topics=role_info, counts=dict(content.counts),
        mounting=mount_info, yaw_rate=yaw_rate, messages=messages, start_s=start_ns / 1e9,
        end_s=records[-1][0] / 1e9, elapsed_s=time.perf_counter() - started,
        notes=tuple(notes))

