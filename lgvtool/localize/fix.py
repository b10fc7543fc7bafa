"""A first pose from one observation, to start the Gaussian estimators."""

from __future__ import annotations

from lgvtool.localize.geometry import nav_to_o, pose_from_correspondences
from lgvtool.localize.observations import PoseObservation, ReflectorMap, ScanObservation


def pose_fix(obs: PoseObservation | ScanObservation, nav_x: float, nav_y: float,
             rmap: ReflectorMap, *, use_ids: bool = True
             ) -> tuple[float, float, float] | None:
    """Pose of O (m, m, rad) from a NAV pose (eq. 5), or from a scan with at least two
    reflectors of known id (least-squares alignment of the measured points on the map); None
    when the observation does not fix the pose."""
    if isinstance(obs, PoseObservation):
        x, y, th = nav_to_o(obs.x, obs.y, obs.heading, nav_x, nav_y)
        return float(x), float(y), float(th)
    if not use_ids or len(obs) < 2 or len(rmap) == 0:
        return None
    j = obs.map_index(rmap)
    ok = j >= 0
    if ok.sum() < 2:
        return None
    return pose_from_correspondences(obs.qx[ok], obs.qy[ok], rmap.x[j[ok]], rmap.y[j[ok]])
