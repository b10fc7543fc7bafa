"""The error-by-segment section of ``lgvtool audit``: a known along-track bias given back in
``along`` and not in ``cross``, reverse driving classified, the bins adding up to the poses on
a simulated warehouse log, pooling by sums, the reference said everywhere, and the keys."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.audit.segment_errors import (
    DIMENSIONS,
    SegmentErrors,
    SegmentSettings,
    bin_labels,
    log_segments,
    segment_errors,
    segments_section,
    summary_line,
)
from lgvtool.trajectory import Trajectory
from tests.inprocess import run_command
from tests.simlogs import simulate_log

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "evaluate"))
from test_report_browser import _check_page, browser, render

__all__ = ["browser"]  # the fixture, used by name

TOL_M = 1e-6
"""Tolerance of errors that the construction makes exact but for interpolation rounding, m."""


def _drive(speed: float = 0.8, radius: float = 5.0, dt: float = 0.02) -> Trajectory:
    """10 s straight along +x at ``speed`` m/s, then 10 s on a left circle of ``radius`` m;
    heading along the velocity (forward)."""
    t = np.arange(0.0, 20.0 + dt / 2, dt)
    x = np.where(t <= 10.0, speed * t, 0.0)
    y = np.zeros(len(t))
    th = np.zeros(len(t))
    arc = t > 10.0
    phi = speed * (t[arc] - 10.0) / radius
    x[arc] = 10.0 * speed + radius * np.sin(phi)
    y[arc] = radius * (1.0 - np.cos(phi))
    th[arc] = phi
    return Trajectory(t, x, y, th)


def _shifted(ref: Trajectory, ahead: float, left: float = 0.0, dth: float = 0.0,
             every: int = 5) -> Trajectory:
    """Every ``every``-th pose of ``ref`` moved ``ahead`` m along its heading, ``left`` m to its
    left, and turned by ``dth`` rad."""
    r = ref.select(np.arange(0, len(ref), every))
    c, s = np.cos(r.heading), np.sin(r.heading)
    return Trajectory(r.t, r.x + ahead * c - left * s, r.y + ahead * s + left * c,
                      r.heading + dth)


def test_a_known_along_track_bias_is_given_back_in_along_not_cross() -> None:
    ref = _drive()
    est = _shifted(ref, ahead=0.05, dth=0.01)
    e = segment_errors(est, ref, source="ekf", reference_name="truth",
                       settings=SegmentSettings())
    assert e is not None and e.reference == "truth"
    for dim in DIMENSIONS:
        b = e.bins[dim]
        used = b.n > 0
        assert np.allclose(b.mean()[used, 0], 0.05, atol=TOL_M)
        assert np.allclose(b.rms()[used, 0], 0.05, atol=TOL_M)
        assert np.allclose(b.mean()[used, 1], 0.0, atol=TOL_M)
        assert np.allclose(b.rms()[used, 1], 0.0, atol=TOL_M)
        assert np.allclose(b.mean()[used, 2], 0.01, atol=1e-9)
    shape = dict(zip(bin_labels("shape", SegmentSettings()), e.bins["shape"].n, strict=True))
    # the arc's curvature 0.2 1/m is a turn; the straight is straight (a window's worth of
    # poses around the corner may fall either way)
    assert shape["straight"] >= 90 and shape["turn"] >= 90 and shape["standstill"] == 0
    curv = e.bins["curvature"]
    labels = bin_labels("curvature", SegmentSettings())
    assert int(curv.n[labels.index("0.00-0.25")]) == e.poses  # 0 and 0.2 1/m
    speed = dict(zip(bin_labels("speed", SegmentSettings()), e.bins["speed"].n, strict=True))
    assert speed["0.75-1.00"] == e.poses


def test_a_cross_track_offset_stays_in_cross() -> None:
    ref = _drive()
    e = segment_errors(_shifted(ref, ahead=0.0, left=-0.02), ref, source="laser",
                       reference_name="truth", settings=SegmentSettings())
    assert e is not None
    b = e.bins["direction"]
    assert b.mean()[0, 0] == pytest.approx(0.0, abs=TOL_M)
    assert b.mean()[0, 1] == pytest.approx(-0.02, abs=TOL_M)


def test_reverse_driving_is_classified_and_along_is_along_the_travel() -> None:
    """Reversing along -x with the heading 0: the direction of travel is -x, so an estimate
    0.03 m further along -x is 0.03 m ahead."""
    t = np.arange(0.0, 10.0, 0.02)
    ref = Trajectory(t, -0.5 * t, np.zeros(len(t)), np.zeros(len(t)))
    r = ref.select(np.arange(0, len(ref), 4))
    est = Trajectory(r.t, r.x - 0.03, r.y + 0.01, r.heading)
    e = segment_errors(est, ref, source="ekf", reference_name="truth",
                       settings=SegmentSettings())
    assert e is not None
    direction = dict(zip(bin_labels("direction", SegmentSettings()), e.bins["direction"].n,
                         strict=True))
    assert direction == {"forward": 0, "reverse": len(est), "standstill": 0}
    m = e.bins["direction"].mean()[1]
    assert m[0] == pytest.approx(0.03, abs=TOL_M)
    assert m[1] == pytest.approx(-0.01, abs=TOL_M)  # left of the travel is -y
    shape = e.bins["shape"].n
    assert int(shape[0]) == len(est)  # straight


def test_a_standstill_is_neither_forward_nor_reverse() -> None:
    t = np.arange(0.0, 5.0, 0.1)
    ref = Trajectory(t, np.full(len(t), 2.0), np.ones(len(t)), np.full(len(t), 0.3))
    e = segment_errors(ref, ref, source="ekf", reference_name="truth",
                       settings=SegmentSettings())
    assert e is not None
    for dim in ("direction", "shape", "curvature"):
        assert int(e.bins[dim].n[-1]) == len(t)  # the standstill bin


def test_pooling_adds_the_sums() -> None:
    ref = _drive()
    s = SegmentSettings()
    a = segment_errors(_shifted(ref, 0.04), ref, source="ekf", reference_name="truth",
                       settings=s)
    b = segment_errors(_shifted(ref, 0.01, every=10), ref, source="ekf",
                       reference_name="truth", settings=s)
    assert a is not None and b is not None
    sec = segments_section([a, b], [], s)
    sources = sec["sources"]
    assert isinstance(sources, list) and len(sources) == 1
    src = sources[0]
    assert isinstance(src, dict)
    assert src["poses"] == a.poses + b.poses
    overall = src["overall"]
    assert isinstance(overall, dict)
    along = overall["along"]
    assert isinstance(along, dict)
    expected = (0.04 * a.poses + 0.01 * b.poses) / (a.poses + b.poses)
    assert along["mean"] == pytest.approx(expected, abs=1e-5)
    rms = math.sqrt((0.04**2 * a.poses + 0.01**2 * b.poses) / (a.poses + b.poses))
    assert along["rms"] == pytest.approx(rms, abs=1e-5)
    with pytest.raises(ValueError):
        a.merged(SegmentErrors("laser", "truth", a.bins))


def test_without_truth_the_laser_is_compared_with_the_estimator() -> None:
    ref = _drive()
    laser = _shifted(ref, -0.06, every=20)
    (only,) = log_segments(ref, "ekf", laser, None, SegmentSettings())
    assert (only.source, only.reference) == ("laser", "ekf")
    assert only.bins["direction"].mean()[0, 0] == pytest.approx(-0.06, abs=TOL_M)
    both = log_segments(_shifted(ref, 0.0, every=2), "ekf", laser, ref, SegmentSettings())
    assert [(e.source, e.reference) for e in both] == [("ekf", "truth"), ("laser", "truth")]
    assert log_segments(laser, "laser", laser, None, SegmentSettings()) == ()
    sec = segments_section(list(log_segments(ref, "ekf", laser, None, SegmentSettings())),
                           ["b.mcap"], SegmentSettings())
    assert sec["reference"] == "ekf" and sec["without_reference"] == ["b.mcap"]
    line = summary_line(sec)
    assert line is not None and "laser vs ekf" in line


@pytest.fixture(scope="module")
def warehouse_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A short simulated warehouse drive (NAV200 poses, odometry, truth; it reverses)."""
    return simulate_log(tmp_path_factory.mktemp("seg") / "warehouse.mcap", 40.0, 2,
                        scenario="warehouse", paper_scans=False)


