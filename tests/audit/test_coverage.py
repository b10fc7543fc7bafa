"""Coverage along a drive: the GDOP against its closed form and a brute-force least squares,
the poor segments, the heat map and the device's reported counts."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lgvtool.audit.coverage import (
    CoverageSettings,
    HeadTrack,
    coverage_at_poses,
    coverage_section,
    gdop,
    poor_segments,
    section_from,
)
from lgvtool.audit.visibility import DeviceView, expected_visibility
from lgvtool.config import Reflector
from lgvtool.json_types import JSON, JSONObject

VIEW = DeviceView.for_family("nav350")


def _obj(v: JSON) -> JSONObject:
    assert isinstance(v, dict)
    return v


def _list(v: JSON) -> list[JSON]:
    assert isinstance(v, list)
    return v


def _float(v: JSON) -> float:
    assert isinstance(v, int | float)
    return float(v)


def _gdop_brute(hx: float, hy: float, refl: list[Reflector], view: DeviceView) -> float:
    """The full (x, y, heading) range-bearing least squares written out: sqrt(trace of the
    position block of (H^T W H)^-1) / sigma_r."""
    rows, weights = [], []
    for r in refl:
        dx, dy = r.x - hx, r.y - hy
        d = math.hypot(dx, dy)
        rows.append([-dx / d, -dy / d, 0.0])
        weights.append(1 / view.sigma_range_m ** 2)
        rows.append([dy / d ** 2, -dx / d ** 2, -1.0])
        weights.append(1 / view.sigma_bearing_rad ** 2)
    h = np.array(rows)
    info = h.T @ np.diag(weights) @ h
    cov = np.linalg.inv(info)
    return math.sqrt(cov[0, 0] + cov[1, 1]) / view.sigma_range_m


def test_gdop_closed_form_four_round() -> None:
    # four reflectors at 10 m east, north, west and south: M = 2 (1 + k / r^2) I with
    # k = (sigma_r / sigma_b)^2, so GDOP = sqrt(1 / (1 + k / r^2))
    refl = [Reflector(id=i, x=10 * math.cos(a), y=10 * math.sin(a))
            for i, a in enumerate((0.0, math.pi / 2, math.pi, -math.pi / 2))]
    k = (VIEW.sigma_range_m / VIEW.sigma_bearing_rad) ** 2
    want = math.sqrt(1 / (1 + k / 100))
    got = gdop(np.zeros(1), np.zeros(1), np.ones((1, 4), dtype=bool), refl, VIEW)
    assert got[0] == pytest.approx(want, rel=1e-9)
    assert want == pytest.approx(0.503, abs=0.002)


def test_gdop_against_least_squares() -> None:
    rng = np.random.default_rng(7)
    refl = [Reflector(id=i, x=float(x), y=float(y)) for i, (x, y) in
            enumerate(zip(rng.uniform(0, 30, 15), rng.uniform(0, 20, 15), strict=True))]
    hx, hy = rng.uniform(2, 28, 50), rng.uniform(2, 18, 50)
    vis = rng.random((50, 15)) < 0.4
    vis[:, :2] = True  # at least two each
    got = gdop(hx, hy, vis, refl, VIEW)
    for i in range(50):
        chosen = [r for r, v in zip(refl, vis[i], strict=True) if v]
        assert got[i] == pytest.approx(_gdop_brute(float(hx[i]), float(hy[i]), chosen, VIEW),
                                       rel=1e-6)


def test_gdop_infinite_below_two() -> None:
    refl = [Reflector(id=1, x=5.0, y=0.0), Reflector(id=2, x=0.0, y=7.0)]
    vis = np.array([[False, False], [True, False], [True, True]])
    got = gdop(np.zeros(3), np.zeros(3), vis, refl, VIEW)
    assert math.isinf(got[0]) and math.isinf(got[1]) and math.isfinite(got[2])


def test_poor_segments() -> None:
    t = np.array([0.0, 1, 2, 3, 4, 10, 11, 12, 13])
    poor = np.array([False, True, True, False, True, True, True, False, True])
    segs = poor_segments(t, poor, gap_s=2.0)
    # 1-2 (ends at 3, the next good pose), 4 alone (the pause to 10 ends it there),
    # 10-11 (ends at 12), 13 (the end of the drive)
    assert [(s.first, s.last, s.start_s, s.end_s) for s in segs] == [
        (1, 2, 1.0, 3.0), (4, 4, 4.0, 4.0), (5, 6, 10.0, 12.0), (8, 8, 13.0, 13.0)]
    assert poor_segments(t, np.zeros(9, dtype=bool), 2.0) == []


def _corridor() -> tuple[list[Reflector], HeadTrack]:
    # a 40 m corridor along x: reflectors every 4 m on both walls from x = 0 to 16, then a
    # stretch with nothing, then again from 28 m; range 8 m (so at x = 22 nothing is seen)
    refl = [Reflector(id=100 + i, x=float(x), y=float(y)) for i, (x, y) in enumerate(
        [(x, w) for x in (0, 4, 8, 12, 16, 28, 32, 36, 40) for w in (-2.0, 2.0)])]
    t = np.arange(0.0, 40.0, 0.1)
    x = t.copy()  # 1 m/s along the axis
    return refl, HeadTrack.of(t, x, np.zeros_like(x), np.zeros_like(x), source="laser")


def test_coverage_section_finds_the_gap() -> None:
    refl, track = _corridor()
    view = DeviceView.for_family("nav350", {"range_max_m": 8.0})
    settings = CoverageSettings(cell_m=2.0, gdop_max=2.0)
    # the device reports 4 everywhere, but 0 between 19 and 25 s
    used = np.where((track.t > 19) & (track.t < 25), 0, 4)
    track = HeadTrack.of(track.t, track.x, track.y, track.heading, "laser", "corridor",
                         track.t + 0.01, used)
    sec = coverage_section(track, refl, view, settings)
    json.dumps(sec, allow_nan=False)  # plain JSON, no NaN or infinity
    assert sec["source"] == "laser" and sec["poses"] == 400
    assert sec["distance_m"] == pytest.approx(39.9, abs=1e-6)
    # in range (8 m) of a wall pair at x0 while |x - x0| <= sqrt(64 - 4) = 7.746 m: only the
    # pair at x = 16 between 19.75 and 20.25 m, only the pair at 28 between 23.75 and 24.25 m
    # (2 visible: fewer than 3); 4 or more everywhere else
    assert sec["segments_total"] == 2
    segs = [_obj(g) for g in _list(sec["segments"])]
    starts = sorted(_float(g["start_s"]) for g in segs)
    assert starts == pytest.approx([19.8, 23.8], abs=1e-6)
    for seg in segs:
        assert seg["duration_s"] == pytest.approx(0.5, abs=1e-6)
        assert seg["length_m"] == pytest.approx(0.5, abs=1e-6)
        assert seg["visible_min"] == 2
        assert seg["reasons"] == ["fewer than 3 visible"]
        assert seg["reported_used_min"] == 0
        assert seg["log"] == "corridor"
    vis = expected_visibility(track.x, track.y, track.heading, refl, view).sum(axis=1)
    assert int((vis < 3).sum()) == 10
    assert sec["below_min_fraction"] == pytest.approx(10 / 400, abs=1e-4)
    assert sec["poor_time_s"] == pytest.approx(1.0, abs=1e-6)
    rep = sec["reported_used"]
    assert isinstance(rep, dict) and rep["poses"] == 400
    assert rep["median"] == pytest.approx(4.0, abs=1e-9)
    grid = sec["grid"]
    assert isinstance(grid, dict)
    assert (grid["nx"], grid["ny"], grid["cell_m"]) == (21, 3, 2.0)
    assert grid["x0_m"] == pytest.approx(0.0, abs=1e-9)
    assert grid["y0_m"] == pytest.approx(-2.0, abs=1e-9)
    poses = [_list(r) for r in _list(grid["poses"])]
    assert sum(_float(p) for r in poses for p in r) == 400
    # the drive runs along y = 0: row 1; cell x in [18, 20) holds 20 poses, the fewest seen 2
    vmin = [_list(r) for r in _list(grid["visible_min"])]
    assert poses[1][9] == 20
    assert vmin[1][9] == 2 == int(vis[(track.x >= 18) & (track.x < 20)].min())
    assert vmin[1][8] == int(vis[(track.x >= 16) & (track.x < 18)].min()) == 4
    assert vmin[0][9] is None  # no pose in the cell


def test_reported_needs_a_close_pose() -> None:
    refl, track = _corridor()
    # device poses only in the first 10 s: the rest of the drive has no reported count
    rt = np.arange(0.0, 10.0, 0.125)
    track = HeadTrack.of(track.t, track.x, track.y, track.heading, reported_t=rt,
                         reported_used=np.full(len(rt), 5))
    cov = coverage_at_poses(track, refl, VIEW, CoverageSettings())
    assert (cov.reported[track.t <= 10.0] == 5).all()
    assert (cov.reported[track.t > 10.5] == -1).all()


def test_blocks_match_whole(monkeypatch: pytest.MonkeyPatch) -> None:
    from lgvtool.audit import visibility

    refl, track = _corridor()
    whole = coverage_at_poses(track, refl, VIEW)
    monkeypatch.setattr(visibility, "PAIR_BUDGET", 18 * 18 * 13)
    parts = coverage_at_poses(track, refl, VIEW)
    assert (parts.visible == whole.visible).all()
    np.testing.assert_allclose(parts.gdop, whole.gdop, rtol=1e-12)


def test_empty_track() -> None:
    refl, _ = _corridor()
    sec = coverage_section(HeadTrack.of([], [], [], []), refl, VIEW)
    json.dumps(sec, allow_nan=False)
    assert sec["poses"] == 0 and sec["segments"] == []


def test_several_drives_pool() -> None:
    refl, track = _corridor()
    view = DeviceView.for_family("nav350", {"range_max_m": 8.0})
    a = HeadTrack.of(track.t, track.x, track.y, track.heading, "laser", "first")
    half = track.t < 20.0  # the second drive stops before the gap
    b = HeadTrack.of(track.t[half], track.x[half], track.y[half], track.heading[half], "laser",
                     "second")
    one = coverage_section(a, refl, view)
    both = coverage_section([a, b], refl, view)
    assert both["logs"] == ["first", "second"] and both["source"] == "laser"
    assert both["poses"] == 400 + 200
    assert _float(both["distance_m"]) == pytest.approx(39.9 + 19.9, abs=1e-6)
    # the second drive reaches the first poor stretch (19.8 s on) for 0.2 s: one segment more,
    # named by its log
    assert both["segments_total"] == _float(one["segments_total"]) + 1
    logs = sorted(str(_obj(g)["log"]) for g in _list(both["segments"]))
    assert logs == ["first", "first", "second"]
    pooled = [_list(r) for r in _list(_obj(both["grid"])["poses"])]
    single = [_list(r) for r in _list(_obj(one["grid"])["poses"])]
    assert pooled[1][0] == 2 * _float(single[1][0])  # both drives crossed the first cell


def test_on_a_simulated_nav350_log(tmp_path: Path) -> None:
    # the device's poses of a short NAV350 log, with the count each reports using (read by
    # load_log as nav["used"]), against the log's own layout
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader

    log = tmp_path / "nav350.mcap"
    subprocess.run([sys.executable, "-m", "lgvtool", "simulate", "--scenario", "warehouse",
                    "--duration", "20", "--seed", "3", "--set", "sim.nav_device=nav350",
                    "-o", str(log)], check=True, capture_output=True)
    data = load_log(LogReader(log))
    nav = data.nav
    assert nav is not None and nav["used"].dtype == np.int64
    ok = nav["valid"]
    assert int(ok.sum()) > 100 and (nav["used"][ok] >= 3).all()
    track = HeadTrack.of(nav["t"][ok], nav["x"][ok], nav["y"][ok], nav["heading"][ok],
                         reported_t=nav["t"], reported_used=nav["used"])
    sec = coverage_section(track, data.reflectors,
                           DeviceView.for_family("nav350", {"range_max_m": 28.0}))
    rep = _obj(sec["reported_used"])
    assert rep["poses"] == int(ok.sum())  # every pose is its own device pose
    # the device uses at most what the layout lets it see
    assert _float(rep["mean_visible_minus_used"]) >= 0.0
    assert _float(_obj(sec["visible"])["min"]) >= 3


def test_missing_reflectors_are_left_out() -> None:
    refl, track = _corridor()
    view = DeviceView.for_family("nav350", {"range_max_m": 8.0})
    s = CoverageSettings()
    covs = [coverage_at_poses(track, refl, view, s)]
    full = section_from([track], covs, refl, view, s)
    # the pair at x = 16 found missing: poor from 15.75 m (only the pair at 12 left in range),
    # with nothing in range between 19.75 and 20.25 m, to 24.25 m (only the pair at 28 until
    # the pair at 32 comes in): 8.5 s poor instead of 1 s; the GDOP's median cannot fall
    less = section_from([track], covs, refl, view, s, missing=[108, 109, 999])
    assert full["excluded_ids"] == [] and less["excluded_ids"] == [108, 109]
    assert _float(less["poor_time_s"]) == pytest.approx(8.5, abs=0.11)
    assert _float(full["poor_time_s"]) == pytest.approx(1.0, abs=1e-6)
    assert _float(_obj(less["visible"])["min"]) == 0  # nothing within 8 m about x = 20
    assert _float(_obj(less["gdop"])["median"]) >= _float(_obj(full["gdop"])["median"])


def test_track_drops_bad_poses_and_grid_stays_bounded() -> None:
    refl, track = _corridor()
    x = track.x.copy()
    x[5] = np.nan
    y = track.y.copy()
    x[7] = y[7] = 3000.0  # a pose 3 km off: the grid's cells grow, their count stays bounded
    bad = HeadTrack.of(track.t, x, y, track.heading)
    assert len(bad) == len(track) - 1
    sec = coverage_section(bad, refl, VIEW)
    json.dumps(sec, allow_nan=False)
    grid = _obj(sec["grid"])
    nx, ny = grid["nx"], grid["ny"]
    assert isinstance(nx, int) and isinstance(ny, int)
    assert nx * ny <= 40_000
    # 1 m doubled 4 times: 3001 m / 16 m = 188 cells a side, 35 344 in all
    assert _float(grid["cell_m"]) == pytest.approx(16.0, abs=1e-9)
    assert sum(_float(p) for r in _list(grid["poses"]) for p in _list(r)) == len(bad)
