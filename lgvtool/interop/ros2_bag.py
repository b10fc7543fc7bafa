"""Read the chosen topics of a rosbag2 bag into plain values (``lgvtool import ros2``).

:func:`open_bag` opens a bag folder (``metadata.yaml``), a ``.mcap`` or a ``.db3`` file with
rosbags; :func:`read_content` decodes every message of the topics chosen for each role
(:mod:`lgvtool.interop.ros2_roles`) into a :class:`BagContent`: times in int ns (header stamps,
the bag's receive time where a stamp is zero), positions m, angles rad, speeds m/s and rad/s.

- ``nav_msgs/Odometry``, ``geometry_msgs/TwistStamped``: ``twist.linear.x``,
  ``twist.angular.z``; the odometry's frame is the vehicle frame;
- ``sensor_msgs/Imu``: ``angular_velocity.z``;
- ``sick_scan_xd/NAVPoseData``: the telegram's own ``x``, ``y`` (mm) and ``phi`` (mdeg) in the
  device's map frame, valid when ``pose_valid`` > 0, and what the device says of it
  (:attr:`BagContent.nav_device`); a ``geometry_msgs`` pose or an Odometry's
  ``pose`` as it is, with the frames each message names (:attr:`BagContent.nav_frames`); a
  ``tf2_msgs/TFMessage`` on the nav role: every transform from ``map``, by child frame
  (:attr:`BagContent.map_poses`), one of which the importer takes;
- ``sick_scan_xd/NAVLandmarkData``: each reflector with polar data as range ``dist`` (mm) and
  bearing ``phi`` (mdeg, counter-clockwise from the head's x axis), id its ``global_id`` when the
  optional block is present, else -1; with reflector times on all, ``time_in_scan`` after the
  earliest and the NAV350's revolution as the scan period; with the optional block also its
  local and global ids, quality, hit count, mean echo and tick, as a recorded NAV350 scan;
- ``tf2_msgs/TFMessage``: the first transform seen for each child frame;
- the circle role (a pose topic named by ``--circle-from``): poses as the truth's.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, cast

from lgvtool.angles import wrap_scalar
from lgvtool.errors import InputError
from lgvtool.interop import ros2_roles as R
from lgvtool.interop.ros2_types import NAV_POSE_DATA, require_rosbags, typestore
from lgvtool.log.messages import NAV350_NO_POSITION, yaw_from_quaternion

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.rosbag2 import Reader

    from lgvtool.interop.ros2_messages import (
        Header,
        Imu,
        NavLandmarkData,
        NavPoseData,
        Odometry,
        Pose,
        PoseStamped,
        PoseWithCovarianceStamped,
        Quaternion,
        Stamped,
        TFMessage,
        TwistStamped,
    )

MDEG = math.pi / 180000.0
"""rad per mdeg (NAV350 angles)."""
NAV350_PERIOD_S = 0.125
"""Revolution of the NAV350 head, s (8 Hz): the scan period when reflector times are known."""
MAP_FRAME = "map"
"""REP 105's world frame: the parent of the transforms a /tf NAV pose topic is read from."""


@dataclass
class BagContent:
    """What the chosen topics hold, decoded (times int ns; m, rad, m/s, rad/s)."""

    odom: list[tuple[int, float, float]] = field(default_factory=list)
    gyro: list[tuple[int, float]] = field(default_factory=list)
    nav: list[tuple[int, float, float, float, int, bool]] = field(default_factory=list)
    """t, x, y, heading, reflectors used, valid."""
    nav_device: dict[int, dict[str, int]] = field(default_factory=dict)
    """What a NAVPoseData says of its pose beside it, by the pose's time (ns): the fields of
    :func:`lgvtool.log.messages.nav350_pose_message` it holds (``quality`` 0 or 0xFF as a
    NAV350's; with the optional pose block ``device_time_ms``, ``mean_dev``, ``nav_mode``,
    ``info_state``, ``output_mode``)."""
    scans: list[tuple[int, float, list[dict[str, float | int]]]] = field(default_factory=list)
    """t, scan period s, the observations (range m, bearing rad, id, time_in_scan s)."""
    truth: list[tuple[int, float, float, float]] = field(default_factory=list)
    circle: list[tuple[int, float, float, float]] = field(default_factory=list)
    """Poses of the topic named by ``--circle-from`` (t, x, y, heading)."""
    nav_frames: list[tuple[str, str]] = field(default_factory=list)
    """(header frame, child frame or '') of the nav messages, each pair once, in order seen."""
    map_poses: dict[str, list[tuple[int, float, float, float, int, bool]]] = field(
        default_factory=dict)
    """A /tf nav topic's poses by child frame (transforms from ``map``), as :attr:`nav`."""
    transforms: dict[str, tuple[str, float, float, float]] = field(default_factory=dict)
    """child frame -> (parent frame, x m, y m, yaw rad), first seen."""
    vehicle_frames: list[str] = field(default_factory=list)
    sensor_frames: list[str] = field(default_factory=list)
    counts: dict[str, int] = field(default_factory=dict)
    """Messages read per role and what was dropped (``dropped_*``)."""

    def count(self, key: str, n: int = 1) -> None:
        """Add ``n`` to counter ``key``."""
        self.counts[key] = self.counts.get(key, 0) + n


