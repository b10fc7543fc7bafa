"""``lgvtool audit``: every flag found on one small simulated NAV350 site whose faults the
simulator knows, the keys of ``audit.json``, the NAV200 line, and bad input (one line, exit 2).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from inprocess import run_command
from simlogs import simulate_log, write_topic_log

from lgvtool.app.audit_job import AuditOptions, AuditRun, audit_logs
from lgvtool.audit.audit_moments import Moments
from lgvtool.audit.audit_settings import AuditSettings
from lgvtool.audit.unmapped_objects import listed_objects, pooled_unmapped, unmapped_evidence
from lgvtool.config import paper_hall_reflectors

MOVED, MOVE = 3, (0.06, -0.03)
MISSING = 13
WEAK = 9
EXTRA = (16.0, 19.95)
PAIR = (7, 21)  # 21 stands 0.34 m from 7: within the device's matching tolerance
SHIFT_TOLERANCE_M = 0.015
"""The moved reflector's shift within this of the move, m: a 90 s drive, the survey's 10 mm
per axis and the reflectors' own range offsets."""


def _site_config(path: Path) -> Path:
    """The paper hall's layout plus reflector 21 beside 7, and one fault of each kind."""
    lines = []
    for r in paper_hall_reflectors():
        lines += ["[[reflectors]]", f"id = {r.id}", f"x = {r.x}", f"y = {r.y}", ""]
    lines += ["[[reflectors]]", "id = 21", "x = 24.95", "y = 4.25", "",
              "[simulator.site]", f"missing = [{MISSING}]", "",
              "[[simulator.site.moved]]", f"id = {MOVED}", f"dx = {MOVE[0]}", f"dy = {MOVE[1]}",
              "", "[[simulator.site.weak]]", f"id = {WEAK}", "detection = 0.3", "",
              "[[simulator.site.extra]]", f"x = {EXTRA[0]}", f"y = {EXTRA[1]}", ""]
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, AuditRun]:
    """A 90 s warehouse drive with a NAV350 on the faulty site, and its audit."""
    d = tmp_path_factory.mktemp("audit")
    log = simulate_log(d / "site.mcap", 90.0, 11, scenario="warehouse",
                       sets=["sim.nav_device=nav350"], config=_site_config(d / "site.toml"))
    run = audit_logs(AuditOptions((str(log),), str(d / "out"), show_progress=False))
    return log, run


def _by_id(run: AuditRun) -> dict[int, dict[str, Any]]:
    refl = run.document["reflectors"]
    assert isinstance(refl, list)
    return {int(r["id"]): r for r in refl if isinstance(r, dict)}  # type: ignore[arg-type]


def test_the_missing_reflector_is_missing(site: tuple[Path, AuditRun]) -> None:
    r = _by_id(site[1])[MISSING]
    assert r["status"] == "missing"
    assert r["expected_sightings"] >= 40 and r["sightings"] == 0


def test_the_moved_reflector_is_moved_by_its_shift(site: tuple[Path, AuditRun]) -> None:
    r = _by_id(site[1])[MOVED]
    assert r["status"] == "moved"
    dx, dy = r["shift_m"]
    assert math.hypot(dx - MOVE[0], dy - MOVE[1]) <= SHIFT_TOLERANCE_M
    sx, sy = r["shift_sigma_m"]
    assert 0.0 < sx < 0.02 and 0.0 < sy < 0.02


def test_the_weak_reflector_is_weak(site: tuple[Path, AuditRun]) -> None:
    r = _by_id(site[1])[WEAK]
    assert r["status"] == "weak"
    assert 0.15 <= r["detection_share"] <= 0.55  # 0.3 of the others' 0.9


def test_the_close_pair_is_ambiguous(site: tuple[Path, AuditRun]) -> None:
    by_id = _by_id(site[1])
    assert by_id[PAIR[0]]["status"] == "ambiguous" and by_id[PAIR[0]]["near"] == [PAIR[1]]
    assert by_id[PAIR[1]]["status"] == "ambiguous" and by_id[PAIR[1]]["near"] == [PAIR[0]]


