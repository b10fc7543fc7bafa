"""The warehouse's stations and the docking controller (lgvtool.sim.docking, station_poses).

Each visit of a station ends at the station's nominal pose plus the docking controller's error
of that visit (``drive.dock_sigma_*``), built up over the final approach and undone after it:
exactly so in the kind world (a kinematic vehicle), to within the path controller's residual
on the site (a few mm, docs/simulator.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from lgvtool.errors import ConfigError, InputError
from lgvtool.log import LogReader
from lgvtool.quantiles import chi2_quantile
from lgvtool.sim.docking import StationVisit
from lgvtool.sim.kinematics import TrueDrive
from lgvtool.sim.logfile import write_log
from lgvtool.sim.scenarios import REVERSE_PAUSE_S, get_scenario
from lgvtool.sim.simulation import STREAMS, Simulation, resolve, simulate, true_drive, true_vehicle
from lgvtool.sim.station_poses import Station, scenario_stations, setup_stations
from tests.inprocess import run_command

SimCache = Callable[..., Simulation]

DOCKING = {"drive.dock_sigma_along_m": 0.010, "drive.dock_sigma_across_m": 0.008,
           "drive.dock_sigma_heading_deg": 0.3}
"""The defaults, set explicitly (the kind world switches docking off)."""
EXACT = {"drive.dock_sigma_along_m": 0.0, "drive.dock_sigma_across_m": 0.0,
         "drive.dock_sigma_heading_deg": 0.0}
KIND_M = 1e-5
"""Kind world: the true stop against nominal + error, m (the plan's turns are sampled on the
200 Hz grid: about 1 um)."""
KIND_RAD = math.radians(1e-4)
"""Kind world: the same for the heading, rad (about 6e-6 deg)."""
SITE_M = 5e-3
"""On the site: the path controller's residual at a stop, m (seeds 1 to 3: at most 4 mm,
about 1 mm spread about a mean of -1.5 mm along and -1.8 mm across)."""
SITE_RAD = math.radians(0.1)
"""On the site: its residual in heading, rad (at most 0.08 deg)."""


def _offsets(truth: TrueDrive, stations: tuple[Station, ...],
             visits: tuple[StationVisit, ...]) -> np.ndarray:
    """Per visit the true pose of O in the middle of its standstill minus its station's
    nominal pose, in the station's frame: along (m), across (m), heading (rad)."""
    by_name = {s.name: s for s in stations}
    out = np.empty((len(visits), 3))
    for i, v in enumerate(visits):
        st = by_name[v.station]
        x, y, h = truth.pose_at(np.array([0.5 * (v.arrive_s + v.leave_s)]))
        dx, dy = float(x[0]) - st.x, float(y[0]) - st.y
        c, s = math.cos(st.heading), math.sin(st.heading)
        out[i] = (c * dx + s * dy, -s * dx + c * dy,
                  math.remainder(float(h[0]) - st.heading, 2 * math.pi))
    return out


def _errors(visits: tuple[StationVisit, ...]) -> np.ndarray:
    return np.array([(v.error.along, v.error.across, v.error.heading) for v in visits])


def test_the_warehouse_has_a_pick_and_a_drop_station() -> None:
    pick, drop = scenario_stations("warehouse")
    assert (pick.name, drop.name) == ("pick", "drop")
    # halfway along the short sides (6 m) of the 10 m route from (6, 4) heading east
    assert pick.heading == pytest.approx(math.pi / 2, abs=1e-6)
    assert drop.heading == pytest.approx(-math.pi / 2, abs=1e-6)
    assert pick.y == pytest.approx(drop.y, abs=1e-5)
    assert pick.x - drop.x == pytest.approx(12.563, abs=1e-3)  # 10 m + the turns' 2 x 1.28 m
    assert get_scenario("warehouse").stations == (pick.name, drop.name)
    assert scenario_stations("paper-circle") == () == get_scenario("paper-circle").stations