def open_bag(path: Path) -> Reader:
    """An open rosbags reader of a bag folder, ``.mcap`` or ``.db3`` file.

    :raises InputError: no such path, not a rosbag2 bag, a bag rosbags cannot read.
    """
    require_rosbags()
    from rosbags.rosbag2 import Reader, ReaderError

    if not path.exists():
        raise InputError(f"{path}: no such file or folder")
    if not (path.is_dir() or path.is_file()):  # a FIFO or a device would block the reading
        raise InputError(f"{path}: not a file or a folder")
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise InputError(f"{path}: a folder without metadata.yaml, not a rosbag2 bag")
    if path.is_file() and path.suffix not in (".mcap", ".db3"):
        raise InputError(f"{path}: not a rosbag2 bag (expected a bag folder, a .mcap or a .db3 "
                         f"file)")
    try:
        reader = Reader(path)
        reader.open()
    except (ReaderError, KeyError, ValueError, TypeError, OSError) as exc:
        text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(f"{path}: not a readable rosbag2 bag ({text})") from None
    except Exception as exc:  # the storage readers raise what their parsers raise
        raise InputError(f"{path}: not a readable rosbag2 bag ({type(exc).__name__}: "
                         f"{exc})") from None
    return reader


def _ns(header: Header, bag_ns: int) -> int:
    """A header's stamp in ns, or the bag time when it is zero."""
    ns = int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
    return ns if ns > 0 else int(bag_ns)


def _yaw(q: Quaternion) -> float:
    return yaw_from_quaternion({"x": q.x, "y": q.y, "z": q.z, "w": q.w})


def _finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


def frame_name(name: str) -> str:
    """A tf frame name without blanks and a leading slash."""
    return name.strip().lstrip("/")


# ------------------------------------------------------------------ one reader per role


def _read_odom(c: BagContent, msg: object, msgtype: str, ns: int) -> None:
    # each reader's message is of its ``msgtype`` (the type the bag's connection names)
    if msgtype == R.ODOMETRY:
        odometry = cast("Odometry", msg)
        header, twist, frame = odometry.header, odometry.twist.twist, odometry.child_frame_id
    else:
        stamped = cast("TwistStamped", msg)
        header, twist, frame = stamped.header, stamped.twist, stamped.header.frame_id
    v, w = float(twist.linear.x), float(twist.angular.z)
    if frame and frame_name(frame) not in c.vehicle_frames:
        c.vehicle_frames.append(frame_name(frame))
    if not _finite(v, w):
        c.count("dropped_odom_not_finite")
        return
    c.odom.append((_ns(header, ns), v, w))


def _read_gyro(c: BagContent, message: object, _msgtype: str, ns: int) -> None:
    msg = cast("Imu", message)  # the gyro role reads sensor_msgs/Imu only (ros2_roles.ROLES)
    w = float(msg.angular_velocity.z)
    if not _finite(w):
        c.count("dropped_gyro_not_finite")
        return
    c.gyro.append((_ns(msg.header, ns), w))


def _nav_frames(c: BagContent, header: str, child: str) -> None:
    pair = (frame_name(header), frame_name(child))
    if pair not in c.nav_frames:
        c.nav_frames.append(pair)


