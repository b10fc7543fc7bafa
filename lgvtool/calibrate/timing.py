"""The age of the NAV poses, fitted against the trajectory the reflector scans gave.

A NAV200 answers a poll with the pose of its last complete revolution, so a pose is older than
its receive time by the device's own delay (from the middle of the revolution to the reply)
plus the NAV-to-host time offset. With the trajectory of O from the least squares, the age is
the time shift that puts every reported heading (minus ``nav_yaw``) onto the trajectory's
heading: a robust one-unknown Gauss-Newton fit, its 1-sigma cluster-robust over stretches of
``cluster_s`` seconds.

The fit uses the heading, not the position: a device that fits a revolution as if it were
measured at one instant pulls its *position* off while it turns (the skew of the revolution,
a shift fixed in the vehicle frame that has a component along the path), and a time shift
would absorb that component (on a development circle it made the age 40 ms short). The
revolution's saw-tooth in bearing averages out in the fitted heading, so the heading is old
by the pose's age alone. A drive observes the age where it turns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.calibrate.drive import Drive

FloatArray = NDArray[np.float64]

RATE_STEP_S = 0.01
"""Time step of the trajectory's yaw rate (the residual's derivative), s."""


def _heading(drive: Drive, pose: FloatArray, t: FloatArray) -> FloatArray:
    """Heading of O on the trajectory at ``t`` (s), unwrapped along the nodes, rad."""
    return np.interp(t, drive.t, np.unwrap(pose[:, 2]))


@dataclass(frozen=True)
class PoseAge:
    """The fitted age of the NAV poses beyond ``nav_time_offset``."""

    age: float
    """s."""
    sigma: float
    """1-sigma, s, grown by the drives' disagreement (``inf`` when not observed)."""
    sigma_fit: float
    """1-sigma of the pooled fit alone, s: whether the drives observe the age at all."""
    used: int
    """NAV poses used."""
    per_drive: tuple[float, ...] = ()
    """Each drive's own age when there are several with poses, s."""


def fit_pose_age(drives: list[Drive], poses: list[FloatArray], values: dict[str, float],
                 start: float, *, cluster_s: float = 10.0, huber_k: float = 2.0) -> PoseAge:
    """The age of the NAV poses beyond ``nav_time_offset``. ``values``: the calibrated
    quantities (SI); ``poses``: the trajectory of O per drive (node rows x, y, heading).

    With poses in more than one drive, each drive's own age is fitted too; when they disagree
    by more than their 1-sigmas allow, the 1-sigma grows by that factor (the Birge ratio,
    ``sqrt(chi2 / (drives - 1))``): one age for all drives is then a model that misses
    something, such as the small heading error a revolution's skew leaves on a steady circle.
    """
    age, sigma, used = _fit(drives, poses, values, start, cluster_s, huber_k)
    with_poses = [d for d, drive in enumerate(drives) if len(drive.pose_t)]
    if len(with_poses) < 2 or not math.isfinite(sigma):
        return PoseAge(age, sigma, sigma, used)
    chi2 = 0.0
    own = []
    for d in with_poses:
        a, s, n = _fit([drives[d]], [poses[d]], values, age, cluster_s, huber_k)
        if not (n and math.isfinite(s) and s > 0):
            return PoseAge(age, sigma, sigma, used)
        own.append(a)
        chi2 += ((a - age) / s) ** 2
    birge = max(1.0, math.sqrt(chi2 / (len(with_poses) - 1)))
    return PoseAge(age, sigma * birge, sigma, used, tuple(own))


def _fit(drives: list[Drive], poses: list[FloatArray], values: dict[str, float], start: float,
         cluster_s: float, huber_k: float) -> tuple[float, float, int]:
    """The pooled fit of :func:`fit_pose_age` (without the agreement check)."""
    yaw, tau = values["nav_yaw"], values["nav_time_offset"]
    age = start
    used = 0
    g = e = w = np.zeros(0)
    parts: list[tuple[FloatArray, FloatArray, FloatArray, int]] = []
    for _ in range(10):
        parts = []
        for d, drive in enumerate(drives):
            if not len(drive.pose_t):
                continue
            t = drive.pose_t - tau - age
            inside = (t >= drive.t[0] + RATE_STEP_S) & (t <= drive.t[-1])
            if not inside.any():
                continue
            t = t[inside]
            th = _heading(drive, poses[d], t)
            rate = (th - _heading(drive, poses[d], t - RATE_STEP_S)) / RATE_STEP_S
            # e(age) = reported - yaw - theta(t_recv - tau - age); de/dage = +rate
            res = wrap_angle(drive.pose_heading[inside] - yaw - th)
            parts.append((rate, res, t, d))
        if not parts:
            return start, math.inf, 0
        g = np.concatenate([p[0] for p in parts])
        e = np.concatenate([p[1] for p in parts])
        scale = 1.4826 * float(np.median(np.abs(e))) or 1e-4
        a = np.abs(e) / scale
        w = np.where(a <= huber_k, 1.0, huber_k / np.maximum(a, 1e-12))
        den = float(np.sum(w * g * g))
        if not den > 0:
            return start, math.inf, 0
        step = -float(np.sum(w * g * e)) / den
        age += step
        used = len(e)
        if abs(step) < 1e-6:
            break
    blocks = np.concatenate([np.floor(p[2] / cluster_s) + 1e6 * p[3] for p in parts])
    _, inv = np.unique(blocks, return_inverse=True)
    u = np.zeros(int(inv.max()) + 1)
    np.add.at(u, inv, w * g * e)
    sigma = math.sqrt(float(np.sum(u * u))) / float(np.sum(w * g * g))
    return age, sigma, used