def test_the_extra_object_is_unmapped_and_nothing_else_is_flagged(
        site: tuple[Path, AuditRun]) -> None:
    doc = site[1].document
    unmapped = doc["unmapped"]
    assert isinstance(unmapped, list) and len(unmapped) == 1
    u = unmapped[0]
    assert isinstance(u, dict)
    assert math.hypot(float(u["x"]) - EXTRA[0], float(u["y"]) - EXTRA[1]) <= 0.1  # type: ignore[arg-type]
    assert int(u["sightings"]) >= 20 and 0.0 < float(u["sigma_m"]) < 0.05  # type: ignore[arg-type]
    faulty = {MOVED, MISSING, WEAK, *PAIR}
    assert {i: r["status"] for i, r in _by_id(site[1]).items() if i not in faulty} == {
        i: "ok" for i in range(1, 21) if i not in faulty}


def test_the_document_has_the_keys_and_is_written(site: tuple[Path, AuditRun]) -> None:
    log, run = site
    doc = run.document
    for key in ("reflectors", "unmapped", "coverage", "estimator", "logs"):
        assert key in doc
    assert doc["estimator"] == "pf" and doc["logs"] == [str(log)]
    for r in _by_id(run).values():
        assert {"id", "status", "expected_sightings", "sightings", "residual_m", "shift_m",
                "shift_sigma_m"} <= set(r)
    coverage = doc["coverage"]
    assert isinstance(coverage, dict) and coverage["poses"]
    out = Path(run.written[0]).parent
    assert json.loads((out / "audit.json").read_text(encoding="utf-8")) == doc
    assert (out / "report.html").read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    assert any("1 moved" in line and "1 missing" in line for line in run.lines)


def test_the_command_prints_the_summary_or_the_document(
        site: tuple[Path, AuditRun], tmp_path: Path, capsys: pytest.CaptureFixture[str]
        ) -> None:
    log = site[0]
    code, out, err = run_command(capsys, "audit", log, "-o", tmp_path / "a", "--no-progress")
    assert code == 0, err
    assert out.startswith("audit of 1 log (nav350); pose: pf (the best available")
    assert len(out.splitlines()) <= 24  # one screen
    code, out, err = run_command(capsys, "audit", log, "-o", tmp_path / "b", "--json",
                                 "--no-progress")
    assert code == 0, err
    assert json.loads(out)["counts"]["moved"] == 1


