"""Radial statistics and errors against interpolated ground truth."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from lgvtool.evaluate.metrics import (
    associate_truth,
    average_stats,
    improvement,
    radial_stats,
    truth_errors,
    truth_stats,
)


def test_known_bias_and_variance() -> None:
    rng = np.random.default_rng(7)
    e = 0.030 + rng.normal(0.0, 0.020, 200_000)   # 30 mm bias, 20 mm sd
    s = radial_stats(e)
    assert s.mean * 1e3 == pytest.approx(30.0, abs=0.2)
    assert s.variance * 1e6 == pytest.approx(400.0, rel=0.01)
    assert s.rmse * 1e3 == pytest.approx(math.sqrt(30.0**2 + 400.0), rel=0.005)
    assert s.rmse**2 == pytest.approx(s.mean**2 + s.variance, rel=1e-12)


def test_exact_small_case() -> None:
    s = radial_stats([0.001, -0.003, 0.002, 0.004])
    assert s.mean == pytest.approx(0.001)
    assert s.variance == pytest.approx((0 + 16 + 1 + 9) / 4 * 1e-6)
    assert s.rmse == pytest.approx(math.sqrt((1 + 9 + 4 + 16) / 4) * 1e-3)
    assert s.max_abs == pytest.approx(0.004)
    assert s.samples == 4


def test_empty_and_nan() -> None:
    assert radial_stats([]).samples == 0
    assert math.isnan(radial_stats([math.nan]).rmse)
    assert radial_stats([math.nan, 0.002]).rmse == pytest.approx(0.002)


def test_average_and_improvement() -> None:
    a = average_stats([radial_stats([0.01]), radial_stats([0.03, -0.03])])
    assert a.rmse == pytest.approx(0.02)
    assert a.max_abs == pytest.approx(0.03)
    assert improvement(20.0, 50.0) == pytest.approx(60.0)
    assert math.isnan(improvement(1.0, 0.0))


def test_truth_is_interpolated_not_nearest() -> None:
    # Truth every 1 s on a straight line; estimates exactly on the line between samples.
    truth = pd.DataFrame({"t": [0.0, 1.0, 2.0, 3.0], "x": [0.0, 1.0, 2.0, 3.0],
                          "y": [0.0, 0.0, 0.0, 0.0], "heading": [0.0] * 4})
    est = pd.DataFrame({"t": [0.4, 1.5, 2.9], "x": [0.4, 1.5, 2.9], "y": [0.0] * 3,
                        "heading": [0.0] * 3})
    err = truth_errors(est, truth)
    assert err["position_error"].to_numpy() == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


def test_heading_interpolated_on_the_unwrapped_angle() -> None:
    # Truth heading crosses +-pi: 179 deg -> -179 deg. Halfway the truth is 180 deg, not 0.
    truth = pd.DataFrame({"t": [0.0, 1.0], "x": [0.0, 0.0], "y": [0.0, 0.0],
                          "heading": [math.radians(179.0), math.radians(-179.0)]})
    est = pd.DataFrame({"t": [0.5], "x": [0.0], "y": [0.0], "heading": [math.pi]})
    a = associate_truth(est, truth)
    assert abs(abs(a["heading_true"].iloc[0]) - math.pi) < 1e-9
    err = truth_errors(est, truth)
    assert abs(err["heading_error"].iloc[0]) < 1e-9


def test_truth_outside_span_and_gaps_are_left_out() -> None:
    # Truth every 0.5 s with a 4 s hole: longer than 1.5 s and than 5 x the median interval.
    tt = [0.0, 0.5, 1.0, 5.0, 5.5, 6.0]
    truth = pd.DataFrame({"t": tt, "x": tt, "y": [0.0] * 6, "heading": [0.0] * 6})
    te = [-1.0, 0.75, 3.0, 5.25, 7.0]
    est = pd.DataFrame({"t": te, "x": te, "y": [0.0] * 5, "heading": [0.0] * 5})
    a = associate_truth(est, truth, max_gap=1.5)
    assert a["t"].tolist() == [0.75, 5.25]


def test_truth_stats() -> None:
    pe = np.arange(1, 101) * 1e-3
    s = truth_stats(pe, np.full(100, math.radians(1.0)))
    assert s.position_max == pytest.approx(0.1)
    assert s.position_mean == pytest.approx(0.0505)
    assert s.position_p95 == pytest.approx(np.percentile(pe, 95))
    assert math.degrees(s.heading_rmse) == pytest.approx(1.0)
