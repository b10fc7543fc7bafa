"""ROS 2 message types for ``lgvtool import ros2``: the standard ones that rosbags carries, and
the NAV350 messages of SICK's driver sick_scan_xd, registered from their ``.msg`` text.

The standard definitions (``nav_msgs``, ``geometry_msgs``, ``sensor_msgs``, ``tf2_msgs``) are
those of ROS 2 Humble; their CDR layout is the same in every ROS 2 release since. A bag that
carries the definition of a type the store lacks (MCAP bags do) has it registered from the bag.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

from lgvtool.errors import InputError
from lgvtool.extras import require

if TYPE_CHECKING:
    from rosbags.interfaces import Connection
    from rosbags.interfaces.typing import Typesdict
    from rosbags.typesys.store import Typestore

SICK_PACKAGE = "sick_scan_xd"

NAV_POSE_DATA = f"{SICK_PACKAGE}/msg/NAVPoseData"
NAV_LANDMARK_DATA = f"{SICK_PACKAGE}/msg/NAVLandmarkData"
NAV_REFLECTOR_DATA = f"{SICK_PACKAGE}/msg/NAVReflectorData"

SICK_MSGS: dict[str, str] = {
    NAV_POSE_DATA: """\
std_msgs/Header header
int32 x
int32 y
uint32 phi
uint16 opt_pose_data_valid
uint8 output_mode
uint32 timestamp
int32 mean_dev
uint8 nav_mode
uint32 info_state
uint8 quant_used_reflectors
int8 pose_valid
float32 pose_x
float32 pose_y
float32 pose_yaw
""",
    NAV_REFLECTOR_DATA: """\
uint16 cartesian_data_valid
int32 x
int32 y
uint16 polar_data_valid
uint32 dist
uint32 phi
uint16 opt_reflector_data_valid
uint16 local_id
uint16 global_id
uint8 type
uint16 sub_type
uint16 quality
uint32 timestamp
uint16 size
uint16 hit_count
uint16 mean_echo
uint16 start_index
uint16 end_index
int8 pos_valid
float32 pos_x
float32 pos_y
""",
    NAV_LANDMARK_DATA: """\
std_msgs/Header header
uint8 landmark_filter
uint16 num_reflectors
sick_scan_xd/NAVReflectorData[] reflectors
""",
}
"""sick_scan_xd's NAV350 messages (msg/NAVPoseData.msg, NAVReflectorData.msg,
NAVLandmarkData.msg), as the driver defines them."""


def require_rosbags() -> None:
    """Raise a one-line :class:`InputError` naming the extra when rosbags is missing."""
    require("import ros2", "ros2", "rosbags")


def typestore(connections: Iterable[Connection] = ()) -> Typestore:
    """The ROS 2 Humble types, then the ``.msg`` definitions that the bag's ``connections``
    carry for types the store lacks (a bag's own definition of a sick_scan_xd message wins),
    then sick_scan_xd's NAV350 messages as :data:`SICK_MSGS` defines them.

    :raises InputError: a definition in the bag that cannot be read.
    """
    require_rosbags()
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    from rosbags.typesys.base import TypesysError

    store = get_typestore(Stores.ROS2_HUMBLE)
    for conn in connections:
        if conn.msgtype in store.types or conn.msgdef.format != MessageDefinitionFormat.MSG:
            continue
        try:
            store.register(get_types_from_msg(conn.msgdef.data, conn.msgtype))
        except (TypesysError, ValueError, KeyError) as exc:
            raise InputError(f"topic {conn.topic}: the bag's definition of {conn.msgtype} "
                             f"cannot be read ({exc})") from None
    types: Typesdict = {}
    for name, text in SICK_MSGS.items():
        if name not in store.types:
            types.update((k, v) for k, v in get_types_from_msg(text, name).items()
                         if k not in store.types)
    store.register(types)
    return store
