"""The view's reflector scans: observations carried from the instant each was measured to the
head frame at the scan's start, as Foxglove's 3D panel would carry them between transforms."""

from __future__ import annotations

import math
from itertools import pairwise

import numpy as np
import pytest

from lgvtool.log import foxglove as fx
from lgvtool.log.view_channels import Carrier, carry_to_start, head_track

T0 = 1_704_067_200_000_000_000


def _observed(track_pose: tuple[float, float, float], wx: float, wy: float
              ) -> tuple[float, float]:
    """A world point (m) in the frame of a head at (x, y m, heading rad)."""
    x, y, h = track_pose
    c, s = math.cos(h), math.sin(h)
    return c * (wx - x) + s * (wy - y), -s * (wx - x) + c * (wy - y)


def test_a_turning_and_moving_head_sees_a_fixed_reflector_where_it_was_at_the_scan_start(
        ) -> None:
    # a head driving 1.5 m/s along x while turning at 2 rad/s, poses every 50 ms
    t = T0 + 50_000_000 * np.arange(21)
    dt = (t - T0) * 1e-9
    track = head_track(t, 1.5 * dt, 0.0 * dt, 0.3 + 2.0 * dt, fx.Mounting(0.0, 0.0))
    wx, wy = 12.0, 5.0
    start = T0 + 200_000_000
    obs = start + np.array([0, 30_000_000, 110_000_000, 125_000_000])
    seen = [_observed((1.5 * (k - T0) * 1e-9, 0.0, 0.3 + 2.0 * (k - T0) * 1e-9), wx, wy)
            for k in obs.tolist()]
    px, py = (np.array(v) for v in zip(*seen, strict=True))
    qx, qy = carry_to_start(np.full(4, start), obs, px, py, track)
    want = _observed((1.5 * 0.2, 0.0, 0.3 + 2.0 * 0.2), wx, wy)
    assert qx == pytest.approx([want[0]] * 4, abs=1e-9)
    assert qy == pytest.approx([want[1]] * 4, abs=1e-9)
    # uncarried, the last observation is off by the head's turn times the range, metres
    assert math.hypot(px[-1] - want[0], py[-1] - want[1]) > 2.0


def test_heading_is_interpolated_across_the_wrap() -> None:
    t = np.array([T0, T0 + 100_000_000])
    track = head_track(t, np.zeros(2), np.zeros(2), [math.pi - 0.05, -math.pi + 0.05],
                       fx.Mounting(0.0, 0.0))
    # half way, the head has turned 0.05 rad: a point straight ahead at 10 m then
    qx, qy = carry_to_start([T0], [T0 + 50_000_000], [10.0], [0.0], track)
    assert (qx[0], qy[0]) == pytest.approx((10 * math.cos(0.05), 10 * math.sin(0.05)), abs=1e-9)


def test_a_prepared_carrier_gives_each_window_what_the_whole_log_gives() -> None:
    # a head circling several times (its heading wraps), scans carried in windows of any cut:
    # the view computes each window's points alone, the unwrapped track shared
    rng = np.random.default_rng(3)
    t = T0 + 50_000_000 * np.arange(400)
    dt = (t - T0) * 1e-9
    track = head_track(t, 4.0 * np.cos(dt), 4.0 * np.sin(dt), np.pi / 2 + 1.3 * dt,
                       fx.Mounting(0.2, -0.1, 0.05))
    start = np.sort(rng.integers(int(t[0]), int(t[-1]), 300))
    obs = start + rng.integers(0, 120_000_000, 300)
    px, py = rng.uniform(-20, 20, 300), rng.uniform(-20, 20, 300)
    whole = carry_to_start(start, obs, px, py, track)
    carry = Carrier(track)
    for cut in ([0, 300], [0, 1, 150, 299, 300], [*range(0, 301, 7), 300]):
        parts = [carry(start[a:b], obs[a:b], px[a:b], py[a:b]) for a, b in pairwise(cut)]
        for k in (0, 1):
            got = np.concatenate([p[k] for p in parts])
            assert got == pytest.approx(whole[k], abs=1e-12)


def test_without_a_track_points_stay_as_measured() -> None:
    empty = head_track([], [], [], [], fx.Mounting(0.0, 0.0))
    qx, qy = carry_to_start([T0], [T0 + 1], [3.0], [4.0], empty)
    assert (qx.tolist(), qy.tolist()) == ([3.0], [4.0])


def test_head_track_puts_the_head_at_the_mounting_and_drops_unfinite_rows() -> None:
    t, x, y, h = head_track([T0 + 2, T0, T0 + 1], [1.0, 0.0, math.nan], [0.0, 0.0, 0.0],
                            [math.pi / 2, 0.0, 0.0], fx.Mounting(1.0, 0.5, 0.1))
    assert t.tolist() == [T0, T0 + 2]
    assert x == pytest.approx([1.0, 0.5]) and y == pytest.approx([0.5, 1.0])
    assert h == pytest.approx([0.1, math.pi / 2 + 0.1])