def test_the_stations_follow_the_scenario_and_the_vehicle() -> None:
    pick, _ = scenario_stations("warehouse")
    longer, _ = scenario_stations("warehouse", {"length_b": 8.0})
    assert longer.y - pick.y == pytest.approx(1.0, abs=1e-6)  # halfway along 8 m, not 6
    assert scenario_stations("warehouse", {"scenario.length_b": 8.0})[0] == longer
    wider, _ = scenario_stations("warehouse", {"vehicle.h": 1.5})
    assert abs(wider.x - pick.x) > 0.01  # the turns' geometry depends on the wheelbase
    with pytest.raises(InputError, match="unknown scenario"):
        scenario_stations("storehouse")
    with pytest.raises(ConfigError, match="length_b"):
        scenario_stations("warehouse", {"length_b": -1.0})


def test_every_lap_stops_at_both_stations_long_enough_to_be_found(sim_cache: SimCache) -> None:
    sim = sim_cache("warehouse")
    assert [v.station for v in sim.visits] == ["pick", "drop"] * 2
    assert [s.name for s in sim.stations] == ["pick", "drop"]
    # standstills while driving: the stations' (3 s, 4 s) and the 1 s pause after reversing
    t = sim.truth.path.t
    still = sim.truth.drive_speed == 0.0
    edges = np.diff(still.astype(int))
    starts, ends = t[1:][edges == 1], t[1:][edges == -1]
    ref = sim.plan.reference
    lengths = [e - s for s, e in zip(starts, ends[1:], strict=False)
               if ref["moving_from_s"] < s < ref["moving_until_s"]]
    expected = [3.0, REVERSE_PAUSE_S, 4.0] * 2
    assert lengths == pytest.approx(expected, abs=0.011)  # s: the 200 Hz grid
    dwells = [sim.setup.parameters[k] for k in ("pick_dwell_s", "drop_dwell_s")]
    assert REVERSE_PAUSE_S < 2.0 <= min(dwells)  # s: a standstill detector's least time
    for v in sim.visits:  # the vehicle stands still through each visit
        x, y, h = sim.truth.pose_at(np.array([v.arrive_s + 0.01, v.leave_s - 0.01]))
        assert np.ptp(x) == 0.0 and np.ptp(y) == 0.0 and np.ptp(h) == 0.0


def test_in_the_kind_world_each_stop_is_the_nominal_pose_plus_its_docking_error(
        sim_cache: SimCache) -> None:
    sim = sim_cache("warehouse", seed=5, **{"sim.world": "ideal", **DOCKING})
    off, err = _offsets(sim.truth, sim.stations, sim.visits), _errors(sim.visits)
    assert np.all(np.abs(err[:, :2]) > 1e-4)  # the draws are not zero
    assert np.abs(off[:, :2] - err[:, :2]).max() < KIND_M
    assert np.abs(off[:, 2] - err[:, 2]).max() < KIND_RAD
    # and back on the route after each visit: the ideal route closes
    p = sim.truth.path
    assert math.hypot(p.x[-1] - p.x[0], p.y[-1] - p.y[0]) < KIND_M


def test_on_the_site_each_stop_is_within_the_docking_spread(sim_cache: SimCache) -> None:
    for seed in (1, 2, 3):
        sim = sim_cache("warehouse", seed=seed)
        d = sim.settings.drive
        off, err = _offsets(sim.truth, sim.stations, sim.visits), _errors(sim.visits)
        # the docking error drawn, plus the path controller's residual
        assert np.abs(off[:, :2] - err[:, :2]).max() < SITE_M
        assert np.abs(off[:, 2] - err[:, 2]).max() < SITE_RAD
        # and so within 4 sigma of the docking spread (and the residual) of the nominal pose
        bound = 4 * np.array([d.dock_sigma_along_m, d.dock_sigma_across_m,
                              math.radians(d.dock_sigma_heading_deg)])
        assert np.all(np.abs(off) < bound + np.array([SITE_M, SITE_M, SITE_RAD]))


