"""Generic odometry that is the commanded velocity: the robot follows it late and smoothed,
and the calibrated odometry scales are the robot's over seconds, not those of 0.1 s intervals
(which a robot that cannot follow a step in the command makes too small)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from lgvtool.calibrate.drive import prepare
from lgvtool.calibrate.quantities import QUANTITIES
from lgvtool.calibrate.solve import Problem, SolveSettings, solve
from lgvtool.config import Reflector, Vehicle
from lgvtool.localize.logdata import LogData
from lgvtool.localize.observations import RawScan

SV, SW, LAG_S = 0.95, 0.90, 0.15


def _commanded_drive(seed: int = 5) -> LogData:
    rng = np.random.default_rng(seed)
    dt, duration = 0.02, 240.0
    t = np.arange(0.0, duration, dt)
    # a new command every 1-3 s: a step the robot follows through a first-order lag
    switches = np.cumsum(rng.uniform(1.0, 3.0, 200))
    k = np.searchsorted(switches, t)
    w_cmd = rng.uniform(-0.6, 0.6, 201)[k]
    v_cmd = rng.uniform(0.1, 0.35, 201)[k]
    a = dt / LAG_S
    w = np.zeros_like(t)
    v = np.zeros_like(t)
    for i in range(1, len(t)):
        w[i] = w[i - 1] + a * (w_cmd[i - 1] - w[i - 1])
        v[i] = v[i - 1] + a * (v_cmd[i - 1] - v[i - 1])
    th = np.concatenate([[0.0], np.cumsum(SW * w[:-1] * dt)])
    x = np.concatenate([[0.0], np.cumsum(SV * v[:-1] * np.cos(th[:-1]) * dt)])
    y = np.concatenate([[0.0], np.cumsum(SV * v[:-1] * np.sin(th[:-1]) * dt)])
    marks = [Reflector(i, 8.0 * math.cos(a_), 8.0 * math.sin(a_))
             for i, a_ in enumerate(np.linspace(0, 2 * math.pi, 12, endpoint=False))]
    lx = np.array([m.x for m in marks])
    ly = np.array([m.y for m in marks])
    scans = []
    for i in range(0, len(t), 25):  # a camera frame every 0.5 s
        dx, dy = lx - x[i], ly - y[i]
        rng_m = np.hypot(dx, dy) + rng.normal(0, 0.03, len(lx))
        bear = np.arctan2(dy, dx) - th[i] + rng.normal(0, 0.005, len(lx))
        seen = np.abs(np.remainder(bear + math.pi, 2 * math.pi) - math.pi) < 0.6
        if seen.any():
            scans.append(RawScan(float(t[i]), 0.0, rng_m[seen], bear[seen],
                                 np.zeros(int(seen.sum())), np.arange(len(lx))[seen]))
    return LogData(0, tuple(marks), twist={"t": t, "v": v_cmd, "omega": w_cmd}, scans=scans)


def _scales(data: LogData, **prep: Any) -> dict[str, float]:
    drive = prepare("cmd", data, data.reflectors, **prep)
    vehicle = Vehicle(nav_x=0.0)
    start = {n: float(getattr(vehicle, n)) for n in QUANTITIES}
    names = ["odom_scale_v", "odom_scale_w"]
    problem = Problem([drive], names, start, data.reflectors, vehicle.encoder_ppr,
                      SolveSettings(), [False])
    return dict(solve(problem, allow_unobservable=False).values)


def test_commanded_odometry_scales_are_the_robots() -> None:
    data = _commanded_drive()
    got = _scales(data)
    assert got["odom_scale_v"] == pytest.approx(SV, abs=0.02)
    assert got["odom_scale_w"] == pytest.approx(SW, abs=0.015)
    # interval by interval at 10 Hz the lag pulls the turn scale down
    fine = _scales(data, node_rate_hz=10.0)
    assert fine["odom_scale_w"] < got["odom_scale_w"] - 0.01
