"""The navigation-health section of ``lgvtool audit``: dropouts against the simulator's injected
faults and its site-caused losses, a pose jump, the clock figures, and the section's keys."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.audit.navigation_health import (
    NavigationHealth,
    NavigationSettings,
    NavStatus,
    NavStatusTap,
    navigation_health,
    odometry_path,
)
from lgvtool.trajectory import Trajectory
from tests.inprocess import run_command
from tests.simlogs import simulate_log

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evaluate"))
from test_report_browser import _check_page, browser, render

__all__ = ["browser"]  # the fixture, used by name

POLL_PERIOD_S = 0.45
"""The simulated NAV200's poll period (the simulator's nav.poll_period_s), s."""


def _read(path: Path, settings: NavigationSettings | None = None
          ) -> tuple[NavStatus, NavigationHealth, list[tuple[float, str]]]:
    """A log's pose replies, its navigation health (placed on the device's own poses) and its
    simulator fault events (s on the same clock, kind)."""
    from lgvtool.localize.logdata import load_log
    from lgvtool.localize.motion import MotionSettings
    from lgvtool.log import LogReader

    reader = LogReader(path)
    cfg = reader.config()
    tap = NavStatusTap()
    data = load_log(reader, cfg.reflectors, tap=tap)
    st = tap.status(data.t0_ns)
    inc = data.increments(MotionSettings(), cfg.vehicle)
    ok = st.navigating
    health = navigation_health(
        st, track=st.pose.select(ok), odometry=odometry_path(inc.t, inc.ds, inc.dth),
        nav_offset=(cfg.vehicle.nav_x, cfg.vehicle.nav_y),
        settings=settings or NavigationSettings())
    events = []
    for m in reader.raw_messages(["/diagnostics"]):
        d = json.loads(m.data)
        if d.get("source") == "simulator":
            ts = d["timestamp"]
            events.append(((ts["sec"] * 1_000_000_000 + ts["nsec"] - data.t0_ns) * 1e-9,
                           str(d["kind"])))
    return st, health, events


def _runs(times: list[float]) -> list[float]:
    """The first time of each run of consecutive polls among ``times`` (s)."""
    firsts: list[float] = []
    last = -np.inf
    for t in sorted(times):
        if t - last > 1.5 * POLL_PERIOD_S:
            firsts.append(t)
        last = t
    return firsts


@pytest.fixture(scope="module")
def invalid_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """40 s of a NAV200 recording whose device replies 'no valid position' to 15 % of polls."""
    return simulate_log(tmp_path_factory.mktemp("nav") / "invalid.mcap", 40.0, 5,
                        paper_scans=False, sets=["faults.nav_invalid_rate=0.15"])


def test_dropouts_equal_the_injected_no_position_replies(invalid_log: Path) -> None:
    _, health, events = _read(invalid_log)
    injected = _runs([t for t, kind in events if kind == "nav_no_position"])
    assert len(injected) >= 3  # the seed injects several
    assert len(health.dropouts) == len(injected)
    for d, t in zip(health.dropouts, injected, strict=True):
        assert abs(d.start - t) < POLL_PERIOD_S
        assert d.cause == "no_position"
        assert d.duration >= 0.9 * POLL_PERIOD_S
        assert np.isfinite(d.x) and np.isfinite(d.y)
    assert health.period_s == pytest.approx(POLL_PERIOD_S, abs=0.01)
    lost = sum(d.duration for d in health.dropouts)
    assert health.share_in_navigation == pytest.approx(1.0 - lost / health.span_s, abs=1e-9)


def test_dropouts_equal_the_injected_error_replies(tmp_path: Path) -> None:
    """A NAV200 that answers 15 % of its polls with an error reply (function E, not on
    /nav/pose): each such dropout is found from /diagnostics and called an error."""
    log = simulate_log(tmp_path / "errors.mcap", 40.0, 5, paper_scans=False,
                       sets=["faults.nav_error_rate=0.15"])
    st, health, events = _read(log)
    injected = _runs([t for t, kind in events if kind == "nav_error_reply"])
    assert len(injected) >= 3
    assert len(st.device_errors) == sum(kind == "nav_error_reply" for _, kind in events)
    assert [d.cause for d in health.dropouts] == ["error"] * len(injected)
    for d, t in zip(health.dropouts, injected, strict=True):
        assert abs(d.start - t) < POLL_PERIOD_S
    assert health.errors == len(st.device_errors)


def test_replies_that_stop_before_the_log_ends_are_a_dropout() -> None:
    """The NAV's last valid reply at 2.25 s, the motion data going on to 4 s: a dropout from
    when the next reply was due to the log's end, none when the motion ends with the replies;
    an error reply between two valid poses makes its dropout an error."""
    t = np.array([0.0, 0.45, 0.9, 1.35, 1.8, 2.25])
    motion = np.arange(0.0, 4.001, 0.1)
    odometry = odometry_path(motion, np.zeros(len(motion) - 1), np.zeros(len(motion) - 1))
    h = navigation_health(_status(t), track=None, odometry=odometry, nav_offset=(0.0, 0.0),
                          settings=NavigationSettings())
    (d,) = h.dropouts
    assert d.cause == "no_reply"
    assert d.start == pytest.approx(2.7, abs=1e-9)
    assert d.duration == pytest.approx(4.0 - 2.7, abs=1e-9)
    assert h.span_s == pytest.approx(4.0, abs=1e-9)
    assert h.share_in_navigation == pytest.approx(1.0 - 1.3 / 4.0, abs=1e-9)
    short = odometry_path(motion[:24], np.zeros(23), np.zeros(23))  # ends at 2.3 s
    assert navigation_health(_status(t), track=None, odometry=short, nav_offset=(0.0, 0.0),
                             settings=NavigationSettings()).dropouts == ()
    gap = np.delete(t, 3)  # the poll at 1.35 s answered with an error reply at 1.36 s
    err = replace(_status(gap), device_errors=np.array([1.36]))
    (e,) = navigation_health(err, track=None, odometry=None, nav_offset=(0.0, 0.0),
                             settings=NavigationSettings()).dropouts
    assert e.cause == "error" and e.replies == 0
    assert e.start == pytest.approx(1.35, abs=1e-9)


def test_site_losses_are_found_as_too_few_reflectors(tmp_path: Path) -> None:
    """With the reflectors detected only up to 5 m, the simulated NAV loses its position where
    fewer than three are in range: no fault injected, the device reports it."""
    log = simulate_log(tmp_path / "short_range.mcap", 20.0, 3, paper_scans=False,
                       sets=["nav.detection_range_m=5"])
    _, health, events = _read(log)
    assert not [k for _, k in events if k.startswith("nav_")]
    assert health.dropouts
    assert {d.cause for d in health.dropouts} == {"few_reflectors"}
    assert all(0 <= d.used_min < 3 for d in health.dropouts)
    assert health.navigating < health.replies


def test_a_pose_jump_is_found(tmp_path: Path) -> None:
    """A clean drive has no jump; the same drive with its NAV poses from one reply on moved by
    0.4 m (a relocalisation onto a wrong solution) has exactly that one."""
    log = simulate_log(tmp_path / "clean.mcap", 20.0, 7, paper_scans=False)
    st, health, _ = _read(log)
    assert health.jumps == ()
    assert health.step_difference_m[-1] < NavigationSettings().jump_m
    k = len(st.t) // 2
    moved = replace(st, pose=replace(st.pose, x=np.where(np.arange(len(st.t)) >= k,
                                                          st.x + 0.4, st.x)))
    from lgvtool.localize.logdata import load_log
    from lgvtool.localize.motion import MotionSettings
    from lgvtool.log import LogReader

    reader = LogReader(log)
    cfg = reader.config()
    data = load_log(reader, cfg.reflectors)
    inc = data.increments(MotionSettings(), cfg.vehicle)
    found = navigation_health(moved, track=None, odometry=odometry_path(inc.t, inc.ds, inc.dth),
                              nav_offset=(cfg.vehicle.nav_x, cfg.vehicle.nav_y),
                              settings=NavigationSettings())
    assert len(found.jumps) == 1
    jump = found.jumps[0]
    assert jump.t == pytest.approx(float(st.t[k]), abs=1e-9)
    assert jump.jump_m == pytest.approx(0.4, abs=0.15)


def _status(t: np.ndarray, *, valid: np.ndarray | None = None,
            error: np.ndarray | None = None, ticks: np.ndarray | None = None) -> NavStatus:
    n = len(t)
    z = np.zeros(n)
    return NavStatus(
        pose=Trajectory(t, z, z, z), valid=np.ones(n, bool) if valid is None else valid,
        quality=np.zeros(n, np.int64), used=np.full(n, 5, np.int64),
        error_code=np.zeros(n, np.int64) if error is None else error,
        mean_dev=np.full(n, 20.0), nav_mode=np.full(n, 4, np.int64),
        info_state=np.zeros(n, np.int64),
        device_ms=np.full(n, -1, np.int64) if ticks is None else ticks,
        device_stamp=np.full(n, np.nan))


def test_error_replies_missing_replies_and_the_clock() -> None:
    """A NAV350-like stream at 8 Hz: an error reply, two replies missing, the log ending in an
    error; the device tick wraps once and jumps by 0.5 s once."""
    t = np.arange(0.0, 10.0, 0.125)
    keep = np.ones(len(t), bool)
    keep[[30, 31]] = False  # no reply at all
    t = t[keep]
    error = np.zeros(len(t), np.int64)
    error[10] = 4
    error[-1] = 4
    ticks = (np.round(t * 1000).astype(np.int64) + 2**32 - 3000) % 2**32
    ticks[50:] = (ticks[50:] + 500) % 2**32
    h = navigation_health(_status(t, error=error, ticks=ticks), track=None, odometry=None,
                          nav_offset=(0.0, 0.0), settings=NavigationSettings())
    assert [d.cause for d in h.dropouts] == ["error", "no_reply", "error"]
    assert h.dropouts[0].start == pytest.approx(t[10], abs=1e-9)
    assert h.dropouts[0].duration == pytest.approx(0.125, abs=1e-9)
    assert h.dropouts[1].start == pytest.approx(t[29] + 0.125, abs=1e-9)
    assert h.dropouts[1].duration == pytest.approx(0.25, abs=1e-9)
    assert h.dropouts[2].duration == pytest.approx(0.125, abs=1e-9)
    assert h.errors == 2
    assert len(h.clock_jumps) == 1
    assert h.clock_jumps[0][0] == pytest.approx(t[50], abs=1e-9)
    assert h.clock_jumps[0][1] == pytest.approx(0.5, abs=1e-6)
    assert abs(h.clock_drift_ppm) < 1.0
    assert h.mean_dev[0] == pytest.approx(20.0, abs=1e-9)
    assert h.jumps == ()


def test_a_lost_reply_before_an_invalid_one_starts_the_dropout() -> None:
    """A NAV200 polled every 0.45 s: a reply lost, then a 'no position' one: one dropout from
    when the lost reply was due."""
    t = np.array([0.0, 0.45, 1.35, 1.8, 2.25])
    valid = np.array([True, True, False, True, True])
    h = navigation_health(_status(t, valid=valid), track=Trajectory(t, t * 2.0, t * 0, t * 0),
                          odometry=None,
                          nav_offset=(0.0, 0.0), settings=NavigationSettings())
    (d,) = h.dropouts
    assert d.start == pytest.approx(0.9, abs=1e-9)
    assert d.duration == pytest.approx(0.9, abs=1e-9)
    assert d.cause == "no_position" and d.replies == 1
    assert d.x == pytest.approx(1.8, abs=1e-9)
    assert h.share_in_navigation == pytest.approx(1.0 - 0.9 / 2.25, abs=1e-9)


def test_audit_json_summary_and_report(invalid_log: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "audit"
    code, stdout, err = run_command(capsys, "audit", invalid_log, "-o", out, "--no-progress")
    assert code == 0, err
    doc: dict[str, Any] = json.loads((out / "audit.json").read_text(encoding="utf-8"))
    nav = doc["navigation"]
    assert set(nav) == {"share_in_navigation", "dropouts", "dropout_causes", "dropout_time_s",
                        "pose_jumps", "clock_jumps", "logs", "without_poses", "settings"}
    (log,) = nav["logs"]
    assert set(log) == {"path", "device", "period_s", "span_s", "replies", "navigating",
                        "error_replies", "share_in_navigation", "dropouts", "dropout_time_s",
                        "reflectors_used", "mean_dev", "nav_mode", "info_state",
                        "step_difference_m", "pose_jumps", "latency_s", "clock_jumps",
                        "clock_drift_ppm", "vda5050"}
    drops = log["dropouts"]
    assert drops
    assert set(drops[0]) == {"start_s", "duration_s", "x", "y", "cause", "replies",
                             "reflectors_used_min"}
    assert nav["dropouts"] == len(drops)
    assert set(log["vda5050"]) == {"positionInitialized_share", "localizationScore",
                                   "deviationRange_m"}
    assert log["mean_dev"] is None and log["latency_s"] is None  # a NAV200 has neither
    assert any(line.startswith("navigation: ") for line in stdout.splitlines())
    page = (out / "report.html").read_text(encoding="utf-8")
    assert 'data-section="navigation"' in page
    assert 'data-figure="navigation-timeline"' in page
    assert 'data-table="dropouts"' in page


@pytest.mark.parametrize("width", (1400, 420))
def test_the_timeline_renders_in_chromium(browser: str, invalid_log: Path, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str],
                                          width: int) -> None:
    out = tmp_path / "audit"
    code, _, err = run_command(capsys, "audit", invalid_log, "-o", out, "--no-progress")
    assert code == 0, err
    m = render(browser, out / "report.html", width)
    _check_page(m, width)
    assert "navigation-timeline" in [f["slug"] for f in m["figures"]]


def test_a_bad_navigation_setting_is_one_line(invalid_log: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_command(capsys, "audit", invalid_log, "-o", tmp_path / "a",
                               "--set", "navigation.jump_m=-1")
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "navigation.jump_m" in err


def test_the_docs_list_every_setting_as_declared() -> None:
    from lgvtool.declared import markdown_table

    doc = (Path(__file__).resolve().parents[2] / "docs" / "audit.md").read_text(encoding="utf-8")
    assert markdown_table(NavigationSettings, "navigation.") in doc, (
        "docs/audit.md: the navigation thresholds' table differs from navigation_health.py")