def _read_map_poses(c: BagContent, msg: TFMessage, ns: int) -> int:
    """The transforms from ``map`` of a TFMessage on the nav role; returns how many."""
    n = 0
    for tr in msg.transforms:
        if frame_name(tr.header.frame_id) != MAP_FRAME:
            continue
        t, q = tr.transform.translation, tr.transform.rotation
        x, y, h = float(t.x), float(t.y), _yaw(q)
        child = frame_name(tr.child_frame_id)
        _nav_frames(c, MAP_FRAME, child)
        if not _finite(x, y, h):
            c.count("dropped_nav_not_finite")
            continue
        c.map_poses.setdefault(child, []).append((_ns(tr.header, ns), x, y, wrap_scalar(h), 0,
                                                  True))
        n += 1
    return n


def _read_nav(c: BagContent, message: object, msgtype: str, ns: int) -> None:
    if msgtype == R.TF:
        if _read_map_poses(c, cast("TFMessage", message), ns):
            c.count("nav")
        return
    header = cast("Stamped", message).header  # every other nav type has one
    if msgtype == NAV_POSE_DATA:
        msg = cast("NavPoseData", message)
        x, y, h = msg.x / 1000.0, msg.y / 1000.0, wrap_scalar(msg.phi * MDEG)
        used = int(msg.quant_used_reflectors) if msg.opt_pose_data_valid else 0
        valid = int(msg.pose_valid) > 0
        if msg.header.frame_id and frame_name(msg.header.frame_id) not in c.sensor_frames:
            c.sensor_frames.append(frame_name(msg.header.frame_id))
        device = {"quality": 0 if valid else NAV350_NO_POSITION}
        if msg.opt_pose_data_valid:
            device.update(device_time_ms=int(msg.timestamp), mean_dev=int(msg.mean_dev),
                          nav_mode=int(msg.nav_mode), info_state=int(msg.info_state),
                          output_mode=int(msg.output_mode))
        c.nav_device[_ns(header, ns)] = device
    else:
        pose = _pose(message, msgtype)
        x, y, h = float(pose.position.x), float(pose.position.y), _yaw(pose.orientation)
        used, valid = 0, True
        _nav_frames(c, header.frame_id,
                    cast("Odometry", message).child_frame_id if msgtype == R.ODOMETRY else "")
    c.count("nav")
    if not _finite(x, y, h):
        c.count("dropped_nav_not_finite")
        return
    c.nav.append((_ns(header, ns), x, y, wrap_scalar(h), min(used, 255), valid))


def _read_reflectors(c: BagContent, message: object, _msgtype: str, ns: int) -> None:
    # the reflectors role reads sick_scan_xd/NAVLandmarkData only (ros2_roles.ROLES)
    msg = cast("NavLandmarkData", message)
    if msg.header.frame_id and frame_name(msg.header.frame_id) not in c.sensor_frames:
        c.sensor_frames.append(frame_name(msg.header.frame_id))
    seen: list[tuple[float, float, int, int | None, dict[str, int]]] = []
    for r in msg.reflectors:
        if not r.polar_data_valid:
            c.count("dropped_reflectors_without_polar_data")
            continue
        rng, bearing = r.dist / 1000.0, wrap_scalar(r.phi * MDEG)
        ident = int(r.global_id) if r.opt_reflector_data_valid else -1
        tick = int(r.timestamp) if r.opt_reflector_data_valid and r.timestamp else None
        # what the device says of the reflector, under the keys a recorded NAV350 scan has
        device = ({"local_id": int(r.local_id), "global_id": int(r.global_id),
                   "quality": int(r.quality), "hit_count": int(r.hit_count),
                   "mean_echo": int(r.mean_echo), "device_time_ms": int(r.timestamp)}
                  if r.opt_reflector_data_valid else {})
        seen.append((rng, bearing, ident, tick, device))
    ticks = [s[3] for s in seen if s[3] is not None]
    timed = len(ticks) == len(seen) and bool(seen)
    # ms ticks of a 32-bit counter: differences to the first one, across a wrap-around
    rel = [(t - ticks[0] + 2**31) % 2**32 - 2**31 for t in ticks] if timed else []
    start = min(rel, default=0)
    obs: list[dict[str, float | int]] = [
        {"range": rng, "bearing": b, "id": i,
         "time_in_scan": (rel[k] - start) / 1000.0 if timed else 0.0, **device}
        for k, (rng, b, i, _tick, device) in enumerate(seen)]
    period = max([NAV350_PERIOD_S, *(o["time_in_scan"] for o in obs)]) if timed else 0.0
    c.scans.append((_ns(msg.header, ns), period, obs))


