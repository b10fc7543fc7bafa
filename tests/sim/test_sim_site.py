"""The honest site: the true reflectors and floor differ from the stored layout, the NAV
identifies reflectors itself, and only what a device delivers reaches the log.

- no estimator input carries a simulator-only id: every observation the replay reads holds the
  id the simulated device gave it (the stored-layout id it matched, or none);
- a NAV200 log holds reflector observations only as the paper's setup, and says so;
- each site mechanism does what docs/simulator.md says (survey error, range bias, tilt);
- the device's identification from its own prediction is the sequential device's;
- a site setting out of its physical range is one line and exit 2.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from lgvtool.config import Area, Reflector
from lgvtool.localize.logdata import load_log
from lgvtool.log import LogReader, topics
from lgvtool.sim import nav_model
from lgvtool.sim.event_stream import NavScan
from lgvtool.sim.settings import FaultSettings, SiteSettings
from lgvtool.sim.simulation import Simulation
from lgvtool.sim.site_model import FALSE_ID, build_site
from tests.inprocess import run_command

NO_ID = -1
"""What /nav/reflectors writes for an observation without an id (schemas/lgvtool.ReflectorScan)."""

KIND = {"sim.noise": False, "site.survey_sigma_mm": 0.0, "nav.angle_step_deg": 0.0,
        "nav.skew": False, "site.range_bias_sigma_mm": 0.0, "site.floor_tilt_deg": 0.0}
"""No noise, an exact layout, centres measured at mid-revolution, no bias, a level floor: each
test below switches on the one mechanism it checks."""


def _device_ids(sim: Simulation) -> np.ndarray:
    """What the device reports for each (revolution, landmark) of the run, from its matches:
    the stored-layout id of the reflector it matched, else none."""
    matched = sim.scans.matched
    return np.where(matched >= 0, sim.landmarks.ids[np.maximum(matched, 0)], NO_ID)


def _logged_against_the_device(sim: Simulation, path: Any) -> tuple[int, list[int]]:
    """Read the log as the replay does and compare each scan's observations with the
    revolution of the simulation it came from; returns (observations, their ids)."""
    data = load_log(LogReader(path))
    assert data.has_scans
    sc = sim.scans
    expected = _device_ids(sim)
    offset = (data.t0_ns - sim.start_ns) / 1e9
    count, ids = 0, []
    for scan in data.scans:
        # the revolution it came from: the last to start before it (a NAV350 scan starts at
        # its first landmark's tick, on the clock the host estimates), the one with its ranges
        k0 = int(np.searchsorted(sc.start, scan.t + offset, side="right")) - 1
        found = []
        for k in (k0 - 1, k0, k0 + 1):
            if not 0 <= k < len(sc):
                continue
            seen = np.nonzero(sc.seen[k])[0]
            seen = seen[np.argsort(sc.time_in_scan[k, seen], kind="stable")]
            if len(seen) == len(scan.ranges) and np.allclose(scan.ranges, sc.range[k, seen],
                                                             rtol=0.0, atol=0.0006):
                found.append((k, seen))  # whole mm on the wire
        assert len(found) == 1, (scan.t, k0)
        k, seen = found[0]
        assert scan.ids.tolist() == expected[k, seen].tolist()
        count += len(seen)
        ids += scan.ids.tolist()
    return count, ids


@pytest.mark.parametrize("mode", [{"sim.nav_device": "nav350"}, {"sim.paper_scans": True}],
                         ids=["nav350", "paper-scans"])
@pytest.mark.parametrize("scenario", ["degraded", "warehouse"])
def test_no_estimator_input_carries_a_simulator_only_id(sim_cache, log_cache, scenario: str,
                                                        mode: dict[str, Any]) -> None:
    sim = sim_cache(scenario, **mode)
    count, ids = _logged_against_the_device(sim, log_cache(scenario, **mode))
    assert count > 10_000
    layout = {r.id for r in sim.config.reflectors}
    assert set(ids) <= layout | {NO_ID}
    assert FALSE_ID not in ids
    # what an emulator plays: the same ids
    expected = _device_ids(sim)
    for event in sim.events():
        if isinstance(event, NavScan):
            k = round((event.start - sim.scans.start[0]) / sim.scans.period)
            assert sorted(o.id for o in event.observations) == sorted(
                expected[k, sim.scans.seen[k]].tolist())
    if scenario == "degraded":
        # the shiny object beside reflector 3: taken for it, or left without an id, never
        # reported as what it is; so the ids the log carries are not the true ones
        sc, marks = sim.scans, sim.landmarks
        shiny = marks.is_false
        given = expected[:, shiny][sc.seen[:, shiny]]
        assert set(given.tolist()) == {NO_ID, 3}
        true_ids = np.broadcast_to(marks.ids, sc.seen.shape)[sc.seen]
        assert np.any(expected[sc.seen] != true_ids)
        counts = sim.metadata()["counts"]
        assert counts["nav_ids_wrong"] == int(np.sum(given == 3))
        assert counts["nav_ids_absent"] == int(np.sum(expected[sc.seen] == NO_ID))


def test_a_nav200_log_holds_reflector_scans_only_as_the_papers_setup(log_cache) -> None:
    plain = LogReader(log_cache("warehouse"))
    assert plain.metadata["simulator"]["observations"] == "none"
    assert not plain.has_topic(topics.NAV_REFLECTORS)
    assert sum(1 for _ in plain.messages([topics.NAV_POSE])) > 400
    paper = LogReader(log_cache("warehouse", **{"sim.paper_scans": True}))
    assert paper.metadata["simulator"]["observations"] == "paper-scans"
    assert sum(1 for _ in paper.messages([topics.NAV_REFLECTORS])) > 1500
    nav350 = LogReader(log_cache("warehouse", **{"sim.nav_device": "nav350"}))
    assert nav350.metadata["simulator"]["observations"] == "nav350-landmarks"
    ideal = LogReader(log_cache("warehouse", **{"sim.world": "ideal"}))
    assert ideal.metadata["simulator"]["observations"] == "paper-scans"


def _many_reflectors(n: int) -> tuple[list[Reflector], Area]:
    side = math.ceil(math.sqrt(n))
    return ([Reflector(id=i + 1, x=2.0 * (i % side), y=2.0 * (i // side)) for i in range(n)],
            Area(x_min=-1.0, x_max=2.0 * side, y_min=-1.0, y_max=2.0 * side))


def test_survey_error_and_range_biases_have_their_sizes_and_their_own_draws() -> None:
    reflectors, area = _many_reflectors(4000)
    site = SiteSettings(survey_sigma_mm=10.0, range_bias_sigma_mm=5.0)
    marks = build_site(reflectors, area, site, FaultSettings(), np.random.default_rng(4)
                       ).landmarks
    survey = np.concatenate([marks.x - marks.map_x, marks.y - marks.map_y])
    assert np.std(survey) == pytest.approx(0.010, rel=0.05)  # 8000 draws: 1.6 % sd
    assert abs(np.mean(survey)) < 0.0005
    assert np.std(marks.range_bias) == pytest.approx(0.005, rel=0.05)
    # switching the bias or the floor changes nothing of the survey (the draws' order)
    other = build_site(reflectors, area, SiteSettings(survey_sigma_mm=10.0,
                                                      range_bias_sigma_mm=0.0,
                                                      floor_tilt_deg=2.0),
                       FaultSettings(), np.random.default_rng(4)).landmarks
    assert np.array_equal(other.x, marks.x) and np.array_equal(other.y, marks.y)
    assert np.all(other.range_bias == 0.0)


def test_a_reflectors_range_bias_shifts_every_range_to_it(sim_cache) -> None:
    base = sim_cache("warehouse", duration=60.0, **KIND)
    biased = sim_cache("warehouse", duration=60.0, **{**KIND, "site.range_bias_sigma_mm": 20.0})
    bias = biased.landmarks.range_bias
    assert np.all(base.landmarks.range_bias == 0.0) and np.std(bias) > 0.005
    seen = base.scans.seen
    assert np.array_equal(biased.scans.seen, seen)
    shift = (biased.scans.range - base.scans.range)[seen]
    expected = np.broadcast_to(bias[None, :], seen.shape)[seen]
    np.testing.assert_allclose(shift, expected, rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(biased.scans.bearing, base.scans.bearing)


def test_the_floor_slope_has_its_standard_deviation_and_wavelength() -> None:
    reflectors, area = _many_reflectors(4)
    floor = build_site(reflectors, area, SiteSettings(floor_tilt_deg=0.2, floor_wavelength_m=8.0),
                       FaultSettings(), np.random.default_rng(7)).floor
    x, y = np.meshgrid(np.linspace(0.0, 800.0, 801), np.linspace(0.0, 800.0, 801))
    gx, gy = floor.slope(x, y)
    sigma = math.tan(math.radians(0.2))
    assert np.std(gx) == pytest.approx(sigma, rel=0.05)
    assert np.std(gy) == pytest.approx(sigma, rel=0.05)
    # smooth: alike 1 m apart, unrelated four wavelengths apart
    def along_x(lag: int) -> float:
        return float(np.corrcoef(gx[:, :-lag].ravel(), gx[:, lag:].ravel())[0, 1])

    assert along_x(1) > 0.5
    assert abs(along_x(32)) < 0.2
    level = build_site(reflectors, area, SiteSettings(floor_tilt_deg=0.0), FaultSettings(),
                       np.random.default_rng(7)).floor
    assert level.level and not np.any(level.slope(x, y)[0])


def test_a_tilted_head_leans_and_measures_slant_ranges_and_shifted_bearings(sim_cache) -> None:
    sim = sim_cache("warehouse", duration=40.0, **{**KIND, "site.floor_tilt_deg": 3.0})
    sc, v, marks = sim.scans, sim.vehicle, sim.landmarks
    mid = sc.start + 0.5 * sc.period
    hx, hy, hth = sim.truth.point_at(mid, v.nav_x, v.nav_y)
    hth = hth + v.nav_yaw
    gx, gy = sim.site.floor.slope(hx, hy)
    g = np.hypot(gx, gy)
    assert np.max(g) > math.tan(math.radians(1.0))  # a noticeable tilt somewhere
    # the head stands nav_height up the floor's normal (-g, 1)/|(-g, 1)|: it leans downhill
    lean = v.nav_height / np.sqrt(1.0 + g * g)
    px, py = hx - lean * gx, hy - lean * gy
    dx, dy = marks.x[None, :] - px[:, None], marks.y[None, :] - py[:, None]
    horizontal = np.hypot(dx, dy)
    psi = np.arctan2(dy, dx) - hth[:, None]  # horizontal bearing from the head's heading
    b = np.arctan2(gy, gx)[:, None] - hth[:, None]  # where the scan plane rises, head frame
    tan_e = g[:, None] * np.cos(psi - b)  # the beam's elevation
    slant = horizontal * np.sqrt(1.0 + tan_e ** 2)
    tau = np.arctan(g)[:, None]
    angle = b + np.arctan2(np.cos(tau) * np.sin(psi - b), np.cos(psi - b))
    seen = sc.seen
    np.testing.assert_allclose(sc.range[seen], slant[seen], rtol=0.0, atol=1e-9)
    err = (sc.bearing - angle + math.pi) % (2 * math.pi) - math.pi
    assert np.max(np.abs(err[seen])) < 1e-9
    # the sizes docs/simulator.md gives: slant ranges longer by about r tau^2 cos^2 / 2, the
    # bearing shifted by about -(tau^2 / 4) sin 2(psi - b)
    longer = (slant - horizontal)[seen]
    assert np.all(longer >= 0.0)
    approx = (horizontal * np.tan(tau) ** 2 * np.cos(psi - b) ** 2 / 2.0)[seen]
    np.testing.assert_allclose(longer, approx, rtol=0.01, atol=1e-7)
    shift = ((angle - psi + math.pi) % (2 * math.pi) - math.pi)[seen]
    approx = np.broadcast_to(-(tau ** 2) / 4.0 * np.sin(2.0 * (psi - b)), seen.shape)[seen]
    np.testing.assert_allclose(shift, approx, rtol=0.02, atol=1e-9)


@pytest.mark.parametrize("latency", [0.04, 0.3], ids=["default", "over-two-revolutions"])
def test_the_device_identifies_with_its_own_prediction_as_a_sequential_device(
        sim_cache, latency: float) -> None:
    sim = sim_cache("degraded", seed=4, duration=30.0, **{"nav.latency_s": latency})
    s, v, marks = sim.settings, sim.vehicle, sim.landmarks
    scans = sim.scans
    assert np.any(scans.prior != 0.0)
    n = len(scans)
    mid = scans.start + 0.5 * scans.period
    hx, hy, hth = sim.truth.point_at(mid, v.nav_x, v.nav_y)
    truth = np.stack([hx, hy, hth + v.nav_yaw], axis=1)
    # the device one revolution after the other
    x, y, heading = np.zeros(n), np.zeros(n), np.zeros(n)
    valid = np.zeros(n, dtype=bool)
    matched = np.empty_like(scans.matched)
    # the newest solution available when each revolution ends (the previous revolution's, or
    # with the long latency the one before that)
    usable = np.searchsorted(sim.solutions.available, scans.start + scans.period) - 1
    lag = 1 if latency < scans.period else 3
    assert np.array_equal(usable[3:], np.arange(3, n) - lag)
    for k in range(n):
        prior = nav_model.carried_error(x, y, heading, valid, truth, usable)[k]
        one = replace(scans.take(np.array([k])), prior=prior[None, :])
        one = replace(one, matched=nav_model._match(one, sim.truth, v, s.nav, marks))
        sol = nav_model.solve(one, sim.truth, v, s.nav, marks)
        matched[k] = one.matched[0]
        x[k], y[k], heading[k], valid[k] = sol.x[0], sol.y[0], sol.heading[0], sol.valid[0]
        # the same operations on one row: equal but for a processor's last bits
        np.testing.assert_allclose(prior, scans.prior[k], rtol=0.0, atol=1e-12)
    np.testing.assert_array_equal(matched, scans.matched)
    np.testing.assert_allclose(x, sim.solutions.x, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(y, sim.solutions.y, rtol=0.0, atol=1e-12)


def test_the_kind_world_identifies_from_the_true_pose_with_the_true_ids(sim_cache) -> None:
    sim = sim_cache("degraded", duration=30.0, **{"sim.world": "ideal"})
    assert np.all(sim.scans.prior == 0.0)
    scan = next(e for e in sim.events() if isinstance(e, NavScan) and len(e.observations) > 3)
    assert {o.id for o in scan.observations} <= {r.id for r in sim.config.reflectors} | {NO_ID}


@pytest.mark.parametrize("setting", ["site.survey_sigma_mm=-1", "site.floor_tilt_deg=30",
                                     "site.range_bias_sigma_mm=-2",
                                     "site.floor_wavelength_m=0",
                                     "nav.identification=guess"])
def test_a_site_setting_out_of_its_range_is_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str], tmp_path: Any, setting: str) -> None:
    code, _, err = run_command(capsys, "simulate", "--scenario", "paper-circle", "--set",
                                 setting, "-o", tmp_path / "x.mcap")
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert setting.partition("=")[0] in err
    assert not (tmp_path / "x.mcap").exists()