def test_the_bins_add_up_to_the_poses_of_a_simulated_log(warehouse_log: Path) -> None:
    from lgvtool.audit.log_audit import LogAuditOptions, log_evidence
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader

    ev = log_evidence(str(warehouse_log), LogAuditOptions())
    assert [(e.source, e.reference) for e in ev.segments] == [(ev.estimator, "truth"),
                                                              ("laser", "truth")]
    reader = LogReader(warehouse_log)
    data = load_log(reader, reader.config().reflectors, truth=True)
    assert data.truth is not None and data.nav is not None
    span = (data.truth.t[0], data.truth.t[-1])
    est_t = ev.track.t
    nav_t = data.nav["t"][data.nav["valid"]]
    expected = {ev.estimator: int(np.count_nonzero((est_t >= span[0]) & (est_t <= span[1]))),
                "laser": int(np.count_nonzero((nav_t >= span[0]) & (nav_t <= span[1])))}
    for e in ev.segments:
        assert e.poses == expected[e.source] > 20
        for dim in DIMENSIONS:
            assert int(e.bins[dim].n.sum()) == e.poses
    laser = ev.segments[1].bins["direction"].n
    assert int(laser[0]) > 0 and int(laser[1]) > 0  # the drive goes forward and in reverse


def test_audit_json_summary_and_report(warehouse_log: Path, tmp_path: Path,
                                       capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "audit"
    code, stdout, err = run_command(capsys, "audit", warehouse_log, "-o", out, "--no-progress",
                                    "--set", "segments.speed_bins=4")
    assert code == 0, err
    doc: dict[str, Any] = json.loads((out / "audit.json").read_text(encoding="utf-8"))
    seg = doc["segments"]
    assert set(seg) == {"reference", "frame", "units", "sources", "without_reference",
                        "settings"}
    assert seg["reference"] == "truth" and seg["settings"]["speed_bins"] == 4
    for src in seg["sources"]:
        assert set(src) == {"source", "reference", "poses", "overall", *DIMENSIONS}
        assert src["reference"] == "truth"
        assert len(src["speed"]) == 4
        for b in src["speed"]:
            assert set(b) == {"bin", "count", "along", "cross", "heading"}
            assert set(b["along"]) == {"rms", "mean"}
        assert sum(b["count"] for b in src["shape"]) == src["poses"]
    assert any(line.startswith("error by segment: ") for line in stdout.splitlines())
    page = (out / "report.html").read_text(encoding="utf-8")
    assert 'data-section="segments"' in page
    assert "Error by segment (against the truth)" in page
    assert 'data-figure="segments-speed"' in page
    assert 'data-table="segment-errors"' in page


@pytest.mark.parametrize("width", (1400, 420))
def test_the_segments_figure_renders_in_chromium(browser: str, warehouse_log: Path,
                                                 tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str],
                                                 width: int) -> None:
    out = tmp_path / "audit"
    code, _, err = run_command(capsys, "audit", warehouse_log, "-o", out, "--no-progress")
    assert code == 0, err
    m = render(browser, out / "report.html", width)
    _check_page(m, width)
    assert "segments-speed" in [f["slug"] for f in m["figures"]]


def test_a_bad_segments_setting_is_one_line(warehouse_log: Path, tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_command(capsys, "audit", warehouse_log, "-o", tmp_path / "a",
                               "--no-progress", "--set", "segments.speed_bins=0")
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "speed_bins" in err
