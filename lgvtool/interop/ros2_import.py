"""``lgvtool import ros2``: a rosbag2 bag (MCAP or SQLite storage) into an lgvtool log.

The bag is read with rosbags (a bag folder with ``metadata.yaml``, or a single ``.mcap`` or
``.db3`` file). Topics play roles (:mod:`lgvtool.interop.ros2_roles`) and are written as the
log contract's channels (docs/log-format.md), in SI units:

- odometry (``nav_msgs/Odometry``, ``geometry_msgs/TwistStamped``): forward speed
  ``twist.linear.x`` (m/s) and yaw rate ``twist.angular.z`` (rad/s) of the vehicle frame's
  origin, taken as O, on ``/odom/twist``; with a gyro (``sensor_msgs/Imu``) the yaw rate of each
  odometry interval is the mean ``angular_velocity.z`` of the gyro samples in it instead;
- NAV pose, on ``/nav/pose`` as the pose of the navigation head (the log's convention):
  ``sick_scan_xd/NAVPoseData`` is the head's own (the telegram's ``x``, ``y`` in mm and
  ``phi`` in mdeg, in the device's map frame; ``pose_valid`` > 0 is a valid pose); a generic
  pose (``geometry_msgs`` PoseStamped or PoseWithCovarianceStamped, and with ``--topic nav=``
  an Odometry or a ``map`` -> frame transform of /tf) is the pose of the frame it names
  (:func:`nav_pose_frame`): by default the vehicle frame's (REP 105: ``base_link`` in
  ``map``), which is O and is converted to the head with the mounting, so that the ``laser``
  baseline gets the bag's pose back; a sensor frame's (``--nav-frame``, or a frame that /tf
  hangs under the vehicle frame) is the head's;
- reflectors: ``sick_scan_xd/NAVLandmarkData``, each reflector with polar data as range
  ``dist`` mm and bearing ``phi`` mdeg (counter-clockwise from the head's x axis), id its
  ``global_id`` when the optional block is present, else -1, on ``/nav/reflectors``;
- truth: a ``geometry_msgs`` pose or ``nav_msgs/Odometry`` pose of O on ``/truth/pose``;
- ``/tf``, ``/tf_static``: the transform chain from the vehicle frame (the odometry's
  ``child_frame_id``, ``base_link``, ``base_footprint``) to the sensor frame (the frame of a
  generic head pose, else ``--sensor-frame``, else the NAV350 messages' ``header.frame_id``,
  else ``nav``) gives the mounting ``vehicle.nav_x``, ``vehicle.nav_y``; else ``--config``'s,
  else lgvtool's default vehicle's (the summary says which).

The reference circle of a circle drive: the bag has no steering angle, so evaluate uses the
``--config`` steering angle if it gives one, else the circle fitted to the ground truth; with
neither, or to choose, ``--circle-from`` names the reference (a pose topic of the bag, fitted
here, or an estimator, fitted by evaluate), never the NAV pose being scored. The choice is
said in the summary and stored in the importer record (``circle_reference``,
:func:`lgvtool.evaluate.reference.circle_from_log`).

Log times are the messages' header stamps (the bag's receive time where a stamp is zero), so
every channel shares the clock the estimators compare. The vehicle geometry and the reflector
map come from ``--config``; without it the log has no reflector map, no reference circle and a
work area around the poses.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lgvtool.angles import wrap_scalar
from lgvtool.config import Area, Config, Reference, default_config, load_config
from lgvtool.errors import InputError, MissingDataError
from lgvtool.interop import ros2_roles as R
from lgvtool.interop.ros2_bag import MAP_FRAME, BagContent, frame_name, open_bag, read_content
from lgvtool.interop.ros2_types import NAV_POSE_DATA
from lgvtool.json_types import JSONObject, as_float
from lgvtool.localize.geometry import o_to_nav
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame
from lgvtool.outputs import atomic_output, guard_output
from lgvtool.timestamps import stamp

if TYPE_CHECKING:
    from lgvtool.circle import Circle
    from lgvtool.evaluate.reference import ReferenceFit

AREA_MARGIN_M = 2.0
"""Margin of the work area around the poses when no --config gives one, m."""
UNKNOWN_QUALITY, INVALID_QUALITY = 0, 255
"""/nav/pose quality written for a valid and an invalid pose: a ROS pose carries no quality
(0, as a NAV350's, says so: no localisation score is made up from it), and a NAVPoseData
carries the NAV350's own (:attr:`lgvtool.interop.ros2_bag.BagContent.nav_device`)."""
DEFAULT_VEHICLE_FRAME = "base_link"
DEFAULT_SENSOR_FRAME = "nav"
VEHICLE_FRAMES = (DEFAULT_VEHICLE_FRAME, "base_footprint")
"""REP 105's frames of the vehicle body: a pose of one of them is the vehicle's (of O)."""
ODOM_FRAME = "odom"
"""REP 105's odometry frame: a map -> odom transform is no pose of the vehicle."""
CIRCLE_OPTIONS = ("auto", "truth", "none")
"""``--circle-from`` words; anything else is a /topic or an estimator's name."""
RADIUS_MISMATCH = 0.05
"""A configured kinematic radius this far (fraction) from the truth's circle is noted."""


@dataclass(frozen=True)
class Ros2ImportSummary:
    """What :func:`import_bag` wrote."""

    path: str
    bag: str
    topics: dict[str, JSONObject]
    """role -> {topic, type, messages}."""
    counts: dict[str, int]
    mounting: JSONObject
    yaw_rate: str
    messages: int
    start_s: float
    end_s: float
    elapsed_s: float
    notes: tuple[str, ...] = ()
    nav_pose: JSONObject | None = None
    """Whose pose the NAV topic gives and how it was stored (of, frame, how, stored)."""
    circle_reference: JSONObject | None = None
    """What evaluate fits the reference circle to (option, source, name, note, ...)."""

    def to_dict(self) -> JSONObject:
        """A JSON-ready dict (stable keys)."""
        d: JSONObject = asdict(self)
        d["notes"] = list(self.notes)
        return d

    def format_text(self) -> str:
        """A short summary: output, one line per role, the mounting."""
        lines = [f"{self.bag} -> {self.path} ({self.messages} messages, "
                 f"{self.end_s - self.start_s:.1f} s of data, imported in {self.elapsed_s:.2f} s)"]
        for role, info in self.topics.items():
            lines.append(f"  {role:<10} {info['topic']} ({info['type']}, {info['messages']} "
                         f"messages)")
        if self.nav_pose is not None:
            lines.append(f"  nav pose   {self.nav_pose['note']}")
        m = self.mounting
        lines.append(f"  mounting   nav_x {m['nav_x']:.4f} m, nav_y {m['nav_y']:.4f} m "
                     f"({m['source']})")
        lines.append(f"  yaw rate   from the {self.yaw_rate}")
        if self.circle_reference is not None:
            lines.append(f"  circle     {self.circle_reference['note']}")
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


def vehicle_frames(content: BagContent) -> list[str]:
    """The frames of the vehicle body: the odometry's child frames, ``base_link``,
    ``base_footprint``."""
    return list(dict.fromkeys([*content.vehicle_frames, *VEHICLE_FRAMES]))


def below_vehicle(content: BagContent, frame: str) -> str | None:
    """``vehicle->frame`` when the bag's transforms hang ``frame`` (not itself a vehicle
    frame) under a vehicle frame, else None."""
    vehicles = vehicle_frames(content)
    current = frame_name(frame)
    for _ in range(32):
        edge = content.transforms.get(current)
        if edge is None:
            return None
        current = edge[0]
        if current in vehicles:
            return f"{current}->{frame_name(frame)}"
    return None


@dataclass(frozen=True)
class NavFrame:
    """Whose pose the NAV topic gives (:func:`nav_pose_frame`)."""

    of: str
    """'vehicle' (the pose of O, converted to the head) or 'head' (stored as it is)."""
    frame: str
    """The frame the pose is of ('' when the messages name none)."""
    how: str
    """Why, for the summary."""


def nav_pose_frame(content: BagContent, nav_type: str, nav_frame: str | None) -> NavFrame:
    """Whose pose the NAV topic of type ``nav_type`` gives.

    NAVPoseData: the head's (the NAV350's own). A generic pose: of ``nav_frame`` if given,
    else of the messages' child frame (Odometry, /tf), else of their header frame when that is
    a vehicle frame or a sensor frame (hung under the vehicle frame in /tf), else of the
    vehicle frame: REP 105's localisation publishes ``base_link``'s pose in ``map``, its
    header frame being the parent. A vehicle frame's pose is the vehicle's, any other the
    head's."""
    if nav_type == NAV_POSE_DATA:
        frame = content.sensor_frames[0] if content.sensor_frames else ""
        return NavFrame("head", frame, "sick_scan_xd NAVPoseData: the NAV350's own pose of "
                                       "its head")
    vehicles = vehicle_frames(content)
    children = list(dict.fromkeys(c for _, c in content.nav_frames if c))
    headers = list(dict.fromkeys(h for h, c in content.nav_frames if not c))
    if nav_frame:
        frame, how = frame_name(nav_frame), "--nav-frame"
    elif children:
        frame = children[0]
        how = "the messages' child frame" + (
            f" (of {', '.join(children)}; --nav-frame chooses)" if len(children) > 1 else "")
    else:
        header = headers[0] if headers else ""
        chain = below_vehicle(content, header) if header else None
        if header in vehicles:
            frame, how = header, "frame_id names the vehicle frame"
        elif chain is not None:
            frame, how = header, f"frame_id names a sensor frame, {chain} in /tf"
        else:
            frame = ""
            how = f"REP 105: frame_id '{header or '(empty)'}' is the pose's parent frame"
    of = "vehicle" if not frame or frame in vehicles else "head"
    return NavFrame(of, frame, how)


def take_map_poses(content: BagContent, nav_frame: str | None) -> None:
    """Make the poses of one child frame of a /tf NAV topic the NAV poses: ``nav_frame``,
    else a vehicle frame, else the one child of ``map`` other than ``odom``.

    :raises InputError: no such transform, or no single candidate.
    """
    children = list(content.map_poses)
    if not children:
        raise MissingDataError(f"the nav topic holds no {MAP_FRAME}->FRAME transform")
    listed = ", ".join(f"{MAP_FRAME}->{c}" for c in children)
    if nav_frame:
        child = frame_name(nav_frame)
        if child not in content.map_poses:
            raise InputError(f"--nav-frame {child}: the nav topic has no {MAP_FRAME}->{child} "
                             f"transform (it has {listed})")
    else:
        vehicles = [f for f in vehicle_frames(content) if f in content.map_poses]
        others = [c for c in children if c != ODOM_FRAME]
        if vehicles:
            child = vehicles[0]
        elif len(others) == 1:
            child = others[0]
        else:
            raise InputError(
                f"the nav topic's transforms ({listed}) give no single pose: lgvtool reads "
                f"direct {MAP_FRAME}->FRAME transforms, not chains such as "
                f"{MAP_FRAME}->{ODOM_FRAME}->{DEFAULT_VEHICLE_FRAME}; name FRAME with "
                f"--nav-frame")
    content.nav = sorted(content.map_poses[child])
    content.nav_frames = [(MAP_FRAME, child)]


def mounting(content: BagContent, sensor_frame: str | None
             ) -> tuple[float, float, float, str] | None:
    """The sensor's pose in the vehicle frame (x m, y m, yaw rad, 'vehicle->sensor') from the
    bag's transforms, or None when no chain joins the two frames."""
    vehicles = vehicle_frames(content)
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


def _records(content: BagContent, fused: np.ndarray | None
             ) -> list[tuple[int, int, str, Mapping[str, object]]]:
    """(log time ns, stream, topic, message) of every message, unsorted."""
    out: list[tuple[int, int, str, Mapping[str, object]]] = []
    for t, x, y, h in content.truth:
        out.append((t, 0, topics.TRUTH, pose_in_frame(t, x, y, h)))
    for k, (t, v, w) in enumerate(content.odom):
        omega = float(fused[k]) if fused is not None else w
        out.append((t, 1, topics.ODOM, {"timestamp": stamp(t), "v": v, "omega": omega}))
    for t, x, y, h, used, valid in content.nav:
        out.append((t, 2, topics.NAV_POSE, {
            "timestamp": stamp(t), "x": x, "y": y, "heading": h,
            "quality": UNKNOWN_QUALITY if valid else INVALID_QUALITY, "reflectors_used": used,
            "valid": valid, **content.nav_device.get(t, {})}))
    for t, period, obs in content.scans:
        out.append((t, 3, topics.NAV_REFLECTORS,
                    {"timestamp": stamp(t), "scan_period": period, "observations": obs}))
    return out


def _config(config: Config | str | Path | None, content: BagContent,
            mount: tuple[float, float, float, str] | None, notes: list[str]
            ) -> tuple[Config, JSONObject]:
    if config is None:
        cfg = replace(default_config(), reflectors=(), area=_data_area(content),
                      reference=Reference(steering_angle_deg=None))
        notes.append("no --config: no reflector map, the work area around the poses, "
                     "lgvtool's default vehicle")
    else:
        cfg = config if isinstance(config, Config) else load_config(config)
    if mount is None:
        source = "config" if config is not None else "default vehicle"
        return cfg, {"source": source, "nav_x": cfg.vehicle.nav_x, "nav_y": cfg.vehicle.nav_y}
    x, y, yaw, chain = mount
    cfg = replace(cfg, vehicle=replace(cfg.vehicle, nav_x=x, nav_y=y))
    return cfg, {"source": f"tf {chain}", "nav_x": x, "nav_y": y, "yaw_rad": yaw}


def _stored_nav(content: BagContent, nf: NavFrame, nav_type: str, cfg: Config,
                mount_info: JSONObject, notes: list[str]
                ) -> tuple[list[tuple[int, float, float, float, int, bool]], str]:
    """The NAV poses as the log stores them (the head's, heading the vehicle's), and how."""
    yaw = as_float(mount_info.get("yaw_rad", 0.0))
    turned = abs(yaw) > 1e-3
    if turned and (nf.of == "vehicle" or nav_type == NAV_POSE_DATA):
        notes.append(f"the sensor is mounted turned by {math.degrees(yaw):.2f} deg in the "
                     f"transforms; only its position is used")
    if nf.of == "vehicle":
        if not content.nav:
            return [], "none"
        a = np.array([(x, y, h) for _, x, y, h, _, _ in content.nav])
        hx, hy, _ = o_to_nav(a[:, 0], a[:, 1], a[:, 2], cfg.vehicle.nav_x, cfg.vehicle.nav_y)
        out = [(t, float(hx[k]), float(hy[k]), h, used, valid)
               for k, (t, _, _, h, used, valid) in enumerate(content.nav)]
        return out, "the vehicle's pose converted to the head with the mounting"
    if nav_type == NAV_POSE_DATA or not turned:
        return list(content.nav), "the head's pose as it is"
    notes.append(f"the sensor is mounted turned by {math.degrees(yaw):.2f} deg in the "
                 f"transforms: its headings are turned back by that much to the vehicle's")
    return ([(t, x, y, wrap_scalar(h - yaw), used, valid)
             for t, x, y, h, used, valid in content.nav],
            "the head's position, its heading turned back by the mounting yaw")


# ------------------------------------------------------------------ the reference circle


def check_circle_option(option: str, types: dict[str, str], chosen: dict[str, list[str]]
                        ) -> str | None:
    """Vet ``--circle-from``; returns the bag topic to read for it (None: no topic).

    :raises InputError: not auto, truth, none, a pose topic of the bag other than the NAV
        pose, or an estimator's name.
    """
    from lgvtool.localize.registry import ESTIMATORS

    if option in CIRCLE_OPTIONS:
        if option == "truth" and not chosen.get("truth"):
            raise InputError("--circle-from truth: the bag has no ground-truth topic (choose one "
                             "with --topic truth=/name)")
        return None
    if option.startswith("/"):
        if option not in types:
            raise InputError(f"--circle-from {option}: the bag has no such topic (it has "
                             f"{', '.join(sorted(types)) or 'none'})")
        if types[option] not in R.POSE_TYPES:
            raise InputError(f"--circle-from {option}: {R.short(types[option])} carries no pose "
                             f"({', '.join(map(R.short, R.POSE_TYPES))} do)")
        if option in chosen.get("nav", []):
            raise InputError(f"--circle-from {option}: that is the NAV pose lgvtool scores (the "
                             f"laser baseline); the reference must be another topic, truth or "
                             f"an estimator")
        return option
    if option in ESTIMATORS:
        return None
    raise InputError(f"--circle-from {option}: expected auto, truth, none, a /topic of the bag "
                     f"or an estimator ({', '.join(ESTIMATORS)})")


def circle_reference(option: str, content: BagContent, cfg: Config,
                     chosen: dict[str, list[str]], notes: list[str]) -> JSONObject:
    """What evaluate fits the reference circle to (the importer record's
    ``circle_reference``; :func:`lgvtool.evaluate.reference.circle_from_log` reads it).

    :raises InputError: a named topic or truth that does not drive a circle.
    """
    from lgvtool.circle import kinematic_radius
    from lgvtool.evaluate.reference import describe_circle, fit_reference_circle

    def fit(poses: list[tuple[int, float, float, float]], name: str) -> ReferenceFit:
        a = np.array([p[:3] for p in sorted(poses)], dtype=float).reshape(-1, 3)
        return fit_reference_circle(a[:, 0] * 1e-9, a[:, 1], a[:, 2], name)

    def circle_fields(c: Circle, turns: int) -> JSONObject:
        return {"centre_x_m": c.cx, "centre_y_m": c.cy, "radius_m": c.r, "turns": turns}

    truth_topic = chosen["truth"][0] if chosen.get("truth") else None
    if option.startswith("/"):
        got = fit(content.circle, option)
        if got.circle is None:
            raise InputError(f"--circle-from {option}: no reference circle: {got.problem}")
        return {"option": option, "source": "topic", "name": option,
                **circle_fields(got.circle, got.laps.complete),
                "note": f"fitted to {option} (--circle-from): {describe_circle(got.circle)}, "
                        f"{got.laps.complete} full turn(s); evaluate scores every estimator "
                        f"against it"}
    if option == "none":
        return {"option": option, "source": "none", "name": None,
                "note": "none (--circle-from none): evaluate gives ground-truth metrics only"}
    if option not in CIRCLE_OPTIONS:  # an estimator
        return {"option": option, "source": "estimator", "name": option,
                "note": f"fitted by evaluate to estimator '{option}' (--circle-from); the other "
                        f"estimators are scored against it, '{option}' itself is not"}
    steering = cfg.reference.steering_angle_deg
    truth = fit(content.truth, "truth") if content.truth else None
    if option == "auto" and steering is not None:
        kin = kinematic_radius(cfg.vehicle.h, math.radians(steering))
        if truth is not None and truth.circle is not None and math.isfinite(kin) and abs(
                truth.circle.r - kin) > RADIUS_MISMATCH * kin:
            notes.append(f"the ground truth drives a circle of radius {truth.circle.r:.4f} m, "
                         f"the configured steering angle {steering:g} deg gives R = {kin:.4f} m: "
                         f"check reference.steering_angle_deg in --config (false, or "
                         f"--circle-from truth, uses the truth's circle)")
        return {"option": option, "source": "kinematic", "name": None,
                "steering_angle_deg": steering, "kinematic_radius_m": kin,
                "note": f"kinematic: R = h / tan(delta) = {kin:.4f} m with the steering angle "
                        f"{steering:g} deg of --config (reference.steering_angle_deg; the bag "
                        f"has no steering angle)"}
    if truth is None:
        if option == "truth":
            raise InputError(f"--circle-from truth: the ground truth {truth_topic} holds no "
                             f"usable pose")
        return {"option": option, "source": "none", "name": None,
                "note": "none: the bag has no steering angle, --config gives none and there is "
                        "no ground truth, so evaluate has nothing to compare with; name a "
                        "reference with --circle-from /TOPIC or ESTIMATOR"}
    if truth.circle is None:
        if option == "truth":
            raise InputError(f"--circle-from truth: no reference circle: {truth.problem}")
        return {"option": option, "source": "none", "name": None,
                "note": f"none: no steering angle, and the ground truth {truth_topic} is no "
                        f"circle drive ({truth.problem}); evaluate gives ground-truth metrics "
                        f"only"}
    return {"option": option, "source": "truth", "name": truth_topic,
            **circle_fields(truth.circle, truth.laps.complete),
            "note": f"fitted to the ground truth {truth_topic}"
                    f"{' (--circle-from truth)' if option == 'truth' else ''}: "
                    f"{describe_circle(truth.circle)}, {truth.laps.complete} full turn(s); "
                    f"evaluate scores every estimator against it"}


# ------------------------------------------------------------------------------ import


def import_bag(bag: str | Path, out: str | Path, *, topic_options: Sequence[str] = (),
               config: Config | str | Path | None = None, sensor_frame: str | None = None,
               nav_frame: str | None = None, circle_from: str = "auto",
               compression: str = "zstd", force: bool = False) -> Ros2ImportSummary:
    """Import the rosbag2 bag ``bag`` into the log ``out`` (replaced atomically).

    :param topic_options: ``ROLE=/name`` choices (``ROLE=none`` leaves a role out).
    :param config: a configuration (or its TOML file) for the vehicle and the reflector map.
    :param sensor_frame: the frame of the navigation sensor in the bag's transforms.
    :param nav_frame: the frame whose pose a generic NAV pose topic gives (default: as the
        messages say, else the vehicle frame: :func:`nav_pose_frame`).
    :param circle_from: what evaluate fits the reference circle to: ``auto`` (the configured
        steering angle, else the truth), ``truth``, ``none``, a pose ``/topic`` of the bag or
        an estimator's name (:func:`circle_reference`).
    :raises InputError: not a bag; no odometry or no observation topic; a bad ``--topic``,
        ``--nav-frame`` or ``--circle-from``; a message that does not decode; an output that is
        the bag or exists without ``force``.
    """
    started = time.perf_counter()
    source = Path(bag)
    overrides = R.parse_topic_options(topic_options)
    circle_from = (circle_from or "auto").strip()
    target = guard_output(out, [source], force=force)
    if not target.parent.is_dir():
        raise InputError(f"{target}: folder {target.parent} does not exist")
    if isinstance(config, str | Path):
        config = load_config(config)
    reader = open_bag(source)
    try:
        types = {c.topic: c.msgtype for c in reader.connections}
        chosen = R.choose_topics(types, overrides)
        circle_topic = check_circle_option(circle_from, types, chosen)
        to_read = {**chosen, "circle": [circle_topic] if circle_topic else []}
        content = read_content(reader, to_read)
        storage = "sqlite3" if source.suffix == ".db3" or any(
            p.suffix == ".db3" for p in (source.iterdir() if source.is_dir() else [])) else "mcap"
        distro = getattr(reader, "ros_distro", None)
    finally:
        reader.close()
    nav_type = types[chosen["nav"][0]] if chosen["nav"] else ""
    if nav_type == R.TF:
        take_map_poses(content, nav_frame)
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
    nf = nav_pose_frame(content, nav_type, nav_frame)
    if nav_frame and nav_type == NAV_POSE_DATA:
        notes.append(f"--nav-frame {nav_frame} has no effect: NAVPoseData is the NAV350's own "
                     f"pose of its head")
    head_frame = nf.frame if nf.of == "head" and nav_type != NAV_POSE_DATA else None
    if head_frame and sensor_frame and frame_name(sensor_frame) != head_frame:
        raise InputError(f"--sensor-frame {sensor_frame}: the NAV poses are those of the sensor "
                         f"frame {head_frame} ({nf.how}); give one sensor frame")
    mount = mounting(content, head_frame or sensor_frame)
    cfg, mount_info = _config(config, content, mount, notes)
    if head_frame and mount is None:
        notes.append(f"no transform from the vehicle frame to {head_frame} in /tf: the mounting "
                     f"is the {mount_info['source']}'s")
    stored_nav, stored = _stored_nav(content, nf, nav_type, cfg, mount_info, notes)
    content.nav = stored_nav
    if nf.of == "vehicle":
        nav_note = (f"the vehicle's pose ({nf.frame or DEFAULT_VEHICLE_FRAME}; {nf.how}), "
                    f"converted to the head with the mounting")
    else:
        nav_note = f"the head's pose ({nf.frame or 'its frame unnamed'}; {nf.how})"
        if stored != "the head's pose as it is":
            nav_note += f": {stored}"
    nav_info: JSONObject | None = ({"of": nf.of, "frame": nf.frame or None, "how": nf.how, "stored": stored,
                 "note": nav_note} if content.nav else None)
    circle_info = circle_reference(circle_from, content, cfg, chosen, notes)
    records = sorted(_records(content, fused), key=lambda r: (r[0], r[1]))
    role_info: dict[str, JSONObject] = {role: {"topic": ts[0], "type": R.short(types[ts[0]]),
                        "messages": content.counts.get(role, 0)}
                 for role, ts in chosen.items() if ts and role != "tf"}
    if chosen["tf"]:
        role_info["tf"] = {"topic": ", ".join(chosen["tf"]), "type": R.short(R.TF),
                           "messages": content.counts.get("tf", 0)}
    if circle_topic:
        role_info["circle"] = {"topic": circle_topic, "type": R.short(types[circle_topic]),
                               "messages": content.counts.get("circle", 0)}
    start_ns = records[0][0]
    with atomic_output(target) as tmp, LogWriter(tmp, chunk_seconds=None, compression=compression,
                   source="import ros2") as w:
        w.add_metadata("importer", {
            "importer": "ros2", "bag": source.name, "storage": storage,
            "ros_distro": distro, "topics": role_info, "nav_pose": nav_info,
            "mounting": mount_info, "circle_reference": circle_info,
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
        notes=tuple(notes), nav_pose=nav_info, circle_reference=circle_info)
