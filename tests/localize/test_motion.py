"""Motion input: counters, gaps, fusion, integration."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.config import Vehicle
from lgvtool.localize.motion import (
    MotionSettings,
    MotionTrack,
    clock_rate,
    increments_from_mcu,
    increments_from_twist,
    unwrap_counter,
)


def test_unwrap_counters() -> None:
    v = np.array([2**31 - 2, -2**31 + 1, -2**31 + 5], dtype=np.int64)
    assert unwrap_counter(v, 2**32, signed=True).tolist() == [3, 4]
    s = np.array([65534, 65535, 0, 3], dtype=np.int64)
    assert unwrap_counter(s, 2**16, signed=False).tolist() == [1, 1, 3]


def _frames(n: int, v: float, omega: float, veh: Vehicle):
    t = np.arange(n) * 0.1
    k_l, k_r = veh.metres_per_count()
    cl = np.round((v - omega * veh.track / 2) * t / k_l).astype(np.int64)
    cr = np.round((v + omega * veh.track / 2) * t / k_r).astype(np.int64)
    return t, np.arange(n) % 65536, np.round(t * 1000).astype(np.int64), cl, cr, \
        np.full(n, omega)


def test_mcu_distance_and_heading() -> None:
    veh = Vehicle()
    t, seq, ms, cl, cr, g = _frames(101, 0.2, 0.1, veh)
    inc = increments_from_mcu(t, seq, ms, cl, cr, g, veh, MotionSettings())
    assert abs(inc.ds.sum() - 2.0) < 1e-3
    assert abs(inc.dth.sum() - 1.0) < 1e-12
    enc = increments_from_mcu(t, seq, ms, cl, cr, g * 0.0, veh, MotionSettings("encoders"))
    assert abs(enc.dth.sum() - 1.0) < 5e-3
    blend = increments_from_mcu(t, seq, ms, cl, cr, g * 0.0, veh, MotionSettings("blend", 0.5))
    assert abs(blend.dth.sum() - 0.5 * enc.dth.sum()) < 1e-12


def test_a_run_played_faster_integrates_the_gyro_over_mcu_time() -> None:
    veh = Vehicle()
    t, seq, ms, cl, cr, g = _frames(101, 0.2, 0.1, veh)
    jitter = np.random.default_rng(0).uniform(0.0, 0.003, len(t))
    inc = increments_from_mcu(t / 4.0 + jitter, seq, ms, cl, cr, g, veh, MotionSettings())
    assert abs(inc.dth.sum() - 1.0) < 1e-12  # 10 s of MCU time at 0.1 rad/s, received in 2.5 s
    assert clock_rate(np.diff(ms) * 1e-3, np.diff(t)) == pytest.approx(1.0, abs=1e-12)
    # the MCU clock resets once: that step falls back to the (scaled) host step
    ms2 = ms.copy()
    ms2[50:] -= 4000
    inc = increments_from_mcu(t / 4.0, seq, ms2, cl, cr, g, veh, MotionSettings())
    assert abs(inc.dth.sum() - 1.0) < 1e-9


def test_long_gap_takes_heading_from_encoders() -> None:
    veh = Vehicle()
    t, seq, ms, cl, cr, g = _frames(101, 0.2, 0.1, veh)
    keep = np.r_[0:20, 60:101]
    g = g.copy()
    g[keep[19]] = g[keep[20]] = 5.0  # a gyro spike at the gap's ends must not be integrated
    inc = increments_from_mcu(t[keep], seq[keep], ms[keep], cl[keep], cr[keep], g[keep], veh,
                              MotionSettings(max_gyro_gap_s=0.5))
    assert inc.missing_frames == 40
    assert abs(inc.ds.sum() - 2.0) < 1e-3
    assert abs(inc.dth[19] - 0.1 * 4.1) < 3e-3  # 1.9 s to 6.0 s, from the encoders


def test_duplicate_frames_are_dropped() -> None:
    veh = Vehicle()
    t, seq, ms, cl, cr, g = _frames(11, 0.2, 0.0, veh)
    idx = np.r_[0:5, 4, 5:11]
    inc = increments_from_mcu(t[idx] + np.r_[np.zeros(5), 0.001, np.zeros(6)], seq[idx],
                              ms[idx], cl[idx], cr[idx], g[idx], veh, MotionSettings())
    assert len(inc.ds) == 10


def test_track_is_exact_on_a_circle() -> None:
    v, w = 0.18, 0.26
    t = np.arange(0.0, 30.0, 0.1)
    track = MotionTrack(increments_from_twist(t, np.full(len(t), v), np.full(len(t), w)))
    tq = np.array([3.05, 17.33, 29.9])
    x, y, _th, dist, rot = track.poses_at(tq)
    r = v / w
    assert np.allclose(x, r * np.sin(w * tq), atol=1e-12)
    assert np.allclose(y, r * (1 - np.cos(w * tq)), atol=1e-12)
    assert np.allclose(dist, v * tq) and np.allclose(rot, w * tq)
    d = track.deltas(np.array([3.05]), np.array([17.33]))
    a = w * (17.33 - 3.05)
    assert math.isclose(float(d.dx[0]), r * math.sin(a), abs_tol=1e-12)
    assert math.isclose(float(d.dy[0]), r * (1 - math.cos(a)), abs_tol=1e-12)


def test_paper_step_form_differs_from_arc() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    inc = increments_from_twist(t, np.full(len(t), 0.18), np.full(len(t), 0.26))
    arc, paper = MotionTrack(inc, "arc"), MotionTrack(inc, "paper")
    assert abs(arc.x[-1] - paper.x[-1]) + abs(arc.y[-1] - paper.y[-1]) > 1e-3
