"""--max/--min bounds and --baseline checks on the evaluation document."""

from __future__ import annotations

import copy
from typing import Any

import pytest
from evaluate_synth import DELTA, H, circle_drive

from lgvtool.errors import InputError, ThresholdError
from lgvtool.evaluate.document import build_document
from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.regress import (
    check_baseline,
    check_bounds,
    lookup,
    parse_bound,
    parse_tolerance,
    raise_failures,
)


@pytest.fixture(scope="module")
def doc() -> dict:
    res = evaluate_trajectories(
        {"laser": circle_drive(rotations=2.5, dt=0.45, bias=0.05, sd=0.02, seed=1),
         "pf": circle_drive(rotations=2.5, sd=0.01, seed=2)},
        truth=circle_drive(rotations=2.5, dt=0.05), steering_angle=DELTA, h=H)
    return build_document([res])


def test_parse() -> None:
    assert parse_bound("pf.circle.rmse_mm=25") == ("pf.circle.rmse_mm", 25.0)
    assert parse_tolerance("10%") == pytest.approx(0.10)
    assert parse_tolerance("2.5") == pytest.approx(0.025)
    for bad in ("pf.circle.rmse_mm", "=3", "pf.circle.rmse_mm=abc", "x=nan"):
        with pytest.raises(InputError):
            parse_bound(bad)
    with pytest.raises(InputError):
        parse_tolerance("-1%")


def test_lookup(doc) -> None:
    assert lookup(doc, "pf.circle.rmse_mm") == doc["estimators"]["pf"]["circle"]["rmse_mm"]
    assert lookup(doc, "laser.truth.position_rmse_m") > 0.04
    assert lookup(doc, "rotations.complete") == 2
    with pytest.raises(InputError, match="no estimator 'ekf'"):
        lookup(doc, "ekf.circle.rmse_mm")
    with pytest.raises(InputError, match="no 'rmse'"):
        lookup(doc, "pf.circle.rmse")
    with pytest.raises(InputError, match=r"'laser' is a group.*circle, .*truth"):
        lookup(doc, "laser")
    with pytest.raises(InputError, match=r"'pf.circle' is a group.*rmse_mm"):
        lookup(doc, "pf.circle")


def test_bounds(doc) -> None:
    pf = doc["estimators"]["pf"]["circle"]["rmse_mm"]
    assert check_bounds(doc, [("pf.circle.rmse_mm", pf + 1)]) == []
    failures = check_bounds(doc, [("pf.circle.rmse_mm", pf - 1), ("laser.circle.rmse_mm", 1e9)],
                            [("rotations.complete", 8)])
    assert len(failures) == 2
    assert "pf.circle.rmse_mm" in failures[0] and "rotations.complete" in failures[1]
    with pytest.raises(ThresholdError) as exc:
        raise_failures(failures)
    assert exc.value.exit_code == 1
    raise_failures([])


def test_unavailable_figure_fails(doc) -> None:
    d = copy.deepcopy(doc)
    d["estimators"]["pf"]["circle"] = None
    assert "not available" in check_bounds(d, [("pf.circle.rmse_mm", 30)])[0]


def test_baseline(doc) -> None:
    assert check_baseline(doc, doc, 0.0) == ([], [])
    worse = copy.deepcopy(doc)
    worse["estimators"]["pf"]["circle"]["rmse_mm"] *= 1.2
    failures, _ = check_baseline(worse, doc, 0.10)
    assert len(failures) == 1 and failures[0].startswith("pf.circle.rmse_mm")
    assert "20.0% worse" in failures[0]
    assert check_baseline(worse, doc, 0.25)[0] == []
    worse["estimators"]["laser"]["truth"]["heading_rmse_deg"] = 5.0   # baseline: about 0
    failures, _ = check_baseline(worse, doc, 0.25)
    assert [f.split(" ")[0] for f in failures] == ["laser.truth.heading_rmse_deg"]
    better = copy.deepcopy(doc)
    better["estimators"]["pf"]["circle"]["rmse_mm"] *= 0.5
    assert check_baseline(better, doc, 0.0)[0] == []
    base = copy.deepcopy(doc)
    base["estimators"]["ekf"] = copy.deepcopy(doc["estimators"]["pf"])
    failures, notes = check_baseline(doc, base, 0.1)
    assert failures == [] and "ekf" in notes[0]


def test_baseline_of_another_shape(doc) -> None:
    bad: Any
    for bad in ([], {"estimators": {}}, {"format": "lgvtool.evaluation", "estimators": [1]},
                {"format": "other"}):
        with pytest.raises(InputError, match="not an lgvtool evaluation"):
            check_baseline(doc, bad, 0.1)
    other = copy.deepcopy(doc)
    other["estimators"] = {"ekf": other["estimators"]["pf"]}
    with pytest.raises(InputError, match="no estimator in common"):
        check_baseline(doc, other, 0.1)
