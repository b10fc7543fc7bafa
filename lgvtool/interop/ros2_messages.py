"""The fields of the ROS 2 messages ``lgvtool import ros2`` reads, as typed Protocols.

rosbags decodes a message into an instance of a class it makes from the type's definition
(the standard ROS 2 Humble types, sick_scan_xd's NAV350 messages); each Protocol here names
the fields :mod:`lgvtool.interop.ros2_bag` reads of one type, with the units the message
defines (m, rad, rad/s, m/s; sick_scan_xd: mm and mdeg).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

__all__ = ["Header", "Imu", "NavLandmarkData", "NavPoseData", "NavReflectorData", "Odometry",
           "Pose", "PoseStamped", "PoseWithCovarianceStamped", "Quaternion", "Stamped", "TFMessage",
           "TwistStamped", "Vector3"]


class Time(Protocol):
    """``builtin_interfaces/Time``: seconds and nanoseconds."""

    sec: int
    nanosec: int


class Header(Protocol):
    """``std_msgs/Header``: the stamp and the frame the message is given in."""

    stamp: Time
    frame_id: str


class Stamped(Protocol):
    """Any message with a header (every type read here but ``tf2_msgs/TFMessage``)."""

    header: Header


class Vector3(Protocol):
    """``geometry_msgs/Vector3`` (also a Point): x, y, z (m, m/s or rad/s)."""

    x: float
    y: float
    z: float


class Quaternion(Protocol):
    """``geometry_msgs/Quaternion``: a rotation as x, y, z, w."""

    x: float
    y: float
    z: float
    w: float


class Pose(Protocol):
    """``geometry_msgs/Pose``: position (m) and orientation."""

    position: Vector3
    orientation: Quaternion


class PoseWithCovariance(Protocol):
    """``geometry_msgs/PoseWithCovariance``: its pose (the covariance is not read)."""

    pose: Pose


class Twist(Protocol):
    """``geometry_msgs/Twist``: linear (m/s) and angular (rad/s) velocity."""

    linear: Vector3
    angular: Vector3


class TwistWithCovariance(Protocol):
    """``geometry_msgs/TwistWithCovariance``: its twist (the covariance is not read)."""

    twist: Twist


class Odometry(Protocol):
    """``nav_msgs/Odometry``: the pose in ``header.frame_id``, the twist in ``child_frame_id``."""

    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


class TwistStamped(Protocol):
    """``geometry_msgs/TwistStamped``."""

    header: Header
    twist: Twist


class Imu(Protocol):
    """``sensor_msgs/Imu``: the angular velocity (rad/s) is read."""

    header: Header
    angular_velocity: Vector3


class PoseStamped(Protocol):
    """``geometry_msgs/PoseStamped``."""

    header: Header
    pose: Pose


class PoseWithCovarianceStamped(Protocol):
    """``geometry_msgs/PoseWithCovarianceStamped``."""

    header: Header
    pose: PoseWithCovariance


class Transform(Protocol):
    """``geometry_msgs/Transform``: translation (m) and rotation."""

    translation: Vector3
    rotation: Quaternion


class TransformStamped(Protocol):
    """``geometry_msgs/TransformStamped``: the child frame in ``header.frame_id``."""

    header: Header
    child_frame_id: str
    transform: Transform


class TFMessage(Protocol):
    """``tf2_msgs/TFMessage``."""

    transforms: Sequence[TransformStamped]


class NavPoseData(Protocol):
    """``sick_scan_xd/NAVPoseData``: the NAV350's pose, x and y in mm, phi in mdeg; its tick
    ``timestamp`` in ms; ``mean_dev``, ``nav_mode``, ``info_state`` as the device reports them
    (units and codes not documented)."""

    header: Header
    x: int
    y: int
    phi: int
    opt_pose_data_valid: int
    output_mode: int
    timestamp: int
    mean_dev: int
    nav_mode: int
    info_state: int
    quant_used_reflectors: int
    pose_valid: int


class NavReflectorData(Protocol):
    """``sick_scan_xd/NAVReflectorData``: dist in mm, phi in mdeg, timestamp in ms; quality,
    hit count and mean echo in device units."""

    polar_data_valid: int
    dist: int
    phi: int
    opt_reflector_data_valid: int
    local_id: int
    global_id: int
    quality: int
    timestamp: int
    hit_count: int
    mean_echo: int


class NavLandmarkData(Protocol):
    """``sick_scan_xd/NAVLandmarkData``: the reflectors of one scan."""

    header: Header
    reflectors: Sequence[NavReflectorData]
