"""Ground truth: the tricycle model and the scenarios' routes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.config import Vehicle
from lgvtool.log import LogReader, topics
from lgvtool.sim.kinematics import Controls, integrate


@pytest.mark.parametrize("scenario", ["paper-circle", "fast"])
def test_circle_radius_of_o_is_h_over_tan_delta(sim_cache, scenario: str) -> None:
    sim = sim_cache(scenario, **{"sim.world": "ideal"})  # the kinematic path
    ref = sim.plan.reference
    vehicle = sim.config.vehicle
    expected = vehicle.h / math.tan(math.radians(60.0))
    assert ref["radius"] == pytest.approx(expected)
    t = np.linspace(0.0, sim.duration, 20001)
    x, y, _ = sim.truth.pose_at(t)
    radius = np.hypot(x - ref["centre_x"], y - ref["centre_y"])
    assert np.max(np.abs(radius - expected)) < 1e-3


def test_logged_truth_is_on_the_circle_and_turns_eight_times(log_cache) -> None:
    reader = LogReader(log_cache("paper-circle", **{"sim.world": "ideal"}))
    ref = reader.metadata["simulator"]["reference"]
    poses = [m.data["pose"] for m in reader.messages([topics.TRUTH])]
    x = np.array([p["position"]["x"] for p in poses])
    y = np.array([p["position"]["y"] for p in poses])
    assert np.max(np.abs(np.hypot(x - ref["centre_x"], y - ref["centre_y"]) - ref["radius"])) < 1e-3
    yaw = np.unwrap([2 * math.atan2(p["orientation"]["z"], p["orientation"]["w"]) for p in poses])
    # eight rotations exactly: the ideal world plans no turn past them (scenario.overrun_deg 0)
    assert (yaw[-1] - yaw[0]) / (2 * math.pi) == pytest.approx(8.0, abs=1e-3)


def test_integration_rate_is_at_least_200_hz(sim_cache) -> None:
    sim = sim_cache("paper-circle")
    assert np.max(np.diff(sim.truth.path.t)) <= 1 / 200 + 1e-12


def test_arc_steps_are_exact_for_any_step() -> None:
    vehicle = Vehicle()
    delta = math.radians(35.0)
    for rate in (200.0, 1000.0):
        t = np.arange(0, int(10 * rate) + 1) / rate
        c = Controls(t=t, drive_speed=np.full_like(t, 0.5), steering=np.full_like(t, delta))
        tr = integrate(c, vehicle, 0.0, 0.0, 0.0)
        r = vehicle.h / math.tan(delta)
        assert np.max(np.abs(np.hypot(tr.path.x, tr.path.y - r) - r)) < 1e-9
        # O moves at v_d cos(delta), turns at v_d sin(delta) / h
        assert tr.path.heading[-1] == pytest.approx(0.5 * math.sin(delta) / vehicle.h * 10.0)


def test_warehouse_has_turns_two_stations_and_a_reverse_leg(sim_cache) -> None:
    sim = sim_cache("warehouse")
    tr = sim.truth
    assert np.any(tr.drive_speed < -0.1), "no reverse leg"
    moving = np.abs(tr.drive_speed) > 1e-6
    starts = np.nonzero(moving[1:] & ~moving[:-1])[0]
    assert len(starts) == 1 + 2 * 3, ("start, then on each lap: after the pick station, after "
                                      "reversing and after the drop station")
    turned = (tr.path.heading[-1] - tr.path.heading[0]) / (math.pi / 2)
    assert turned == pytest.approx(8.0, abs=1e-3)  # two laps of four left 90-degree turns
    assert math.hypot(tr.path.x[-1] - tr.path.x[0], tr.path.y[-1] - tr.path.y[0]) < 0.01  # the route closes
    area = sim.config.area
    assert area.x_min + 1 < tr.path.x.min() and tr.path.x.max() < area.x_max - 1
    assert area.y_min + 1 < tr.path.y.min() and tr.path.y.max() < area.y_max - 1


def test_duration_drives_circles_until_the_end(sim_cache) -> None:
    sim = sim_cache("paper-circle", duration=400.0)
    assert sim.duration == pytest.approx(400.0)
    assert (sim.truth.path.heading[-1] - sim.truth.path.heading[0]) / (2 * math.pi) > 15
