"""``lgvtool compare A B`` on real results: evaluations and audits of short simulated logs
(the same run, a noisier NAV, another site), the gate's exit codes, and bad input refused in
one line."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest
from inprocess import run_command
from simlogs import simulate_log

from lgvtool.compare.result_comparison import (
    AUDIT_KPIS,
    ESTIMATOR_KPIS,
    SEGMENT_KPIS,
    compare_documents,
    site_check,
)
from lgvtool.errors import InputError
from lgvtool.json_types import JSONObject

NOISY = ("nav.sigma_range_mm=200", "nav.sigma_bearing_deg=0.5")
"""A NAV about 16 and 10 times noisier in range and bearing than the default: the laser's
truth RMSE grows by about half (from about 7 to 10 cm on the 20 s log)."""


@dataclass(frozen=True)
class Results:
    logs: Path
    eval_a: Path
    """``evaluate -e laser -o`` of the log A."""
    eval_a_again: Path
    """The same log evaluated again, into another folder: the same run."""
    eval_noisy: Path
    """The same drive (seed) with the noisy NAV."""
    audit_a: Path
    audit_a_again: Path
    """The same log audited again, into another folder: the same run."""
    audit_missing: Path
    """The same drive (seed) with reflector 3 covered: the stored layout keeps it."""
    audit_other_site: Path
    """A log of a hall whose reflector 3 stands 1.5 m further along x."""


def _lgvtool(*args: object) -> None:
    subprocess.run([sys.executable, "-m", "lgvtool", *map(str, args)], check=True,
                   capture_output=True)


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Results:
    tmp = tmp_path_factory.mktemp("compare")
    log_a = simulate_log(tmp / "a.mcap", 20.0, seed=1)
    noisy = simulate_log(tmp / "noisy.mcap", 20.0, seed=1, sets=NOISY)
    config = subprocess.run([sys.executable, "-m", "lgvtool", "config"], check=True,
                            capture_output=True, text=True).stdout
    assert config.count("x = 10.2644\n") == 1  # reflector 3 of the default hall
    (tmp / "other.toml").write_text(config.replace("x = 10.2644\n", "x = 11.7644\n"),
                                    encoding="utf-8")
    other = simulate_log(tmp / "other.mcap", 20.0, seed=1, config=tmp / "other.toml")
    missing = simulate_log(tmp / "missing.mcap", 20.0, seed=1, sets=("site.missing=[3]",))
    for log, out in ((log_a, "eval_a"), (log_a, "eval_a_again"), (noisy, "eval_noisy")):
        _lgvtool("evaluate", log, "-e", "laser", "-o", tmp / out, "--no-progress")
    for log, out in ((log_a, "audit_a"), (log_a, "audit_a_again"), (missing, "audit_missing"),
                     (other, "audit_other")):
        _lgvtool("audit", log, "-o", tmp / out, "--no-progress")
    return Results(tmp, tmp / "eval_a", tmp / "eval_a_again", tmp / "eval_noisy",
                   tmp / "audit_a", tmp / "audit_a_again", tmp / "audit_missing",
                   tmp / "audit_other")


def _one_error_line(code: int, out: str, err: str) -> str:
    assert (code, out) == (2, "")
    assert err.count("\n") == 1 and err.startswith("lgvtool: error: "), err
    return err


def test_the_same_run_passes_the_gate(results: Results,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_command(capsys, "compare", results.eval_a, results.eval_a_again,
                                 "--tolerance", "0%")
    assert code == 0, err
    rows = [line for line in out.splitlines() if line.startswith("laser.")]
    assert len(rows) >= 4 and all(line.endswith("same") for line in rows), out
    assert "check  pass  laser:" in err and "FAIL" not in err


def test_a_worse_run_fails_the_gate_and_the_better_one_passes(
        results: Results, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_command(capsys, "compare", results.eval_a, results.eval_noisy,
                                 "--tolerance", "10%")
    assert code == 1, err
    assert "check  FAIL  laser.truth.position_rmse_m = " in err
    assert "worse than the baseline" in err and "(tolerance 10%)" in err
    row = next(line for line in out.splitlines()
               if line.startswith("laser.truth.position_rmse_m "))
    assert row.split()[1:3] == ["m", "lower"] and row.endswith("WORSE")
    # the other way round the noisy run is the baseline: B is better, the gate passes
    code, _, err = run_command(capsys, "compare", results.eval_noisy, results.eval_a,
                               "--tolerance", "10%")
    assert code == 0, err
    # a tolerance wider than the worsening (about 50 % on the RMSE, below 100 % on every
    # figure) passes too
    code, _, err = run_command(capsys, "compare", results.eval_a, results.eval_noisy,
                               "--tolerance", "300%")
    assert code == 0, err


def test_the_json_holds_both_values_and_their_difference(
        results: Results, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_command(capsys, "compare", results.eval_a / "table1.json",
                               results.eval_noisy, "--tolerance", "10%", "--json")
    assert code == 1
    doc = json.loads(out)
    assert doc["kind"] == "evaluation" and doc["tolerance_pct"] == pytest.approx(10.0)
    a_doc = json.loads((results.eval_a / "table1.json").read_text(encoding="utf-8"))
    (rmse,) = [k for k in doc["kpis"] if k["key"] == "laser.truth.position_rmse_m"]
    assert rmse["a"] == pytest.approx(
        a_doc["estimators"]["laser"]["truth"]["position_rmse_m"], abs=1e-12)
    assert rmse["difference"] == pytest.approx(rmse["b"] - rmse["a"], abs=1e-12)
    assert rmse["change_pct"] > 20.0 and rmse["worse_beyond_tolerance"] is True
    assert any(not c["passed"] and c["key"] == "laser.truth.position_rmse_m"
               for c in doc["checks"])


def test_audits_of_one_site_compare_and_a_worse_count_fails(
        results: Results, capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run_command(capsys, "compare", results.audit_a, results.audit_a_again,
                                 "--tolerance", "0%")
    assert code == 0, err
    assert "check  pass  audit: " in err
    # a covered reflector: missing 0 -> 1 fails at any tolerance; the rest is within 10 %
    code, out_missing, err = run_command(capsys, "compare", results.audit_a,
                                         results.audit_missing, "--tolerance", "10%")
    assert code == 1
    lines = err.splitlines()
    assert lines[0] == "check  FAIL  counts.missing = 1 is worse than the baseline 0 (tolerance 10%)"
    assert lines[-1].startswith("checks: ") and lines[-1].endswith(" FAILED")
    # the error by segment is compared per source and reference (one check line each)
    assert sum(line.startswith("check  ") and " segments." in line for line in lines) >= 2
    assert any(line.startswith("counts.missing ") and line.endswith("WORSE")
               for line in out_missing.splitlines())
    assert out.splitlines()[1].split()[:3] == ["kpi", "unit", "better"]
    assert any(line.startswith("counts.missing ") for line in out.splitlines())
    doc = json.loads((results.audit_a / "audit.json").read_text(encoding="utf-8"))
    assert len(doc["layout"]) == 20 and doc["counts"]["ok"] == 20
    # a reflector gone missing: lower is better for missing, higher for ok
    worse = {**doc, "counts": {**doc["counts"], "ok": 19, "missing": 1}}
    c = compare_documents(doc, worse, 0.01)
    failed = sorted(ch.text for ch in c.checks if not ch.passed)
    assert failed == ["counts.missing = 1 is worse than the baseline 0 (tolerance 1%)",
                      "counts.ok = 19 is 5.0% worse than the baseline 20 (tolerance 1%)"]
    # within a 10 % tolerance only the count that was zero fails
    assert [ch.key for ch in compare_documents(doc, worse, 0.1).checks
            if not ch.passed] == ["counts.missing"]
    assert all(ch.passed for ch in compare_documents(worse, doc, 0.01).checks)


def test_two_sites_are_refused_in_one_line(results: Results,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    err = _one_error_line(*run_command(capsys, "compare", results.audit_a,
                                       results.audit_other_site))
    assert err == ("lgvtool: error: A and B are not of one site: reflector 3 stands 1.500 m "
                   "apart in their layouts (site tolerance 0.05 m); --any-site compares them "
                   "anyway\n")
    # another hall: its error by segment differs (here by up to about 25 %), its counts not
    code, _, err = run_command(capsys, "compare", results.audit_a, results.audit_other_site,
                               "--any-site", "--tolerance", "60%")
    assert code == 0 and "site not checked (--any-site)" in err
    code, _, err = run_command(capsys, "compare", results.audit_a, results.audit_other_site,
                               "--site-tolerance", "2", "--tolerance", "60%")
    assert code == 0, err


def test_layouts_with_other_ids_are_of_other_sites() -> None:
    a: JSONObject = {"layout": [{"id": 1, "x": 0.0, "y": 0.0}, {"id": 2, "x": 5.0, "y": 0.0}]}
    b: JSONObject = {"layout": [{"id": 1, "x": 0.01, "y": 0.0}, {"id": 7, "x": 5.0, "y": 0.0}]}
    with pytest.raises(InputError, match=r"other reflectors \(ids only in A: 2; ids only "
                                         r"in B: 7\)"):
        site_check(a, b, 0.05)
    same: JSONObject = {"layout": [{"id": 2, "x": 5.0, "y": 0.04},
                                   {"id": 1, "x": 0.0, "y": 0.0}]}
    assert site_check(a, same, 0.05) is None
    assert site_check(a, {"layout": []}, 0.05) == "site not checked: B holds no reflector layout"
    # an audit.json without "layout" is checked by its audited reflectors (layout positions)
    older: JSONObject = {"reflectors": [{"id": 1, "x": 0.0, "y": 0.0, "status": "ok"},
                                        {"id": 2, "x": 5.0, "y": 0.3, "status": "missing"}]}
    with pytest.raises(InputError, match=r"reflector 2 stands 0\.300 m apart"):
        site_check(a, older, 0.05)


@pytest.mark.parametrize("case", ["foreign", "truncated", "log", "mixed", "missing", "empty dir"])
def test_bad_input_is_refused_in_one_line(case: str, results: Results, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    good = results.eval_a / "table1.json"
    text = good.read_text(encoding="utf-8")
    (tmp_path / "foreign.json").write_text('{"hello": [1, 2]}', encoding="utf-8")
    (tmp_path / "table1.json").write_text(text[: len(text) // 2], encoding="utf-8")
    other = {"foreign": tmp_path / "foreign.json", "truncated": tmp_path / "table1.json",
             "log": results.logs / "a.mcap", "mixed": results.audit_a,
             "missing": tmp_path / "nothing.json", "empty dir": tmp_path / "nothing"}[case]
    if case == "empty dir":
        other.mkdir()
    err = _one_error_line(*run_command(capsys, "compare", good, other))
    expected = {
        "foreign": f"{other}: neither an lgvtool audit.json nor an evaluation result "
                   f"(table1.json)",
        "truncated": f"{other}: not JSON (",
        "log": f"{other} is a log; compare reads results: run 'lgvtool audit LOG -o DIR' or "
               f"'lgvtool evaluate LOG -o DIR' on each log first, then compare the DIRs",
        "mixed": f"{good} is an evaluation result and {other / 'audit.json'} an audit result",
        "missing": f"not found: {other}",
        "empty dir": f"{other}: a folder holding neither of audit.json and table1.json",
    }[case]
    assert err.startswith(f"lgvtool: error: {expected}"), err


def test_a_bad_tolerance_is_refused_in_evaluate_s_words(
        results: Results, capsys: pytest.CaptureFixture[str]) -> None:
    err = _one_error_line(*run_command(capsys, "compare", results.eval_a, results.eval_a,
                                       "--tolerance", "-5%"))
    assert err == "lgvtool: error: --tolerance must be a non-negative percentage, got '-5%'\n"


def test_every_kpi_is_declared_once_with_a_direction() -> None:
    for table in (AUDIT_KPIS, ESTIMATOR_KPIS, SEGMENT_KPIS):
        paths = [k.path for k in table]
        assert len(paths) == len(set(paths))
        assert {k.better for k in table} <= {"lower", "higher"}
        assert all(k.slack >= 0.0 for k in table)


def test_a_negative_site_tolerance_is_refused(results: Results,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    err = _one_error_line(*run_command(capsys, "compare", results.audit_a, results.audit_a,
                                       "--site-tolerance", "-1"))
    assert err == ("lgvtool: error: --site-tolerance: compare.site_tolerance_m must be at "
                   "least 0, got -1\n")


def test_station_figures_are_gated_per_source() -> None:
    def audit(radius: float, failed: int) -> JSONObject:
        summary: JSONObject = {"stations": 2, "visits": 20, "sigma_x_max_m": 0.004,
                               "sigma_y_max_m": 0.003, "sigma_heading_max_deg": 0.2,
                               "radius95_max_m": radius, "passed": 2 - failed,
                               "failed": failed}
        return {"logs": ["a.mcap"], "counts": {}, "reflectors": [], "coverage": {},
                "stations": {"summary": {"estimator": summary, "laser": dict(summary)}}}

    base = audit(0.010, 0)
    same = compare_documents(base, audit(0.010, 0), 0.0)
    keys = {r.key for r in same.rows if r.a is not None}
    assert "stations.summary.estimator.radius95_max_m" in keys
    assert "stations.summary.laser.failed" in keys
    assert "stations.summary.truth.radius95_max_m" not in keys  # neither holds it
    assert all(ch.passed for ch in same.checks)
    # a 95 % radius 30 % larger fails a 10 % gate; a station failing its tolerance fails any
    worse = compare_documents(base, audit(0.013, 1), 0.1)
    failed = sorted(ch.key for ch in worse.checks if not ch.passed)
    assert failed == ["stations.summary.estimator.failed", "stations.summary.estimator.passed",
                      "stations.summary.estimator.radius95_max_m",
                      "stations.summary.laser.failed", "stations.summary.laser.passed",
                      "stations.summary.laser.radius95_max_m"]
    assert all(ch.passed for ch in compare_documents(base, audit(0.0105, 0), 0.1).checks)


def test_the_error_by_segment_is_gated_per_source_and_reference() -> None:
    def audit(pf_cross: float, laser_ref: str = "truth") -> JSONObject:
        def entry(source: str, reference: str, cross: float) -> JSONObject:
            return {"source": source, "reference": reference, "poses": 100,
                    "overall": {"count": 100, "along": {"rms": 0.006, "mean": -0.0003},
                                "cross": {"rms": cross, "mean": 0.001},
                                "heading": {"rms": 0.001, "mean": 0.0}}}
        return {"logs": ["a.mcap"], "counts": {}, "reflectors": [], "coverage": {},
                "segments": {"sources": [entry("pf", "truth", pf_cross),
                                         entry("laser", laser_ref, 0.025)]}}

    same = compare_documents(audit(0.005), audit(0.005), 0.0)
    keys = {r.key for r in same.rows if r.a is not None}
    assert {"segments.pf-vs-truth.overall.cross.rms", "segments.laser-vs-truth.overall.along.rms",
            "segments.pf-vs-truth.overall.heading.rms"} <= keys
    assert all(ch.passed for ch in same.checks)
    # pf's cross-track error 40 % larger fails a 10 % gate; 5 % larger passes it
    worse = compare_documents(audit(0.005), audit(0.007), 0.1)
    assert [ch.key for ch in worse.checks if not ch.passed] == [
        "segments.pf-vs-truth.overall.cross.rms"]
    assert all(ch.passed for ch in compare_documents(audit(0.005), audit(0.00525), 0.1).checks)
    # the laser judged against another reference in B is not compared, and a note says so
    other = compare_documents(audit(0.005), audit(0.005, laser_ref="ekf"), 0.0)
    assert not any(r.key.startswith("segments.laser") for r in other.rows)
    assert other.notes == ("error by segment segments.laser-vs-truth of A is not in B",
                           "error by segment segments.laser-vs-ekf of B is not in A")