def test_a_nav200_log_of_poses_gets_one_line_and_the_coverage(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = simulate_log(tmp_path / "poses.mcap", 20.0, 3, paper_scans=False)
    code, out, err = run_command(capsys, "audit", log, "-o", tmp_path / "out", "--no-progress")
    assert code == 0, err
    lines = [ln for ln in out.splitlines() if "reflectors not audited" in ln]
    assert len(lines) == 1 and "landmark observations" in lines[0]
    doc = json.loads((tmp_path / "out" / "audit.json").read_text(encoding="utf-8"))
    assert doc["reflectors"] == [] and doc["coverage"]["poses"] > 0
    assert doc["estimator"] == "ekf"


@pytest.mark.parametrize("args, words", [
    (("-e", "nosuch"), "unknown estimator 'nosuch'"),
    (("-e", "pf,ekf"), "unknown estimator 'pf,ekf'"),
    (("--set", "audit.nosuch=1"), "unknown setting 'audit.nosuch'"),
    (("--set", "audit.weak_max_share=2"), "audit.weak_max_share"),
])
def test_bad_options_give_one_line_and_exit_2(
        site: tuple[Path, AuditRun], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        args: tuple[str, ...], words: str) -> None:
    code, out, err = run_command(capsys, "audit", site[0], "-o", tmp_path / "o", *args)
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and words in err


def test_an_output_that_is_an_input_is_refused(
        site: tuple[Path, AuditRun], capsys: pytest.CaptureFixture[str]) -> None:
    log = site[0]
    before = log.read_bytes()
    code, _, err = run_command(capsys, "audit", log, "-o", log)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "is the input" in err
    assert log.read_bytes() == before


def test_a_log_without_a_layout_is_refused(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    pose = json.dumps({"timestamp": {"sec": 1704067200, "nsec": 0}, "x": 1.0, "y": 2.0,
                       "heading": 0.0, "valid": True, "quality": 0,
                       "reflectors_used": 4}).encode()
    log = write_topic_log(tmp_path / "bare.mcap", "/nav/pose", "lgvtool.NavPose", [pose] * 5)
    code, _, err = run_command(capsys, "audit", log, "-o", tmp_path / "out")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "layout" in err


def test_the_simulator_refuses_a_site_fault_of_an_unknown_reflector(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run_command(capsys, "simulate", "-s", "warehouse", "--duration", "2", "-o",
                               tmp_path / "x.mcap", "--set", "site.missing=[99]")
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "site.missing names reflector 99" in err
    cfg = tmp_path / "moved.toml"
    cfg.write_text("[[simulator.site.moved]]\nid = 77\ndx = 0.05\n", encoding="utf-8")
    code, _, err = run_command(capsys, "simulate", "-s", "warehouse", "--duration", "2", "-o",
                               tmp_path / "y.mcap", "--config", cfg)
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "site.moved names reflector 77" in err


def test_moments_pool_as_one_set() -> None:
    rng = np.random.default_rng(1)
    v = rng.normal(size=(50, 2)) * [1.0, 3.0] + [1e4, -2.0]
    g = rng.integers(0, 3, size=50)
    whole = Moments.of(g, v, 3)
    parts = Moments.of(g[:20], v[:20], 3).merged(Moments.of(g[20:], v[20:], 3))
    assert np.allclose(whole.n, parts.n)
    assert np.allclose(whole.mean, parts.mean, rtol=0, atol=1e-9)
    assert np.allclose(whole.m2, parts.m2, rtol=1e-9, atol=1e-9)


def test_unmapped_clusters_of_two_logs_are_one_object() -> None:
    s = AuditSettings()
    rng = np.random.default_rng(2)
    parts = []
    for k in range(2):
        x = 5.0 + rng.normal(0, 0.02, 30)
        y = 7.0 + rng.normal(0, 0.02, 30)
        parts.append(unmapped_evidence(x, y, np.arange(30) // 10 + 10 * k, s))
    objects = listed_objects(pooled_unmapped(parts, s), s)
    assert len(objects) == 1
    assert objects[0].sightings == 60
    assert abs(objects[0].x - 5.0) < 0.02 and abs(objects[0].y - 7.0) < 0.02


def test_two_logs_pool_per_reflector(site: tuple[Path, AuditRun], tmp_path: Path,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """The same drive twice (in this process: the fleet engine runs the same task function):
    twice the chances and sightings, the same statuses, the same shift within 1 mm (twice the
    sightings weigh the prior on a reflector's own range offset less)."""
    import lgvtool.fleet.connect

    monkeypatch.setattr(lgvtool.fleet.connect, "fleet_available", lambda: False)
    log, one = site
    two = audit_logs(AuditOptions((str(log), str(log)), str(tmp_path / "two"),
                                  show_progress=False))
    a, b = _by_id(one), _by_id(two)
    for rid, r in a.items():
        assert b[rid]["expected_sightings"] == 2 * r["expected_sightings"]
        assert b[rid]["sightings"] == 2 * r["sightings"]
        assert b[rid]["status"] == r["status"]
    assert np.allclose(b[MOVED]["shift_m"], a[MOVED]["shift_m"], rtol=0, atol=1e-3)
    assert two.document["logs"] == [str(log), str(log)]


def test_the_docs_list_every_threshold_as_declared() -> None:
    from lgvtool.declared import markdown_table

    doc = (Path(__file__).resolve().parents[2] / "docs" / "audit.md").read_text(encoding="utf-8")
    assert markdown_table(AuditSettings, "audit.") in doc, (
        "docs/audit.md: the thresholds' table differs from lgvtool/audit/audit_settings.py")


def test_a_long_log_is_gathered_in_blocks_to_the_same_evidence(
        site: tuple[Path, AuditRun], monkeypatch: pytest.MonkeyPatch) -> None:
    """Blocks of revolutions (memory bounded on a long log) give the same counts, and the
    same shift within 3 mm on blocks of 45 s (each block's own common range offsets and
    median offsets; a real block holds an hour or so)."""
    import lgvtool.audit.reflector_audit as ra
    from lgvtool.audit.log_audit import LogAuditOptions, log_evidence

    whole = log_evidence(str(site[0]), LogAuditOptions())
    # about two blocks (the observations counted in blocks include the unmatched ones)
    monkeypatch.setattr(ra, "BLOCK_OBSERVATIONS", int(whole.reflectors.sightings.sum()) // 2)
    blocks = log_evidence(str(site[0]), LogAuditOptions())
    assert whole.reflectors is not None and blocks.reflectors is not None
    assert np.array_equal(whole.reflectors.chances, blocks.reflectors.chances)
    assert np.array_equal(whole.reflectors.sightings, blocks.reflectors.sightings)
    s = AuditSettings()
    a = {v.id: v for v in ra.judge(whole.reflectors, whole.layout, s)}
    b = {v.id: v for v in ra.judge(blocks.reflectors, blocks.layout, s)}
    assert {i: v.status for i, v in a.items()} == {i: v.status for i, v in b.items()}
    assert np.allclose(a[MOVED].shift_m, b[MOVED].shift_m, rtol=0, atol=3e-3)
    assert blocks.unmapped is not None and len(listed_objects(blocks.unmapped, s)) == 1


def test_merging_many_sets_of_moments_at_once_is_merging_them_one_by_one() -> None:
    from lgvtool.audit.unmapped_objects import _grouped

    rng = np.random.default_rng(4)
    sets = [Moments.of(np.zeros(12, dtype=np.int64), rng.normal(size=(12, 2)) + k, 1)
            for k in range(5)]
    stacked = Moments(*(np.concatenate([getattr(m, f) for m in sets])
                        for f in ("n", "mean", "m2")))
    label = np.array([0, 1, 0, 1, 1], dtype=np.int64)
    at_once = _grouped(stacked, label, 2)
    first = sets[0].merged(sets[2])
    second = sets[1].merged(sets[3]).merged(sets[4])
    for g, one in enumerate((first, second)):
        assert np.isclose(at_once.n[g], one.n[0])
        assert np.allclose(at_once.mean[g], one.mean[0], rtol=0, atol=1e-12)
        assert np.allclose(at_once.m2[g], one.m2[0], rtol=1e-12, atol=1e-12)


def test_a_shift_and_a_range_offset_part_when_seen_from_several_sides() -> None:
    """Sightings e = shift + b u from lines of sight u spread over 180 deg: both come back;
    from one direction only, the prior keeps b small and the shift takes the offset."""
    from lgvtool.audit.reflector_audit import shifts

    rng = np.random.default_rng(5)
    shift, b, n = np.array([0.04, -0.02]), -0.01, 2000
    for spread, tol in ((np.pi, 0.002), (0.0, None)):
        ang = rng.uniform(-spread / 2, spread / 2, n)
        u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
        e = shift + b * u + rng.normal(0, 0.02, (n, 2))
        g = np.zeros(n, dtype=np.int64)
        m = Moments.of(g, np.concatenate([e, u], axis=1), 1)
        # the sightings in 200 time blocks (only their count weighs the data)
        blocks = Moments(np.array([200.0]), np.zeros((1, 2)), np.zeros((1, 2, 2)))
        s, fitted = shifts(m, blocks, 0.005)
        if tol is not None:
            assert np.allclose(s[0], shift, rtol=0, atol=tol) and abs(fitted[0] - b) < tol
        else:
            assert abs(fitted[0]) < 1e-3
            assert np.allclose(s[0], shift + b * u[0], rtol=0, atol=0.003)


def test_each_reflector_has_its_quality_and_echo_and_the_weak_one_echoes_weaker(
        site: tuple[Path, AuditRun]) -> None:
    """The simulated NAV350 reports a weak reflector's echo in proportion to its detection
    (0.3 of the others' 0.9); a 90 s drive spreads over less than an hour: no trend."""
    by_id = _by_id(site[1])
    for rid, r in by_id.items():
        if rid == MISSING:
            assert r["quality"]["mean"] is None and r["mean_echo"]["mean"] is None
            continue
        assert 0 < r["quality"]["mean"] <= 100 and 0 < r["mean_echo"]["mean"] <= 200
        assert r["quality"]["trend_per_day"] is None and r["mean_echo"]["trend_per_day"] is None
    clean = float(np.median([r["mean_echo"]["mean"] for i, r in by_id.items()
                             if r["status"] == "ok"]))
    assert by_id[WEAK]["mean_echo"]["mean"] < 0.6 * clean


def test_a_device_value_trend_is_its_slope_per_day_once_spread_over_an_hour() -> None:
    from lgvtool.audit.reflector_audit import Trend

    rng = np.random.default_rng(3)
    days = 19700.0 + np.sort(rng.uniform(0.0, 30.0, 200))
    echo = 180.0 - 1.5 * (days - days[0]) + rng.normal(0.0, 2.0, 200)
    t = Trend.of(Moments.of(np.zeros(200, np.int64), np.stack([days, echo], axis=1), 1), 0)
    assert abs(t.per_day + 1.5) < 0.1 and abs(t.mean - float(echo.mean())) < 1e-9
    short = days[0] + (days - days[0]) / 30.0 / 48.0  # spread over half an hour
    s = Trend.of(Moments.of(np.zeros(200, np.int64), np.stack([short, echo], axis=1), 1), 0)
    assert math.isnan(s.per_day) and abs(s.mean - t.mean) < 1e-9