def _pose(msg: object, msgtype: str) -> Pose:
    """The pose of a PoseStamped, a PoseWithCovarianceStamped or an Odometry (by ``msgtype``)."""
    if msgtype in (R.POSE_COV, R.ODOMETRY):  # both hold a PoseWithCovariance as ``pose``
        return cast("PoseWithCovarianceStamped", msg).pose.pose
    return cast("PoseStamped", msg).pose


def _pose_of(msg: object, msgtype: str, ns: int) -> tuple[int, float, float, float]:
    pose = _pose(msg, msgtype)
    return (_ns(cast("Stamped", msg).header, ns), float(pose.position.x), float(pose.position.y),
            _yaw(pose.orientation))


def _read_truth(c: BagContent, msg: object, msgtype: str, ns: int) -> None:
    t, x, y, h = _pose_of(msg, msgtype, ns)
    if not _finite(x, y, h):
        c.count("dropped_truth_not_finite")
        return
    c.truth.append((t, x, y, h))


def _read_circle(c: BagContent, msg: object, msgtype: str, ns: int) -> None:
    t, x, y, h = _pose_of(msg, msgtype, ns)
    if not _finite(x, y, h):
        c.count("dropped_circle_not_finite")
        return
    c.circle.append((t, x, y, h))


def _read_tf(c: BagContent, msg: object, _msgtype: str, _ns_: int) -> None:
    # the tf role reads tf2_msgs/TFMessage only (ros2_roles.ROLES)
    for tr in cast("TFMessage", msg).transforms:
        child = frame_name(tr.child_frame_id)
        if child in c.transforms:
            continue
        t, q = tr.transform.translation, tr.transform.rotation
        c.transforms[child] = (frame_name(tr.header.frame_id), float(t.x), float(t.y), _yaw(q))


_READERS: dict[str, Callable[[BagContent, object, str, int], None]] = {
    "odom": _read_odom, "gyro": _read_gyro, "nav": _read_nav, "reflectors": _read_reflectors,
    "truth": _read_truth, "tf": _read_tf, "circle": _read_circle,
}
"""Role -> its reader; each counts its messages itself only where it says so (nav)."""


def read_content(reader: Reader, chosen: Mapping[str, Sequence[str]]) -> BagContent:
    """Decode every message of the chosen topics (CDR, with the bag's and SICK's types).

    :raises InputError: a message that does not decode as its topic's type.
    """
    roles_of: dict[str, list[str]] = {}
    for role, ts in chosen.items():
        for t in ts:
            roles_of.setdefault(t, []).append(role)
    conns = [c for c in reader.connections if c.topic in roles_of]
    store = typestore(conns)
    for conn in conns:
        if conn.msgtype not in store.types:
            raise InputError(f"topic {conn.topic}: message type {conn.msgtype} is unknown "
                             f"(neither a standard ROS 2 type nor defined in the bag)")
    content = BagContent()
    for conn, bag_ns, raw in _messages(reader, conns):
        try:
            msg = store.deserialize_cdr(raw, conn.msgtype)
        except Exception as exc:  # rosbags raises whatever a truncated buffer gives
            raise InputError(f"topic {conn.topic}: a message at {bag_ns / 1e9:.3f} s is not a "
                             f"valid {conn.msgtype} ({type(exc).__name__})") from None
        for role in roles_of[conn.topic]:
            _READERS[role](content, msg, conn.msgtype, bag_ns)
            if role != "nav":
                content.count(role)
    return content


def _messages(reader: Reader, conns: Sequence[Connection]
              ) -> Iterator[tuple[Connection, int, bytes]]:
    try:
        yield from reader.messages(connections=conns)
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"{reader.path}: the bag is damaged ({type(exc).__name__}: "
                         f"{exc})") from None
