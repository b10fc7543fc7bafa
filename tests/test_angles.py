"""The one angle convention: every wrap lands in (-pi, pi]."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from lgvtool.angles import TWO_PI, circular_mean, wrap_angle, wrap_scalar


def test_the_ends_of_the_interval() -> None:
    # -pi belongs to the other end; +pi stays; whole turns vanish
    assert wrap_scalar(-math.pi) == math.pi
    assert wrap_scalar(math.pi) == math.pi
    assert wrap_scalar(3.0 * math.pi) == math.pi
    assert wrap_scalar(0.0) == 0.0
    assert wrap_angle([-math.pi, math.pi, -3.0 * math.pi]).tolist() == [math.pi] * 3


@given(st.floats(min_value=-1e4, max_value=1e4, allow_nan=False))
def test_scalar_and_array_agree_and_stay_in_range(a: float) -> None:
    w = wrap_scalar(a)
    assert -math.pi < w <= math.pi
    assert w == float(wrap_angle(np.array([a]))[0])  # the same bits on both paths
    # the same angle: a differs from its wrap by whole turns (to rounding, 1e-9 rad)
    turns = (a - w) / TWO_PI
    assert abs(turns - round(turns)) * TWO_PI < 1e-9


def test_circular_mean_across_the_seam() -> None:
    # two headings either side of +-pi average to pi (to 1e-12 rad), not to 0
    a = np.array([math.pi - 0.1, -math.pi + 0.1])
    assert abs(abs(circular_mean(a)) - math.pi) < 1e-12
    assert abs(circular_mean(np.array([0.1, 0.3]), np.array([0.5, 0.5])) - 0.2) < 1e-12
