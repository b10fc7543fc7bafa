"""Which bag topic plays which role in ``lgvtool import ros2`` (pure: names and types only).

Roles and the message types each reads, in order of preference:

============  =====================================================================  ===========
role          types                                                                  written to
============  =====================================================================  ===========
odom          nav_msgs/Odometry, geometry_msgs/TwistStamped                          /odom/twist
gyro          sensor_msgs/Imu                                                        /odom/twist
nav           sick_scan_xd/NAVPoseData, geometry_msgs/PoseWithCovarianceStamped,      /nav/pose
              geometry_msgs/PoseStamped; with ``--topic nav=`` only: nav_msgs/
              Odometry (its ``pose``), tf2_msgs/TFMessage (a ``map`` -> frame
              transform)
reflectors    sick_scan_xd/NAVLandmarkData                                           /nav/reflectors
truth         geometry_msgs/PoseStamped, geometry_msgs/PoseWithCovarianceStamped,     /truth/pose
              nav_msgs/Odometry
tf            tf2_msgs/TFMessage (every such topic: /tf, /tf_static)                 the mounting
============  =====================================================================  ===========

Chosen automatically: a topic whose name says ground truth (truth, groundtruth, gt, vicon,
mocap, optitrack) is the truth and nothing else; every other role takes the topic of its most
preferred type (among the types it reads without ``--topic``); two candidates of one type
are ambiguous and need ``--topic ROLE=/name``. ``--topic ROLE=none`` leaves a role out. A
topic named for the nav role may also serve the tf role (``--topic nav=/tf``).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from lgvtool.errors import InputError
from lgvtool.interop.named_options import parse_pairs
from lgvtool.interop.ros2_types import NAV_LANDMARK_DATA, NAV_POSE_DATA

ODOMETRY = "nav_msgs/msg/Odometry"
TWIST = "geometry_msgs/msg/TwistStamped"
IMU = "sensor_msgs/msg/Imu"
POSE_COV = "geometry_msgs/msg/PoseWithCovarianceStamped"
POSE = "geometry_msgs/msg/PoseStamped"
TF = "tf2_msgs/msg/TFMessage"

ROLES: dict[str, tuple[str, ...]] = {
    "odom": (ODOMETRY, TWIST),
    "gyro": (IMU,),
    "nav": (NAV_POSE_DATA, POSE_COV, POSE, ODOMETRY, TF),
    "reflectors": (NAV_LANDMARK_DATA,),
    "truth": (POSE, POSE_COV, ODOMETRY),
    "tf": (TF,),
}
"""Role -> the message types it reads, most preferred first."""

NAMED_ONLY: dict[str, tuple[str, ...]] = {"nav": (ODOMETRY, TF)}
"""Role -> the types it reads only from a topic that ``--topic ROLE=/name`` names: a second
odometry is rarely a localisation, and /tf is the tf role's."""

POSE_TYPES = (POSE, POSE_COV, ODOMETRY)
"""The message types whose poses can be the truth or a reference circle's."""

NONE = "none"
"""``--topic ROLE=none``: leave the role out."""

_TRUTH_NAME = re.compile(r"(^|[/_\-.])(ground_?truth|groundtruth|truth|gt|vicon|mocap|optitrack)"
                         r"($|[/_\-.])", re.IGNORECASE)


def auto_types(role: str) -> tuple[str, ...]:
    """The types ``role`` takes a topic of without ``--topic``, most preferred first."""
    return tuple(m for m in ROLES[role] if m not in NAMED_ONLY.get(role, ()))


def short(msgtype: str) -> str:
    """``pkg/msg/Name`` as ``pkg/Name``."""
    return msgtype.replace("/msg/", "/")


def parse_topic_options(items: Sequence[str]) -> dict[str, str]:
    """``ROLE=/name`` options -> ``{role: topic or 'none'}``.

    :raises InputError: no ``=``, a role that does not exist, a role given twice.
    """
    def check(role: str) -> None:
        if role not in ROLES:
            raise InputError(f"--topic: no role '{role}' (roles: {', '.join(ROLES)})")

    return parse_pairs(items, "--topic", "ROLE=/name", check)


def looks_like_truth(topic: str) -> bool:
    """Whether a topic's name says it is ground truth."""
    return bool(_TRUTH_NAME.search(topic))


def _pick(role: str, free: Mapping[str, str]) -> str | None:
    """The topic of the most preferred type among ``free`` (topic -> type) for ``role``."""
    for msgtype in ROLES[role]:
        if msgtype in NAMED_ONLY.get(role, ()):
            continue
        found = sorted(t for t, m in free.items() if m == msgtype)
        if len(found) > 1:
            raise InputError(f"several {short(msgtype)} topics could be the {role} "
                             f"({', '.join(found)}): choose one with --topic {role}=/name")
        if found:
            return found[0]
    return None


def choose_topics(types: Mapping[str, str], overrides: Mapping[str, str] | None = None
                  ) -> dict[str, list[str]]:
    """The topics of each role: ``types`` maps every bag topic to its message type.

    :raises InputError: an override naming a topic the bag lacks or of a type its role does not
        read; an ambiguous choice; no odometry; neither a NAV pose nor reflector topic.
    """
    chosen: dict[str, list[str]] = {}
    used: set[str] = set()
    for role, topic in (overrides or {}).items():
        if topic == NONE:
            chosen[role] = []
            continue
        if topic not in types:
            raise InputError(f"--topic {role}={topic}: the bag has no such topic (it has "
                             f"{', '.join(sorted(types)) or 'none'})")
        if types[topic] not in ROLES[role]:
            raise InputError(f"--topic {role}={topic}: {short(types[topic])} is not a type the "
                             f"{role} role reads ({', '.join(map(short, ROLES[role]))})")
        chosen[role] = [topic]
        used.add(topic)
    free = {t: m for t, m in types.items() if t not in used}
    if "truth" not in chosen:
        truthy = {t: m for t, m in free.items() if looks_like_truth(t) and m in ROLES["truth"]}
        pick = _pick("truth", truthy)
        chosen["truth"] = [pick] if pick else []
        used.update(chosen["truth"])
    free = {t: m for t, m in types.items() if t not in used and not looks_like_truth(t)}
    for role in ("odom", "gyro", "nav", "reflectors"):
        if role not in chosen:
            pick = _pick(role, free)
            chosen[role] = [pick] if pick else []
            free = {t: m for t, m in free.items() if t != pick}
    if "tf" not in chosen:
        chosen["tf"] = sorted(t for t, m in types.items() if m == TF)
    if not chosen["odom"]:
        raise InputError(f"no usable odometry in the bag: no {short(ODOMETRY)} or "
                         f"{short(TWIST)} topic (choose one with --topic odom=/name)")
    if not chosen["nav"] and not chosen["reflectors"]:
        raise InputError(
            f"no observation topic in the bag: no NAV pose ({', '.join(map(short, auto_types('nav')))})"
            f" or reflector ({short(NAV_LANDMARK_DATA)}) topic (choose one with --topic "
            f"nav=/name or reflectors=/name)")
    return chosen
