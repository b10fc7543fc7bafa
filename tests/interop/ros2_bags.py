"""rosbag2 bags written in code with rosbags' writer, from a simulated lgvtool drive.

:func:`bag_from_log` turns a simulated log into the topics a ROS 2 vehicle with SICK's NAV350
driver would record: wheel odometry (nav_msgs/Odometry, its yaw rate off by ``odom_yaw_scale``),
a gyro (sensor_msgs/Imu, exact), sick_scan_xd's NAVPoseData and NAVLandmarkData, a ground-truth
PoseStamped and the mounting on /tf_static.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from lgvtool.interop.ros2_types import typestore
from lgvtool.log import LogReader, topics

MDEG = math.pi / 180000.0
SENSOR_FRAME = "nav350_laser"


class Bag:
    """A rosbags writer with the message classes at hand."""

    def __init__(self, path: Path, storage: str = "mcap") -> None:
        from rosbags.rosbag2 import StoragePlugin, Writer

        self.store = typestore()
        self.T = self.store.types
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
        self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.conns: dict[str, Any] = {}

    def __enter__(self) -> Bag:
        self.writer.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.writer.close()

    def write(self, topic: str, msgtype: str, msg: Any, ns: int) -> None:
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.store)
        self.writer.write(self.conns[topic], ns, bytes(self.store.serialize_cdr(msg, msgtype)))

    # message builders ----------------------------------------------------------------
    def header(self, ns: int, frame: str) -> Any:
        sec, nsec = divmod(int(ns), 1_000_000_000)
        return self.T["std_msgs/msg/Header"](
            stamp=self.T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec), frame_id=frame)

    def vec(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Any:
        return self.T["geometry_msgs/msg/Vector3"](x=x, y=y, z=z)

    def quat(self, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2),
                                                      w=math.cos(yaw / 2))

    def pose(self, x: float, y: float, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/Pose"](
            position=self.T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=self.quat(yaw))

    def odometry(self, ns: int, v: float, w: float) -> Any:
        T = self.T
        return T["nav_msgs/msg/Odometry"](
            header=self.header(ns, "odom"), child_frame_id="base_link",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(0, 0, 0),
                                                          covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=self.vec(v), angular=self.vec(z=w)),
                covariance=np.zeros(36)))

    def twist(self, ns: int, v: float, w: float) -> Any:
        T = self.T
        return T["geometry_msgs/msg/TwistStamped"](
            header=self.header(ns, "base_link"),
            twist=T["geometry_msgs/msg/Twist"](linear=self.vec(v), angular=self.vec(z=w)))

    def imu(self, ns: int, w: float) -> Any:
        return self.T["sensor_msgs/msg/Imu"](
            header=self.header(ns, "imu"), orientation=self.quat(0.0),
            orientation_covariance=np.zeros(9), angular_velocity=self.vec(z=w),
            angular_velocity_covariance=np.zeros(9), linear_acceleration=self.vec(),
            linear_acceleration_covariance=np.zeros(9))

    def pose_stamped(self, ns: int, x: float, y: float, yaw: float) -> Any:
        return self.T["geometry_msgs/msg/PoseStamped"](header=self.header(ns, "map"),
                                                       pose=self.pose(x, y, yaw))

    def nav_pose(self, ns: int, x: float, y: float, heading: float, used: int,
                 valid: bool, device: dict[str, Any] | None = None) -> Any:
        """A NAVPoseData; ``device``: the recorded NAV350 pose's own fields (tick, meanDev,
        navMode, infoState, outputMode), else made-up ones."""
        phi = round((heading % (2 * math.pi)) / MDEG) % 360000
        d = {"device_time_ms": (ns // 1_000_000) % 2**32, "mean_dev": 10, "nav_mode": 4,
             "info_state": 0, "output_mode": 0, **(device or {})}
        return self.T["sick_scan_xd/msg/NAVPoseData"](
            header=self.header(ns, SENSOR_FRAME), x=round(x * 1000), y=round(y * 1000), phi=phi,
            opt_pose_data_valid=1, output_mode=int(d["output_mode"]),
            timestamp=int(d["device_time_ms"]), mean_dev=int(d["mean_dev"]),
            nav_mode=int(d["nav_mode"]), info_state=int(d["info_state"]),
            quant_used_reflectors=used, pose_valid=1 if valid else 0, pose_x=-x, pose_y=-y,
            pose_yaw=phi * MDEG - math.pi)

    def landmarks(self, ns: int, observations: Iterable[dict[str, Any]]) -> Any:
        refl = []
        for o in observations:
            phi = round((o["bearing"] % (2 * math.pi)) / MDEG) % 360000
            known = o["id"] >= 0
            refl.append(self.T["sick_scan_xd/msg/NAVReflectorData"](
                cartesian_data_valid=0, x=0, y=0, polar_data_valid=1,
                dist=round(o["range"] * 1000), phi=phi, opt_reflector_data_valid=1,
                local_id=o.get("local_id", 0), global_id=o["id"] if known else 0, type=1,
                sub_type=0, quality=o.get("quality", 90),
                timestamp=o.get("device_time_ms",
                                round(ns / 1e6 + o["time_in_scan"] * 1000) % 2**32),
                size=80, hit_count=o.get("hit_count", 5), mean_echo=o.get("mean_echo", 100),
                start_index=0, end_index=0, pos_valid=0, pos_x=0.0, pos_y=0.0))
        return self.T["sick_scan_xd/msg/NAVLandmarkData"](
            header=self.header(ns, SENSOR_FRAME), landmark_filter=1, num_reflectors=len(refl),
            reflectors=refl)

    def tf(self, ns: int, parent: str, child: str, x: float, y: float) -> Any:
        T = self.T
        return T["tf2_msgs/msg/TFMessage"](transforms=[T["geometry_msgs/msg/TransformStamped"](
            header=self.header(ns, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](translation=self.vec(x, y),
                                                       rotation=self.quat(0.0)))])


DEVICE_POSE_KEYS = ("device_time_ms", "mean_dev", "nav_mode", "info_state", "output_mode")
"""What a recorded NAV350 pose says of itself, written into the NAVPoseData."""


def bag_from_log(log: Path, path: Path, *, storage: str = "mcap", odom_yaw_scale: float = 1.1,
                 odometry: str = "odometry", gyro: bool = True, nav: bool = True,
                 reflectors: bool = True, truth: bool = True, tf: bool = True) -> Path:
    """Write a bag at ``path`` from the simulated ``log`` (see the module docstring)."""
    reader = LogReader(log)
    cfg = reader.config()
    tru = reader.dataframe(topics.TRUTH)
    t_ns = np.round(tru["t"].to_numpy() * 1e9).astype(np.int64)
    x, y = tru["x"].to_numpy(), tru["y"].to_numpy()
    h = np.unwrap(tru["heading"].to_numpy())
    dt = np.diff(t_ns) * 1e-9
    v = (np.cos(h[:-1]) * np.diff(x) + np.sin(h[:-1]) * np.diff(y)) / dt
    w = np.diff(h) / dt
    with Bag(path, storage) as bag:
        if tf:
            bag.write("/tf_static", "tf2_msgs/msg/TFMessage",
                      bag.tf(int(t_ns[0]), "base_link", SENSOR_FRAME, cfg.vehicle.nav_x,
                             cfg.vehicle.nav_y), int(t_ns[0]))
        for k in range(len(dt)):
            ns = int(t_ns[k])
            if odometry == "odometry":
                bag.write("/odom", "nav_msgs/msg/Odometry",
                          bag.odometry(ns, float(v[k]), float(w[k]) * odom_yaw_scale), ns)
            elif odometry == "twist":
                bag.write("/cmd_vel_stamped", "geometry_msgs/msg/TwistStamped",
                          bag.twist(ns, float(v[k]), float(w[k]) * odom_yaw_scale), ns)
            if gyro:
                mid = (int(t_ns[k]) + int(t_ns[k + 1])) // 2
                bag.write("/imu/data", "sensor_msgs/msg/Imu", bag.imu(mid, float(w[k])), mid)
            if truth:
                bag.write("/ground_truth/pose", "geometry_msgs/msg/PoseStamped",
                          bag.pose_stamped(ns, float(x[k]), float(y[k]), float(h[k])), ns)
        if nav:
            for m in reader.messages([topics.NAV_POSE]):
                d = m.data
                ns = d["timestamp"]["sec"] * 1_000_000_000 + d["timestamp"]["nsec"]
                device = {k: d[k] for k in DEVICE_POSE_KEYS if k in d} or None
                bag.write("/sick_nav_350/nav_pose", "sick_scan_xd/msg/NAVPoseData",
                          bag.nav_pose(ns, d["x"], d["y"], d["heading"],
                                       int(d["reflectors_used"]), bool(d["valid"]), device), ns)
        if reflectors:
            for m in reader.messages([topics.NAV_REFLECTORS]):
                ns = m.data["timestamp"]["sec"] * 1_000_000_000 + m.data["timestamp"]["nsec"]
                bag.write("/sick_nav_350/nav_landmark", "sick_scan_xd/msg/NAVLandmarkData",
                          bag.landmarks(ns, m.data["observations"]), ns)
    return path
