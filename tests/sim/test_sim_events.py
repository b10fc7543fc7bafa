"""The device-side event stream that emulators play, and the settings it is built from."""

from __future__ import annotations

import math

import pytest

from lgvtool.errors import ConfigError, InputError
from lgvtool.sim.event_stream import McuSend, NavScan, NavSolution, TruthSample
from lgvtool.sim.settings import SimSettings, apply_overrides
from lgvtool.sim.simulation import simulate


def test_stream_is_time_ordered_and_complete(sim_cache) -> None:
    sim = sim_cache("paper-circle")
    events = list(sim.events())
    times = [e.t for e in events]
    assert times == sorted(times)
    kinds = {type(e) for e in events}
    assert kinds == {TruthSample, McuSend, NavScan, NavSolution}
    assert sum(isinstance(e, McuSend) for e in events) == len(sim.mcu)
    assert sum(isinstance(e, NavScan) for e in events) == len(sim.scans)
    sends = [e for e in events if isinstance(e, McuSend)]
    assert all(e.delivered == e.data for e in sends)
    scan = next(e for e in events if isinstance(e, NavScan) and e.start > 20)
    assert scan.t == pytest.approx(scan.start + scan.period)
    assert all(o.id > 0 for o in scan.observations)


def test_settings_overrides_are_checked() -> None:
    s = apply_overrides(SimSettings(), {"nav.skew": False, "nav.latency_s": 0,
                                        "faults.false_x": "nan"})
    assert s.nav.skew is False and s.nav.latency_s == 0.0 and math.isnan(s.faults.false_x)
    with pytest.raises(ConfigError, match=r"unknown setting 'nav\.nope'"):
        apply_overrides(SimSettings(), {"nav.nope": 1})
    with pytest.raises(ConfigError, match="unknown setting section"):
        apply_overrides(SimSettings(), {"bogus.x": 1})
    with pytest.raises(ConfigError, match="must be at most 1"):
        apply_overrides(SimSettings(), {"faults.mcu_drop_rate": 2.0})
    with pytest.raises(ConfigError):
        simulate("paper-circle", overrides={"scenario.nope": 1.0})
    with pytest.raises(InputError, match="unknown scenario"):
        simulate("nope")


def test_vehicle_overrides_reach_the_configuration(sim_cache) -> None:
    sim = sim_cache("paper-circle", **{"vehicle.nav_x": 0.5, "vehicle.h": 1.0})
    assert sim.config.vehicle.nav_x == 0.5
    assert sim.plan.reference["radius"] == pytest.approx(1.0 / math.tan(math.radians(60)))
    assert sim.config.simulator["nav"]["skew"] is True
