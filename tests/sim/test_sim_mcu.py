"""The MCU model: encoders, gyro, drive unit and clock, checked through the decoded frames."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.wire.units import counter_delta

EXACT = {"sim.noise": False, "sim.world": "ideal", "mcu.wheel_radius_error_left": 0.0,
         "mcu.wheel_radius_error_right": 0.0, "mcu.gyro_scale_error": 0.0,
         "mcu.gyro_bias_dps": 0.0}
"""No noise, no calibration error, and the kinematic path with no load (``sim.world``)."""


def _decoded(sim):
    decoder = McuStreamDecoder()
    frames = []
    for chunk in sim.mcu_traffic.rx:
        frames.extend(decoder.feed(chunk.data))
    return frames


def _travel(frames, vehicle):
    per_l, per_r = vehicle.metres_per_count()
    left = np.cumsum([0] + [counter_delta(a.enc_left, b.enc_left)
                            for a, b in itertools.pairwise(frames)]) * per_l
    right = np.cumsum([0] + [counter_delta(a.enc_right, b.enc_right)
                             for a, b in itertools.pairwise(frames)]) * per_r
    return left, right


@pytest.mark.parametrize("scenario", ["paper-circle", "warehouse"])
def test_encoder_counts_agree_with_wheel_travel(sim_cache, scenario: str) -> None:
    sim = sim_cache(scenario, **EXACT)
    frames = _decoded(sim)
    assert len(frames) == len(sim.mcu)
    left, right = _travel(frames, sim.config.vehicle)
    true_l = sim.mcu.travel_left - sim.mcu.travel_left[0]
    true_r = sim.mcu.travel_right - sim.mcu.travel_right[0]
    per_l, per_r = sim.config.vehicle.metres_per_count()
    assert np.max(np.abs(left - true_l)) <= 1.0 * per_l + 1e-9
    assert np.max(np.abs(right - true_r)) <= 1.0 * per_r + 1e-9
    # each wheel at +-track/2 from O: the difference of travel is track x heading change
    dth = sim.truth.pose_at(sim.mcu.t)[2] - sim.truth.pose_at(sim.mcu.t[:1])[2]
    track = sim.config.vehicle.track
    assert np.max(np.abs((true_r - true_l) - track * dth)) < 1e-6


def test_wheel_radius_error_scales_the_counts(sim_cache) -> None:
    sim = sim_cache("paper-circle", **{**EXACT, "mcu.wheel_radius_error_left": 0.01})
    frames = _decoded(sim)
    left, _ = _travel(frames, sim.config.vehicle)
    true_l = sim.mcu.travel_left[-1] - sim.mcu.travel_left[0]
    assert left[-1] / true_l == pytest.approx(1 / 1.01, rel=1e-3)


def test_slip_noise_stays_small(sim_cache) -> None:
    sim = sim_cache("paper-circle", **{"mcu.wheel_radius_error_left": 0.0,
                                       "mcu.wheel_radius_error_right": 0.0,
                                       "drive.load_fraction": 0.0})
    left, _ = _travel(_decoded(sim), sim.config.vehicle)
    true_l = sim.mcu.travel_left - sim.mcu.travel_left[0]
    err = np.abs(left - true_l)
    assert 0 < np.max(err) < 0.05  # mm-level random walk over ~35 m


def test_gyro_steering_speed_and_clock(sim_cache) -> None:
    sim = sim_cache("paper-circle", **EXACT)
    frames = _decoded(sim)
    omega = np.array([f.gyro_rate for f in frames])
    v = sim.config.vehicle
    cruise = 0.36 * math.sin(math.radians(60)) / v.h
    moving = slice(len(frames) // 4, 3 * len(frames) // 4)
    step = math.radians(frames[0].gyro_scale_deg_s)
    assert np.max(np.abs(omega[moving] - cruise)) <= step
    assert frames[0].gyro_scale_deg_s == pytest.approx(360 / 32768, rel=1e-3)
    steer = np.array([f.steering_angle for f in frames])
    assert np.max(np.abs(steer - math.radians(60))) <= math.radians(0.005) + 1e-12
    speed = np.array([f.drive_speed for f in frames])
    assert np.max(np.abs(speed[moving] - 0.36)) <= 0.0005 + 1e-12
    seq = np.array([f.seq for f in frames])
    assert np.all(np.diff(seq) == 1)
    ms = np.array([f.mcu_time_ms for f in frames], dtype=np.int64)
    assert np.all(np.abs(np.diff(ms) - 100) <= 1)


def test_gyro_noise_and_bias_are_there_by_default(sim_cache) -> None:
    sim = sim_cache("paper-circle")
    frames = _decoded(sim)
    still = np.array([f.gyro_rate for f in frames[:40]])  # 5 s standstill
    assert abs(math.degrees(np.mean(still)) - 0.05) < 0.03
    assert np.std(still) > 0


def test_host_reads_deliver_frames_in_order_and_in_chunks(sim_cache) -> None:
    sim = sim_cache("paper-circle")
    times = np.array([c.t for c in sim.mcu_traffic.rx])
    assert np.all(np.diff(times) >= 0)
    assert len(sim.mcu_traffic.rx) > len(sim.mcu)  # some frames arrive in two reads
    assert b"".join(c.data for c in sim.mcu_traffic.rx) == b"".join(sim.mcu.data)
