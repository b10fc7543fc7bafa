"""Topic names of the log contract and the schema each one carries (docs/log-format.md)."""

from __future__ import annotations

MCU_RX = "/mcu/rx"
"""Raw bytes received from the MCU (lgvtool.RawBytes)."""
MCU_TX = "/mcu/tx"
"""Raw bytes sent to the MCU (lgvtool.RawBytes)."""
NAV_RX = "/nav200/rx"
"""Raw bytes received from the NAV200 (lgvtool.RawBytes)."""
NAV_TX = "/nav200/tx"
"""Raw bytes sent to the NAV200 (lgvtool.RawBytes)."""
NAV350_RX = "/nav350/rx"
"""Raw bytes received from the NAV350 (lgvtool.RawBytes)."""
NAV350_TX = "/nav350/tx"
"""Raw bytes sent to the NAV350 (lgvtool.RawBytes)."""
MCU_FRAME = "/mcu/frame"
"""Decoded MCU frames (lgvtool.McuFrame)."""
ODOM = "/odom/twist"
"""Generic odometry v, omega (lgvtool.Odometry)."""
NAV_POSE = "/nav/pose"
"""The NAV's reported pose of its head (lgvtool.NavPose)."""
NAV_REFLECTORS = "/nav/reflectors"
"""Per-scan reflector observations (lgvtool.ReflectorScan)."""
MAP = "/map/reflectors"
"""The reflector layout in use (lgvtool.ReflectorMap)."""
MAP_SCENE = "/map/scene"
"""The reflector layout for viewing (foxglove.SceneUpdate)."""
TRUTH = "/truth/pose"
"""Ground truth pose of the point O (foxglove.PoseInFrame)."""
DIAGNOSTICS = "/diagnostics"
"""Structured events (lgvtool.Diagnostic)."""
DIAGNOSTICS_LOG = "/diagnostics/log"
"""The same events for viewing (foxglove.Log)."""
NAV_HEAD = "/nav/head"
"""The NAV's reported head pose for viewing (foxglove.PoseInFrame, valid poses only)."""
NAV_TF = "/nav/tf"
"""Frames map -> nav/O -> nav/head from the NAV's reported pose (foxglove.FrameTransforms)."""
NAV_SCAN = "/nav/scan"
"""Each reflector scan as points in the frame nav/head (foxglove.PointCloud)."""
TRUTH_TF = "/truth/tf"
"""Frames map -> truth/O -> truth/head from the ground truth (foxglove.FrameTransforms)."""
REFERENCE = "/reference/circle"
"""The reference circle of a circle drive (foxglove.SceneUpdate)."""

ESTIMATE_PREFIX = "/estimate/"

FIXED: dict[str, str] = {
    MCU_RX: "lgvtool.RawBytes",
    MCU_TX: "lgvtool.RawBytes",
    NAV_RX: "lgvtool.RawBytes",
    NAV_TX: "lgvtool.RawBytes",
    NAV350_RX: "lgvtool.RawBytes",
    NAV350_TX: "lgvtool.RawBytes",
    MCU_FRAME: "lgvtool.McuFrame",
    ODOM: "lgvtool.Odometry",
    NAV_POSE: "lgvtool.NavPose",
    NAV_REFLECTORS: "lgvtool.ReflectorScan",
    MAP: "lgvtool.ReflectorMap",
    MAP_SCENE: "foxglove.SceneUpdate",
    TRUTH: "foxglove.PoseInFrame",
    DIAGNOSTICS: "lgvtool.Diagnostic",
    DIAGNOSTICS_LOG: "foxglove.Log",
    NAV_HEAD: "foxglove.PoseInFrame",
    NAV_TF: "foxglove.FrameTransforms",
    NAV_SCAN: "foxglove.PointCloud",
    TRUTH_TF: "foxglove.FrameTransforms",
    REFERENCE: "foxglove.SceneUpdate",
}
"""Topic -> schema name for every fixed topic."""

ESTIMATE_SUFFIXES: dict[str, str] = {
    "pose": "foxglove.PoseInFrame",
    "state": "lgvtool.PoseEstimate",
    "particles": "foxglove.PosesInFrame",
    "tf": "foxglove.FrameTransforms",
    "covariance": "foxglove.SceneUpdate",
}
"""``/estimate/<name>/<suffix>`` -> schema name."""

RAW_TOPICS = (MCU_RX, MCU_TX, NAV_RX, NAV_TX, NAV350_RX, NAV350_TX)


def raw_topic(device: str, direction: str) -> str:
    """The raw-bytes topic of ``device`` ('mcu', 'nav200', 'nav350') in ``direction`` ('rx', 'tx')."""
    if direction not in ("rx", "tx"):
        raise ValueError(f"direction must be 'rx' or 'tx', not {direction!r}")
    return f"/{device}/{direction}"


def estimate_pose(name: str) -> str:
    """Topic of estimator ``name``'s pose of O (foxglove.PoseInFrame)."""
    return f"{ESTIMATE_PREFIX}{name}/pose"


def estimate_state(name: str) -> str:
    """Topic of estimator ``name``'s pose with covariance (lgvtool.PoseEstimate)."""
    return f"{ESTIMATE_PREFIX}{name}/state"


def estimate_particles(name: str) -> str:
    """Topic of estimator ``name``'s decimated particle cloud (foxglove.PosesInFrame)."""
    return f"{ESTIMATE_PREFIX}{name}/particles"


def estimate_tf(name: str) -> str:
    """Topic of estimator ``name``'s frames map -> NAME/O -> NAME/head
    (foxglove.FrameTransforms)."""
    return f"{ESTIMATE_PREFIX}{name}/tf"


def estimate_covariance(name: str) -> str:
    """Topic of estimator ``name``'s position covariance ellipse (foxglove.SceneUpdate)."""
    return f"{ESTIMATE_PREFIX}{name}/covariance"


VIEW_TOPICS = (NAV_HEAD, NAV_TF, NAV_SCAN, TRUTH_TF, REFERENCE)
"""Topics that ``replay`` derives from a log's own data for Foxglove (replaced when the input
already has them)."""


def estimator_names(topic_names: list[str] | set[str] | tuple[str, ...]) -> list[str]:
    """Names of the estimators that have a pose topic among ``topic_names``, sorted."""
    out = []
    for t in topic_names:
        if t.startswith(ESTIMATE_PREFIX) and t.endswith("/pose"):
            out.append(t[len(ESTIMATE_PREFIX) : -len("/pose")])
    return sorted(out)


def schema_for_topic(topic: str) -> str | None:
    """The schema name a topic carries in the log contract, or None for an unknown topic."""
    if topic in FIXED:
        return FIXED[topic]
    if topic.startswith(ESTIMATE_PREFIX):
        rest = topic[len(ESTIMATE_PREFIX) :]
        name, _, suffix = rest.rpartition("/")
        if name and suffix in ESTIMATE_SUFFIXES:
            return ESTIMATE_SUFFIXES[suffix]
    if topic.startswith("/") and topic.endswith(("/rx", "/tx")) and topic.count("/") == 2:
        return "lgvtool.RawBytes"
    return None