def test_zero_spread_stops_at_the_nominal_pose(sim_cache: SimCache) -> None:
    kind = sim_cache("warehouse", seed=5, **{"sim.world": "ideal"})  # docking off there
    assert np.abs(_offsets(kind.truth, kind.stations, kind.visits)[:, :2]).max() < KIND_M
    assert np.abs(_offsets(kind.truth, kind.stations, kind.visits)[:, 2]).max() < KIND_RAD
    site = sim_cache("warehouse", seed=5, **EXACT)
    off = _offsets(site.truth, site.stations, site.visits)
    assert np.abs(off[:, :2]).max() < SITE_M and np.abs(off[:, 2]).max() < SITE_RAD
    # the docking draws come last: without them every other draw is the same, and so is the
    # drive, bit for bit, up to the first station's approach
    docked = sim_cache("warehouse", seed=5)
    assert not np.array_equal(site.plan.controls.steering, docked.plan.controls.steering)
    far = site.truth.path.t < docked.visits[0].arrive_s - 10.0
    assert np.array_equal(site.truth.path.x[far], docked.truth.path.x[far])
    assert np.array_equal(site.truth.path.heading[far], docked.truth.path.heading[far])


def test_over_many_visits_the_true_stops_spread_as_the_settings_say() -> None:
    """80 visits (40 laps) on the site: per component the sample standard deviation of the
    true stops about each station's mean, against the setting. Tolerance: the chi-square
    interval of the sample variance at 99.9 % (78 degrees of freedom: 0.75 to 1.27 x the
    sigma), widened at the top by the path controller's residual (1.5 mm, 0.05 deg added in
    quadrature; measured 0.6 to 1.0 mm and 0.02 deg)."""
    setup = resolve("warehouse", overrides={"scenario.laps": 40})
    vehicle = true_vehicle(setup.config.vehicle, setup.settings.install)
    rng = np.random.default_rng(2024).spawn(len(STREAMS))[-1]
    _, truth, visits = true_drive(setup, vehicle, rng)
    assert len(visits) == 80
    off = _offsets(truth, setup_stations(setup), visits)
    names = np.array([v.station for v in visits])
    for name in ("pick", "drop"):
        off[names == name] -= off[names == name].mean(axis=0)
    dof = len(visits) - 2
    sample = np.sqrt((off ** 2).sum(axis=0) / dof)
    d = setup.settings.drive
    sigma = np.array([d.dock_sigma_along_m, d.dock_sigma_across_m,
                      math.radians(d.dock_sigma_heading_deg)])
    residual = np.array([1.5e-3, 1.5e-3, math.radians(0.05)])
    low = sigma * math.sqrt(chi2_quantile(0.0005, dof) / dof)
    high = np.sqrt(sigma ** 2 * chi2_quantile(0.9995, dof) / dof + residual ** 2)
    assert np.all(low < sample), (sample, low)
    assert np.all(sample < high), (sample, high)


