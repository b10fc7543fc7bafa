"""The automatic choice of topics for ``import ros2`` and ``--topic`` overrides (names only)."""

from __future__ import annotations

import pytest

from lgvtool.errors import InputError
from lgvtool.interop import ros2_roles as R
from lgvtool.interop.ros2_types import NAV_LANDMARK_DATA, NAV_POSE_DATA

BAG = {
    "/odom": R.ODOMETRY,
    "/ground_truth/odom": R.ODOMETRY,
    "/imu/data": R.IMU,
    "/sick_nav_350/nav_pose": NAV_POSE_DATA,
    "/sick_nav_350/nav_landmark": NAV_LANDMARK_DATA,
    "/amcl_pose": R.POSE_COV,
    "/tf": R.TF,
    "/tf_static": R.TF,
    "/scan": "sensor_msgs/msg/LaserScan",
}


def test_roles_by_type_and_truth_by_name() -> None:
    chosen = R.choose_topics(BAG)
    assert chosen == {"truth": ["/ground_truth/odom"], "odom": ["/odom"], "gyro": ["/imu/data"],
                      "nav": ["/sick_nav_350/nav_pose"],
                      "reflectors": ["/sick_nav_350/nav_landmark"], "tf": ["/tf", "/tf_static"]}


def test_a_generic_pose_is_the_nav_pose_without_nav350_and_twist_is_odometry() -> None:
    bag = {"/cmd_vel_stamped": R.TWIST, "/amcl_pose": R.POSE_COV, "/vicon/robot": R.POSE}
    chosen = R.choose_topics(bag)
    assert chosen["odom"] == ["/cmd_vel_stamped"] and chosen["nav"] == ["/amcl_pose"]
    assert chosen["truth"] == ["/vicon/robot"] and chosen["gyro"] == []


def test_overrides_take_their_topic_away_from_the_automatic_choice() -> None:
    chosen = R.choose_topics(BAG, R.parse_topic_options(
        ["nav=/amcl_pose", "truth=none", "gyro=none"]))
    assert chosen["nav"] == ["/amcl_pose"] and chosen["truth"] == [] and chosen["gyro"] == []
    assert chosen["odom"] == ["/odom"]


@pytest.mark.parametrize(("bag", "options", "expected"), [
    ({"/a": R.ODOMETRY, "/b": R.ODOMETRY, "/p": R.POSE}, [], "several nav_msgs/Odometry"),
    ({"/p": R.POSE}, [], "no usable odometry"),
    ({"/odom": R.ODOMETRY, "/imu": R.IMU}, [], "no observation topic"),
    (BAG, ["gyro=/scan"], "sensor_msgs/LaserScan is not a type the gyro role reads"),
    (BAG, ["odom=/nope"], "no such topic"),
    (BAG, ["lidar=/scan"], "no role 'lidar'"),
    (BAG, ["odom=/odom", "odom=/odom"], "given twice"),
])
def test_refusals(bag: dict[str, str], options: list[str], expected: str) -> None:
    with pytest.raises(InputError, match=expected):
        R.choose_topics(bag, R.parse_topic_options(options))


def test_truth_names() -> None:
    for name in ("/ground_truth/pose", "/groundtruth", "/robot/gt", "/gt_pose", "/vicon/a/a",
                 "/mocap/pose", "/truth"):
        assert R.looks_like_truth(name), name
    for name in ("/odom", "/nav_pose", "/gtx", "/strut"):
        assert not R.looks_like_truth(name), name
