"""Planar rigid-body helpers shared by the estimators (SI units: m, rad).

Poses are ``(x, y, heading)`` of the target rotation centre O in the map frame unless a name
says otherwise. Every function accepts scalars or numpy arrays and broadcasts.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.angles import wrap_angle, wrap_scalar


def nav_to_o(x_n: ArrayLike, y_n: ArrayLike, heading: ArrayLike, nav_x: float,
             nav_y: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Pose of O from the pose of the laser head (domain.md eq. 5, corrected).

    ``x_O = x_N - d_x cos th + d_y sin th``, ``y_O = y_N - d_x sin th - d_y cos th``, heading
    unchanged. (The paper prints ``POS = POS_x d cos(POS_th)``: the sign, the lateral offset and
    the subtraction are missing.) Inputs in m and rad; returns arrays in m, m, rad.
    """
    th = np.asarray(heading, dtype=np.float64)
    c, s = np.cos(th), np.sin(th)
    x = np.asarray(x_n, dtype=np.float64) - nav_x * c + nav_y * s
    y = np.asarray(y_n, dtype=np.float64) - nav_x * s - nav_y * c
    return x, y, th.copy()


def o_to_nav(x_o: ArrayLike, y_o: ArrayLike, heading: ArrayLike, nav_x: float,
             nav_y: float) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Pose of the laser head from the pose of O (inverse of :func:`nav_to_o`), m and rad."""
    th = np.asarray(heading, dtype=np.float64)
    c, s = np.cos(th), np.sin(th)
    x = np.asarray(x_o, dtype=np.float64) + nav_x * c - nav_y * s
    y = np.asarray(y_o, dtype=np.float64) + nav_x * s + nav_y * c
    return x, y, th.copy()


def compose(x: ArrayLike, y: ArrayLike, th: ArrayLike, dx: ArrayLike, dy: ArrayLike,
            dth: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                     NDArray[np.float64]]:
    """Pose ``(x, y, th)`` followed by the body-frame motion ``(dx, dy, dth)``; m, rad."""
    th = np.asarray(th, dtype=np.float64)
    c, s = np.cos(th), np.sin(th)
    dx = np.asarray(dx, dtype=np.float64)
    dy = np.asarray(dy, dtype=np.float64)
    return (np.asarray(x) + c * dx - s * dy, np.asarray(y) + s * dx + c * dy,
            wrap_angle(th + np.asarray(dth)))


def between(x0: ArrayLike, y0: ArrayLike, th0: ArrayLike, x1: ArrayLike, y1: ArrayLike,
            th1: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                     NDArray[np.float64]]:
    """Motion from pose 0 to pose 1 expressed in the body frame of pose 0; m, rad."""
    th0 = np.asarray(th0, dtype=np.float64)
    c, s = np.cos(th0), np.sin(th0)
    ex = np.asarray(x1, dtype=np.float64) - np.asarray(x0)
    ey = np.asarray(y1, dtype=np.float64) - np.asarray(y0)
    return c * ex + s * ey, -s * ex + c * ey, wrap_angle(np.asarray(th1) - th0)




def pose_from_correspondences(body_x: NDArray[np.float64], body_y: NDArray[np.float64],
                              map_x: NDArray[np.float64], map_y: NDArray[np.float64]
                              ) -> tuple[float, float, float] | None:
    """Least-squares rigid pose that maps body-frame points onto their map points (2-D Kabsch).

    Needs at least two distinct correspondences; returns ``(x, y, heading)`` of the body frame
    in the map (m, rad), or None when the points are degenerate.
    """
    if len(body_x) < 2:
        return None
    bx, by = body_x - body_x.mean(), body_y - body_y.mean()
    mx, my = map_x - map_x.mean(), map_y - map_y.mean()
    sxx = float(bx @ mx + by @ my)
    sxy = float(bx @ my - by @ mx)
    if math.hypot(sxx, sxy) < 1e-9:
        return None
    th = math.atan2(sxy, sxx)
    c, s = math.cos(th), math.sin(th)
    x = float(map_x.mean() - (c * body_x.mean() - s * body_y.mean()))
    y = float(map_y.mean() - (s * body_x.mean() + c * body_y.mean()))
    return x, y, wrap_scalar(th)