def test_the_docking_manoeuvre_is_smooth_and_the_odometry_sees_it(sim_cache: SimCache) -> None:
    sim = sim_cache("warehouse", seed=5, **{"drive.dock_sigma_across_m": 0.03})
    tr = sim.truth
    # no jump: each 5 ms step moves O by at most the drive wheel's travel in it
    step = np.hypot(np.diff(tr.path.x), np.diff(tr.path.y))
    assert np.all(step <= np.abs(tr.drive_speed[:-1]) * np.diff(tr.path.t) * (1 + 1e-9))
    assert np.abs(tr.drive_speed).max() < 0.8 * 1.03  # m/s: the warp adds 2 % at most here
    assert np.abs(np.diff(tr.steering_command)).max() < math.radians(0.5)  # rad per step
    # dead reckoning from the encoder wheels' travel over the pick's approach reaches the
    # docked stop (the wheels roll the true motion)
    v = sim.visits[0]
    t = tr.path.t
    k0 = int(np.searchsorted(t, v.arrive_s - 8.0))
    k1 = int(np.searchsorted(t, v.arrive_s + 1.0))
    ds = 0.5 * (np.diff(tr.s_left[k0:k1 + 1]) + np.diff(tr.s_right[k0:k1 + 1]))
    dth = (np.diff(tr.s_right[k0:k1 + 1]) - np.diff(tr.s_left[k0:k1 + 1])) / sim.vehicle.track
    th = tr.path.heading[k0] + np.concatenate([[0.0], np.cumsum(dth)])
    mid = th[:-1] + 0.5 * dth
    x = tr.path.x[k0] + np.sum(ds * np.cos(mid))
    y = tr.path.y[k0] + np.sum(ds * np.sin(mid))
    assert math.hypot(x - tr.path.x[k1], y - tr.path.y[k1]) < 1e-6
    assert th[-1] == pytest.approx(tr.path.heading[k1], abs=1e-9)
    assert abs(_offsets(tr, sim.stations, sim.visits)[0, 1]) > 0.01  # a large across error


def test_the_same_seed_docks_the_same(sim_cache: SimCache) -> None:
    a = simulate("warehouse", seed=3, duration=120.0)
    b = simulate("warehouse", seed=3, duration=120.0)
    c = simulate("warehouse", seed=4, duration=120.0)
    assert a.visits == b.visits and a.visits != c.visits
    assert np.array_equal(a.truth.path.x, b.truth.path.x)
    assert [v.station for v in a.visits] == ["pick", "drop"]


def test_the_log_lists_the_stations(tmp_path: Path, sim_cache: SimCache,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    sim = sim_cache("warehouse")
    log = tmp_path / "w.mcap"
    write_log(sim, log)
    listed = LogReader(log).metadata["simulator"]["stations"]
    assert [s["name"] for s in listed] == ["pick", "drop"]
    for got, want in zip(listed, scenario_stations("warehouse"), strict=True):
        assert got["x"] == pytest.approx(want.x, abs=1e-9)
        assert got["y"] == pytest.approx(want.y, abs=1e-9)
        assert math.radians(got["heading_deg"]) == pytest.approx(want.heading, abs=1e-12)
    code, out, err = run_command(capsys, "info", log)
    assert code == 0, err
    assert "stations:" in out and "'pick'" in out
    circle = tmp_path / "c.mcap"
    write_log(sim_cache("paper-circle", duration=20.0), circle)
    assert "stations" not in LogReader(circle).metadata["simulator"]


@pytest.mark.parametrize("value", ["dock_sigma_along_m=-0.01", "dock_sigma_across_m=-0.001",
                                   "dock_sigma_heading_deg=-0.3", "dock_approach_m=0",
                                   "dock_sigma_along_m=0.2"])
def test_a_bad_docking_setting_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str],
                                                      tmp_path: Path, value: str) -> None:
    out = tmp_path / "x.mcap"
    code, _, err = run_command(capsys, "simulate", "-s", "warehouse", "--set",
                               f"drive.{value}", "-o", out)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert f"drive.{value.partition('=')[0]}" in err
    assert not out.exists()


def test_an_error_too_large_for_the_straight_is_one_line_and_exit_2(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    # 50 mm across (5 sigma ~ 0.25 m) over 0.2 m of approach needs more steering than a dock
    out = tmp_path / "x.mcap"
    code, _, err = run_command(capsys, "simulate", "-s", "warehouse", "--seed", "1",
                               "--set", "drive.dock_sigma_across_m=0.05",
                               "--set", "drive.dock_approach_m=0.2", "-o", out)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert "docking error" in err and "drive.dock_" in err
    assert not out.exists()
