"""The stations section of ``lgvtool audit``: standstills found from the odometry, a visit's
pose per source, grouping into stations (automatic and named), sigma and the 95 % radius
against hand values, the stops' own spread with a source's noise over each stop taken off, a
station outside its tolerance failing, the stations file's faults (one line, exit 2), and a
station found on small simulated warehouse logs."""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path
from typing import Any, cast

import numpy as np
import pytest

from lgvtool.audit.stations import (
    NamedStation,
    StationSettings,
    Visit,
    VisitPose,
    find_stations,
    log_kpis,
    log_visits,
    mean_pose,
    spread,
    standstills,
    stations_section,
    stop_spread,
    summary_line,
)
from lgvtool.audit.stations_file import parse_stations
from lgvtool.errors import ConfigError
from lgvtool.trajectory import Trajectory
from tests.inprocess import run_command
from tests.simlogs import simulate_log

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evaluate"))
from test_report_browser import _check_page, browser, render

__all__ = ["browser"]  # the fixture, used by name

TOL = 1e-9
"""Tolerance of figures the construction makes exact but for float rounding (m, rad, s)."""


def _odometry(segments: list[tuple[float, float, float]], dt: float = 0.1
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motion samples every ``dt`` s through ``segments`` of (duration s, speed m/s, yaw rate
    rad/s): sample times, and per increment the distance m and heading change rad."""
    ds: list[float] = []
    dth: list[float] = []
    for duration, v, w in segments:
        n = round(duration / dt)
        ds += [v * dt] * n
        dth += [w * dt] * n
    t = np.arange(len(ds) + 1) * dt
    return t, np.array(ds), np.array(dth)


def test_a_standstill_is_found_from_the_odometry() -> None:
    # 5 s moving, 3 s still, 5 s moving, 1 s still (a halt), 3 s turning on the spot, 4 s
    # moving
    t, ds, dth = _odometry([(5, 0.5, 0), (3, 0, 0), (5, 0.5, 0), (1, 0, 0), (3, 0, 0.3),
                            (4, 0.5, 0)])
    found = standstills(t, ds, dth, StationSettings())
    # a sample is still when the 0.5 s window centred on it holds no motion: from 5.3 to 7.7 s
    assert len(found) == 1
    assert found[0][0] == pytest.approx(5.3, abs=TOL)
    assert found[0][1] == pytest.approx(7.7, abs=TOL)
    # a shorter minimum finds the 1 s halt too (0.4 s of still samples: 13.3 to 13.7 s)
    short = standstills(t, ds, dth, StationSettings(min_standstill_s=0.3))
    assert len(short) == 2
    assert short[1][0] == pytest.approx(13.3, abs=TOL)
    # a gap in the samples breaks the standstill
    gap = t.copy()
    gap[66:] += 2.0
    assert standstills(gap, ds, dth, StationSettings()) == []


def test_a_visit_pose_is_the_mean_after_settling_with_a_circular_heading() -> None:
    t = np.arange(0.0, 4.01, 0.5)
    # the first second off by 1 m (settling); then headings either side of +-pi
    x = np.where(t < 1.0, 11.0, 10.0 + 0.002 * np.sign(np.sin(7 * t)))
    heading = np.where(np.arange(len(t)) % 2 == 0, math.pi - 0.01, -math.pi + 0.03)
    track = Trajectory(t, x, np.full(len(t), 5.0), heading)
    p = mean_pose(track, 1.0, 4.0)
    assert p is not None and p.samples == 7
    assert p.x == pytest.approx(float(np.mean(x[2:])), abs=TOL)
    assert p.y == pytest.approx(5.0, abs=TOL)
    # four at pi - 0.01 (t = 1, 2, 3, 4) and three at -pi + 0.03: a mean near pi, not near 0
    s = 4 * math.sin(math.pi - 0.01) + 3 * math.sin(-math.pi + 0.03)
    c = 4 * math.cos(math.pi - 0.01) + 3 * math.cos(-math.pi + 0.03)
    assert abs(p.heading) > 3.1
    assert math.remainder(p.heading - math.atan2(s, c), 2 * math.pi) == pytest.approx(
        0.0, abs=TOL)
    # log_visits: one standstill, each source's mean over it after settle_s
    odo = _odometry([(2, 0.5, 0), (4, 0, 0), (2, 0.5, 0)])
    truth = Trajectory(np.arange(0.0, 8.01, 0.05), np.full(161, 3.0), np.full(161, 4.0),
                       np.full(161, 0.5))
    (visit,) = log_visits("a.mcap", odo, {"truth": truth, "laser": None}, "ekf",
                          StationSettings())
    assert set(visit.poses) == {"truth"}
    assert visit.poses["truth"].x == pytest.approx(3.0, abs=TOL)
    assert visit.start_s == pytest.approx(2.3, abs=TOL)
    assert visit.estimator == "ekf"


def _visit(x: float, y: float, heading: float = 0.0, *, log: str = "a.mcap", t: float = 0.0,
           truth: tuple[float, float, float] | None = None) -> Visit:
    poses = {"estimator": VisitPose(x, y, heading, 10)}
    if truth is not None:
        poses["truth"] = VisitPose(*truth, 40)
    return Visit(log, t, t + 3.0, poses, "ekf")


def test_visits_group_into_stations_by_position_and_heading() -> None:
    visits = [_visit(5.0, 5.0, t=0), _visit(20.0, 3.0, math.pi / 2, t=10),
              _visit(5.01, 4.99, t=20, log="b.mcap"),
              _visit(5.0, 5.0, math.pi, t=30),  # the same place, facing the other way
              _visit(20.02, 3.0, math.pi / 2 + 0.01, t=40, log="b.mcap")]
    found = find_stations(visits, None, StationSettings())
    assert [s.name for s in found.stations] == ["S1", "S2"]
    assert [len(s.visits) for s in found.stations] == [2, 2]
    assert found.stations[0].x == pytest.approx(5.005, abs=TOL)
    assert {v.log for v in found.stations[1].visits} == {"a.mcap", "b.mcap"}
    assert [v.start_s for v in found.unmatched] == [30.0]
    assert found.visits == 5
    # named: to the nearest named station within the grouping radius and heading
    named = [NamedStation("pick", 5.0, 5.0, 0.0, 0.02, math.radians(1)),
             NamedStation("drop", 20.0, 3.2, math.pi / 2, 0.02, math.radians(1))]
    by_name = find_stations(visits, named, StationSettings())
    assert [len(s.visits) for s in by_name.stations] == [2, 2]
    assert [v.start_s for v in by_name.unmatched] == [30.0]


def test_sigma_and_the_95_percent_radius_against_hand_values() -> None:
    x = np.array([0.0, 0.01, 0.0, -0.03, 0.02])
    y = np.array([0.0, 0.0, 0.02, 0.0, -0.02])
    h = np.array([math.pi - 0.01, -math.pi + 0.01, math.pi - 0.02, -math.pi + 0.02, math.pi])
    mx, my, mh, sx, sy, sh, r95 = spread(x, y, h)
    assert (mx, my) == (pytest.approx(0.0, abs=TOL), pytest.approx(0.0, abs=TOL))
    assert abs(mh) == pytest.approx(math.pi, abs=TOL)
    assert sx == pytest.approx(math.sqrt((1e-4 + 9e-4 + 4e-4) / 4), abs=TOL)
    assert sy == pytest.approx(math.sqrt((4e-4 + 4e-4) / 4), abs=TOL)
    assert sh == pytest.approx(math.sqrt((2e-4 + 8e-4) / 4), abs=TOL)
    # distances from the mean 0, 0.01, 0.02, 0.03, 0.02*sqrt(2); the 95th percentile lies
    # 0.8 of the way from the fourth to the fifth (rank 0.95 x 4 = 3.8)
    r = sorted([0.0, 0.01, 0.02, 0.03, 0.02 * math.sqrt(2)])
    assert r95 == pytest.approx(r[3] + 0.8 * (r[4] - r[3]), abs=TOL)
    # the section's entry carries the same, in its units
    visits = [_visit(10 + a, 5 + b, float(c), t=i)
              for i, (a, b, c) in enumerate(zip(x, y, h, strict=True))]
    doc: dict[str, Any] = cast(dict[str, Any], stations_section(
        find_stations(visits, None, StationSettings()), StationSettings()))
    (st,) = doc["per_station"]
    (src,) = st["sources"]
    assert src["sigma_x_m"] == pytest.approx(sx, abs=1e-6)
    assert src["sigma_heading_deg"] == pytest.approx(math.degrees(sh), abs=1e-5)
    assert src["radius95_m"] == pytest.approx(r95, abs=1e-6)
    assert src["worst"]["distance_m"] == pytest.approx(0.03, abs=1e-6)
    assert src["worst"]["t_s"] == 3.0
    assert src["pass"] is None  # an automatic station has no tolerance


def test_the_stops_alone_take_the_noise_of_each_mean_off() -> None:
    # hand values: sigma 10 mm, standard errors 6 and 8 mm -> mean square 50 mm^2
    stops, noise = stop_spread(0.01, np.array([0.006, 0.008, math.nan]))
    assert stops == pytest.approx(math.sqrt(50e-6), abs=TOL)
    assert noise == pytest.approx(math.sqrt(50e-6), abs=TOL)
    assert stop_spread(0.005, np.array([0.008]))[0] == 0.0  # noise above the spread: none left
    assert all(math.isnan(v) for v in stop_spread(0.01, np.array([math.nan])))
    assert all(math.isnan(v) for v in stop_spread(math.nan, np.array([0.001])))
    # a visit's standard error: the poses' standard deviation (n - 1) over sqrt(n)
    xs = np.array([1.0, 1.004, 0.998, 1.002, 0.996, 1.0])
    track = Trajectory(np.arange(6.0), xs, np.zeros(6), np.array([0.0, 0.002, -0.002] * 2))
    p = mean_pose(track, 0.0, 5.0)
    assert p is not None
    assert p.se_x == pytest.approx(float(np.std(xs, ddof=1)) / math.sqrt(6), abs=TOL)
    assert p.se_y == 0.0
    assert p.se_heading == pytest.approx(math.sqrt(4 * 4e-6 / 5) / math.sqrt(6), abs=TOL)
    one = mean_pose(track, 0.0, 0.5)
    assert one is not None and math.isnan(one.se_x)
    # statistically: 400 stops spread 9 mm in y, each seen through 6 poses with 10 mm of noise
    # each; the spread of the visit means is sqrt(81 + 100 / 6) = 9.9 mm, the stops' own 9 mm
    rng = np.random.default_rng(7)
    visits = []
    for i in range(400):
        stop_y = 5.0 + rng.normal(0.0, 0.009)
        ys = stop_y + rng.normal(0.0, 0.010, 6)
        pose = mean_pose(Trajectory(np.arange(6.0), np.full(6, 3.0), ys, np.zeros(6)), 0, 5)
        assert pose is not None
        visits.append(Visit("a.mcap", 10.0 * i, 10.0 * i + 3.0, {"laser": pose}, "ekf"))
    doc: dict[str, Any] = cast(dict[str, Any], stations_section(
        find_stations(visits, None, StationSettings()), StationSettings()))
    (src,) = doc["per_station"][0]["sources"]
    # the sampling error of a sigma from 400 visits is about 4 %
    assert src["sigma_y_m"] == pytest.approx(math.sqrt(81e-6 + 100e-6 / 6), rel=0.08)
    assert src["stops_alone"]["sigma_y_m"] == pytest.approx(0.009, rel=0.08)
    assert src["stops_alone"]["noise_y_m"] == pytest.approx(0.010 / math.sqrt(6), rel=0.08)
    assert src["stops_alone"]["sigma_x_m"] == 0.0
    assert doc["summary"]["laser"]["stops_alone_sigma_y_max_m"] == src["stops_alone"][
        "sigma_y_m"]
    listed = doc["per_station"][0]["visit_list"][0]["standard_errors"]["laser"]
    assert listed[1] == pytest.approx(visits[0].poses["laser"].se_y, abs=1e-7)


def test_a_station_outside_its_tolerance_fails() -> None:
    named = [NamedStation("pick", 5.0, 5.0, 0.0, 0.01, math.radians(1)),
             NamedStation("drop", 20.0, 3.0, 0.0, 0.01, math.radians(1))]
    visits = [_visit(5.005, 5.0, t=0, truth=(5.0, 5.0, 0.0)),
              _visit(5.015, 5.0, t=10, truth=(5.0, 5.0, 0.0)),  # 15 mm off: outside
              _visit(20.0, 3.004, t=20), _visit(20.0, 2.996, math.radians(0.5), t=30)]
    found = find_stations(visits, named, StationSettings())
    section = stations_section(found, StationSettings(), file="stations.toml")
    doc: dict[str, Any] = cast(dict[str, Any], section)
    pick, drop = doc["per_station"]
    est = next(s for s in pick["sources"] if s["role"] == "estimator")
    assert est["within_tolerance"] == 1 and est["pass"] is False
    assert est["worst"]["distance_m"] == pytest.approx(0.015, abs=1e-6)
    assert est["error_vs_truth"]["rms_m"] == pytest.approx(
        math.sqrt((0.005**2 + 0.015**2) / 2), abs=1e-6)
    truth = next(s for s in pick["sources"] if s["role"] == "truth")
    assert truth["pass"] is True  # the truth stood on the station: the estimator misplaced it
    (d,) = drop["sources"]
    assert d["pass"] is True and d["within_tolerance"] == 2
    summary = doc["summary"]["estimator"]
    assert (summary["passed"], summary["failed"]) == (1, 1)
    assert "1 passed, 1 failed" in (summary_line(section) or "")
    kpis = log_kpis(found, "a.mcap")
    assert kpis["station_visits"] == 4 and kpis["station_visits_outside"] == 1
    assert kpis["station_deviation_rms_m"] == pytest.approx(
        math.sqrt((0.005**2 + 0.015**2 + 0.004**2 + 0.004**2) / 4), abs=TOL)


STATION = """[[stations]]
name = "pick"
x = 1.0
y = 2.0
heading = 90.0
tolerance_xy_m = 0.02
tolerance_deg = 1.0
"""


def test_a_stations_file_is_read() -> None:
    (st,) = parse_stations(STATION)
    assert (st.name, st.x, st.y) == ("pick", 1.0, 2.0)
    assert st.heading == pytest.approx(math.pi / 2, abs=TOL)
    assert st.tolerance_rad == pytest.approx(math.radians(1.0), abs=TOL)


BAD_FILES = {
    "missing field": (STATION.replace("tolerance_deg = 1.0\n", ""), "missing tolerance_deg"),
    "negative tolerance": (STATION.replace("0.02", "-0.02"), "tolerance_xy_m must be above 0"),
    "not TOML": ("[[stations]\nname = pick", "not TOML"),
    "unknown key": (STATION + "speed = 1\n", "unknown key 'speed'"),
    "text for a number": (STATION.replace("x = 1.0", 'x = "one"'), "x must be a finite"),
    "a name twice": (STATION + STATION, "given twice"),
    "no station": ("", "no [[stations]]"),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_stations_file_is_refused(case: str) -> None:
    text, words = BAD_FILES[case]
    with pytest.raises(ConfigError, match=words.replace("[", r"\[")):
        parse_stations(text, "s.toml")


@pytest.fixture(scope="module")
def warehouse_logs(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Two short simulated warehouse drives (one lap each: a 3 s stop on the lap, the start
    and the end standing)."""
    d = tmp_path_factory.mktemp("stations")
    return [simulate_log(d / f"w{seed}.mcap", 105.0, seed, scenario="warehouse",
                         paper_scans=False) for seed in (1, 2)]


def _audit(capsys: pytest.CaptureFixture[str], logs: list[Path], out: Path,
           *more: object) -> str:
    """``lgvtool audit LOGS -o OUT MORE``: its stdout (``OUT/audit.json`` written)."""
    code, stdout, err = run_command(capsys, "audit", *logs, "-o", out, "--no-progress", *more)
    assert code == 0, err
    return stdout


def test_a_station_is_found_on_small_simulated_logs(
        warehouse_logs: list[Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    stdout = _audit(capsys, warehouse_logs, tmp_path / "auto")
    doc: dict[str, Any] = json.loads((tmp_path / "auto" / "audit.json").read_text("utf-8"))
    st = doc["stations"]
    assert st["mode"] == "automatic" and st["sources"]["estimator"] == "ekf"
    # the lap's stops (away from the start pose (6, 4), where the log starts and ends
    # standing): each one visit per log, the logs pooled into one station
    stops = [s for s in st["per_station"] if math.hypot(s["x"] - 6, s["y"] - 4) > 1]
    assert stops
    for stop in stops:
        assert stop["visits"] == 2
        assert {Path(v["log"]).name for v in stop["visit_list"]} == {"w1.mcap", "w2.mcap"}
    pick = stops[0]
    roles = {s["role"]: s for s in pick["sources"]}
    assert set(roles) == {"truth", "laser", "estimator"}
    for s in roles.values():
        # a repeatable simulated stop: every source within a few cm of the others
        assert s["sigma_x_m"] < 0.03 and s["sigma_y_m"] < 0.03
        assert math.hypot(s["mean"]["x"] - pick["x"], s["mean"]["y"] - pick["y"]) < 0.05
        assert s["pass"] is None
    assert roles["laser"]["error_vs_truth"]["rms_m"] < 0.05
    assert any(line.startswith("stations: ") for line in stdout.splitlines())
    page = (tmp_path / "auto" / "report.html").read_text(encoding="utf-8")
    assert 'data-section="stations"' in page and 'data-figure="stations"' in page
    assert 'data-table="stations"' in page and "no tolerance" in page
    with open(tmp_path / "auto" / "kpis.csv", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    # per log: its visits of the stations
    at_stations = sum(s["visits"] for s in st["per_station"])
    assert [int(r["station_visits"]) for r in rows] == [at_stations // 2] * 2
    assert all(r["station_visits_outside"] == "" for r in rows)

    # the same stop named in a stations file: within 5 cm it passes, within 0.1 mm it fails
    def named(tol: float) -> Path:
        """The audit.json of an audit with the stop named, within ``tol`` m."""
        f = tmp_path / f"stations-{tol}.toml"
        f.write_text(f'[[stations]]\nname = "pick"\nx = {pick["x"]}\ny = {pick["y"]}\n'
                     f'heading = {pick["heading_deg"]}\ntolerance_xy_m = {tol}\n'
                     "tolerance_deg = 2.0\n", encoding="utf-8")
        out = _audit(capsys, warehouse_logs, tmp_path / f"named-{tol}", "--stations", f)
        assert "named" in out
        return tmp_path / f"named-{tol}" / "audit.json"

    good: dict[str, Any] = json.loads(named(0.05).read_text("utf-8"))["stations"]
    assert good["mode"] == "named"
    assert len(good["unmatched"]) == st["visits"] - 2  # every other standstill
    est = next(s for s in good["per_station"][0]["sources"] if s["role"] == "estimator")
    assert est["pass"] is True and est["within_tolerance"] == 2
    bad: dict[str, Any] = json.loads(named(0.0001).read_text("utf-8"))["stations"]
    est = next(s for s in bad["per_station"][0]["sources"] if s["role"] == "estimator")
    assert est["pass"] is False
    assert bad["summary"]["estimator"]["failed"] == 1


@pytest.mark.parametrize("case", ["missing field", "negative tolerance", "not TOML",
                                  "unknown key"])
def test_a_bad_stations_file_is_one_line_exit_2(case: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    f = tmp_path / "stations.toml"
    f.write_text(BAD_FILES[case][0], encoding="utf-8")
    # the file is read before any log: a log that does not exist is never reached
    code, _, err = run_command(capsys, "audit", tmp_path / "none.mcap", "-o", tmp_path / "a",
                               "--stations", f)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and str(f) in err, err
    code, _, err = run_command(capsys, "audit", tmp_path / "none.mcap", "-o", tmp_path / "a",
                               "--set", "stations.min_standstill_s=-1")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "stations." in err


@pytest.mark.parametrize("width", (1400, 420))
def test_the_stations_page_renders_in_chromium(browser: str, warehouse_logs: list[Path],
                                               tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str],
                                               width: int) -> None:
    _audit(capsys, warehouse_logs, tmp_path / "a")
    m = render(browser, tmp_path / "a" / "report.html", width)
    _check_page(m, width)
    assert "stations" in [f["slug"] for f in m["figures"]]


def test_the_docs_list_every_setting_as_declared() -> None:
    from lgvtool.declared import markdown_table

    doc = (Path(__file__).resolve().parents[2] / "docs" / "audit.md").read_text(encoding="utf-8")
    assert markdown_table(StationSettings, "stations.") in doc, (
        "docs/audit.md: the stations thresholds' table differs from stations.py")
