"""The NAV pose age fit: the age is taken from the reported heading, so that a position error
fixed in the vehicle frame (the revolution's skew while turning) does not move it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.calibrate.drive import Drive
from lgvtool.calibrate.timing import fit_pose_age

AGE, TAU, YAW = 0.18, 0.03, math.radians(0.5)
MX, MY = 1.0, 0.0


def _circle(t: np.ndarray, rate: float = 0.26, speed: float = 0.5) -> np.ndarray:
    th = rate * t
    r = speed / rate
    return np.column_stack([r * np.sin(th), r * (1 - np.cos(th)), th])


def _drive(bias_along: float, bias_lat: float, seed: int = 3) -> tuple[Drive, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 120.0, 0.1)
    pose = _circle(t)
    drive = Drive("synthetic", "mcu", t)
    recv = np.arange(2.0, 118.0, 0.45)
    # each pose reports a revolution of its own age: the poll is not synchronised with it
    happened = recv - TAU - AGE + rng.uniform(-0.06, 0.06, len(recv))
    p = _circle(happened)
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    hx = p[:, 0] + c * (MX + bias_along) - s * (MY + bias_lat)
    hy = p[:, 1] + s * (MX + bias_along) + c * (MY + bias_lat)
    drive.pose_t = recv
    drive.pose_x, drive.pose_y = hx, hy
    drive.pose_heading = np.remainder(p[:, 2] + YAW + rng.normal(0, 0.003, len(recv)) + math.pi,
                                      2 * math.pi) - math.pi
    return drive, pose


VALUES = {"nav_x": MX, "nav_y": MY, "nav_yaw": YAW, "nav_time_offset": TAU}


def test_age_recovered_without_bias() -> None:
    drive, pose = _drive(0.0, 0.0)
    fit = fit_pose_age([drive], [pose], VALUES, 0.1)
    assert fit.used == len(drive.pose_t)
    assert fit.age == pytest.approx(AGE, abs=max(3 * fit.sigma, 0.005))
    assert 0 < fit.sigma < 0.01
    assert fit.sigma == fit.sigma_fit and fit.per_drive == ()


def test_position_bias_of_the_skew_does_not_move_the_age() -> None:
    # 20 mm behind and 55 mm inside, fixed in the vehicle frame: on this circle a time shift of
    # the position alone would take 0.02 / 0.63 m/s = 32 ms off the age
    drive, pose = _drive(-0.02, 0.055)
    fit = fit_pose_age([drive], [pose], VALUES, 0.1)
    assert fit.age == pytest.approx(AGE, abs=max(3 * fit.sigma, 0.005))


def test_mounting_yaw_is_taken_off_the_heading() -> None:
    drive, pose = _drive(0.0, 0.0)
    wrong = dict(VALUES, nav_yaw=0.0)
    fit = fit_pose_age([drive], [pose], wrong, 0.1)
    # 0.5 deg at 0.26 rad/s is 34 ms: a fit that forgot the yaw would be that far off
    assert abs(fit.age - AGE) > 0.02


def test_no_turning_gives_no_age() -> None:
    drive, pose = _drive(0.0, 0.0)
    pose = pose.copy()
    pose[:, 2] = 0.0
    drive.pose_heading = np.full(len(drive.pose_t), YAW)
    fit = fit_pose_age([drive], [pose], VALUES, 0.1)
    assert not math.isfinite(fit.sigma_fit) or fit.sigma_fit > 0.02


def test_drives_that_disagree_widen_the_uncertainty() -> None:
    a, pa = _drive(0.0, 0.0, seed=3)
    b, pb = _drive(0.0, 0.0, seed=4)
    alone = fit_pose_age([a, b], [pa, pb], VALUES, 0.1)
    # the second drive's poses 15 ms older: one age cannot fit both within their sigmas
    b.pose_t = b.pose_t + 0.015
    fit = fit_pose_age([a, b], [pa, pb], VALUES, 0.1)
    assert AGE < fit.age < AGE + 0.015
    assert fit.sigma > 3 * alone.sigma
    assert fit.sigma > 0.004
    # the pooled fit alone is as sharp as before: the drives do observe the age
    assert fit.sigma_fit == pytest.approx(alone.sigma_fit, rel=0.5)
    assert len(fit.per_drive) == 2 and fit.per_drive[1] - fit.per_drive[0] > 0.01
