"""The age of the NAV poses, fitted against the trajectory the reflector scans gave.

A NAV200 answers a poll with the pose of its last complete revolution, so a pose is older than
its receive time by the device's own delay (from the middle of the revolution to the reply)
plus the NAV-to-host time offset. With the trajectory of O from the least squares, the age is
the time shift that puts every reported head pose onto the trajectory's head: a robust
one-unknown Gauss-Newton fit of the positions, its 1-sigma cluster-robust over stretches of
``cluster_s`` seconds.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from lgvtool.calibrate.drive import Drive

FloatArray = NDArray[np.float64]


def _head(drive: Drive, pose: FloatArray, t: FloatArray, mx: float, my: float
          ) -> tuple[FloatArray, FloatArray]:
    x = np.interp(t, drive.t, pose[:, 0])
    y = np.interp(t, drive.t, pose[:, 1])
    th = np.interp(t, drive.t, pose[:, 2])
    c, s = np.cos(th), np.sin(th)
    return x + c * mx - s * my, y + s * mx + c * my


def fit_pose_age(drives: list[Drive], poses: list[FloatArray], values: dict[str, float],
                 start: float, *, cluster_s: float = 10.0, huber_k: float = 2.0
                 ) -> tuple[float, float, int]:
    """Age of the NAV poses beyond ``nav_time_offset`` (s), its 1-sigma (s) and the number of
    poses used. ``values``: the calibrated quantities (SI)."""
    mx, my, tau = values["nav_x"], values["nav_y"], values["nav_time_offset"]
    age = start
    used = 0
    for _ in range(10):
        num = den = 0.0
        parts: list[tuple[FloatArray, FloatArray, FloatArray, int]] = []
        for d, drive in enumerate(drives):
            if not len(drive.pose_t):
                continue
            t = drive.pose_t - tau - age
            inside = (t >= drive.t[0]) & (t <= drive.t[-1])
            if not inside.any():
                continue
            t = t[inside]
            hx, hy = _head(drive, poses[d], t, mx, my)
            ax, ay = _head(drive, poses[d], t - 0.01, mx, my)
            vx, vy = (hx - ax) / 0.01, (hy - ay) / 0.01
            ex, ey = hx - drive.pose_x[inside], hy - drive.pose_y[inside]
            # e(age + da) = e - v da
            g = np.concatenate([-vx, -vy])
            e = np.concatenate([ex, ey])
            parts.append((g, e, np.concatenate([t, t]), d))
        if not parts:
            return start, math.inf, 0
        g = np.concatenate([p[0] for p in parts])
        e = np.concatenate([p[1] for p in parts])
        scale = 1.4826 * float(np.median(np.abs(e))) or 1e-3
        a = np.abs(e) / scale
        w = np.where(a <= huber_k, 1.0, huber_k / np.maximum(a, 1e-12))
        num = float(np.sum(w * g * e))
        den = float(np.sum(w * g * g))
        if den <= 0:
            return start, math.inf, 0
        step = -num / den
        age += step
        used = len(e) // 2
        if abs(step) < 1e-6:
            break
    blocks = np.concatenate([np.floor(p[2] / cluster_s) + 1e6 * p[3] for p in parts])
    _, inv = np.unique(blocks, return_inverse=True)
    u = np.zeros(inv.max() + 1)
    np.add.at(u, inv, w * g * e)
    sigma = math.sqrt(float(np.sum(u * u))) / den
    return age, sigma, used
