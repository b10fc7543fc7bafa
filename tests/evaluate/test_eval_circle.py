"""Circle fits: algebraic, geometric, fixed radius, weights and outlier trimming."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lgvtool.circle import Circle, fit_centre, fit_geometric, fit_kasa, radial_error
from lgvtool.errors import InputError


def noisy_circle(cx: float, cy: float, r: float, n: int, sd: float, seed: int = 0,
                 arc: float = 2 * math.pi) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    a = rng.uniform(0.0, arc, n)
    rr = r + rng.normal(0.0, sd, n)
    return cx + rr * np.cos(a), cy + rr * np.sin(a)


@pytest.mark.parametrize("fit", [fit_kasa, fit_geometric])
def test_fit_recovers_known_circle_from_noisy_points(fit) -> None:
    x, y = noisy_circle(3.2, -1.5, 0.6928, 2000, 0.02, seed=1)
    c = fit(x, y)
    assert c.cx == pytest.approx(3.2, abs=2e-3)
    assert c.cy == pytest.approx(-1.5, abs=2e-3)
    assert c.r == pytest.approx(0.6928, abs=2e-3)


def test_geometric_fit_beats_kasa_on_an_arc() -> None:
    # Kasa is biased towards small radii on short noisy arcs; the geometric fit is not.
    x, y = noisy_circle(0.0, 0.0, 2.0, 4000, 0.05, seed=2, arc=math.pi / 2)
    geo = fit_geometric(x, y)
    kasa = fit_kasa(x, y)
    assert abs(geo.r - 2.0) < 0.03
    assert abs(geo.r - 2.0) < abs(kasa.r - 2.0)


def test_fit_centre_with_fixed_radius_and_a_radial_bias() -> None:
    # A path 50 mm outside the true circle: the fixed-radius fit keeps the centre, and the
    # bias shows up as the mean radial error.
    x, y = noisy_circle(10.0, 8.0, 0.6928 + 0.05, 3000, 0.01, seed=3)
    c = fit_centre(x, y, 0.6928)
    assert (c.cx, c.cy) == (pytest.approx(10.0, abs=2e-3), pytest.approx(8.0, abs=2e-3))
    assert c.r == 0.6928
    assert np.mean(c.radial_error(x, y)) == pytest.approx(0.05, abs=2e-3)


def test_exact_points_give_exact_circle() -> None:
    a = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    c = fit_geometric(1.0 + 0.5 * np.cos(a), 2.0 + 0.5 * np.sin(a))
    assert (c.cx, c.cy, c.r) == pytest.approx((1.0, 2.0, 0.5), abs=1e-12)


def test_trim_ignores_outliers_for_the_centre() -> None:
    x, y = noisy_circle(0.0, 0.0, 1.0, 1000, 0.005, seed=4)
    x = np.concatenate([x, np.full(60, 6.0)])   # a burst of wild estimates (converging filter)
    y = np.concatenate([y, np.full(60, 5.0)])
    plain = fit_centre(x, y, 1.0)
    trimmed = fit_centre(x, y, 1.0, trim=5.0)
    assert math.hypot(trimmed.cx, trimmed.cy) < 2e-3
    assert math.hypot(plain.cx, plain.cy) > 0.05


def test_weights_balance_point_sets() -> None:
    x1, y1 = noisy_circle(0.0, 0.0, 1.0, 2000, 0.0, seed=5)
    x2, y2 = noisy_circle(0.1, 0.0, 1.0, 20, 0.0, seed=6)
    x, y = np.concatenate([x1, x2]), np.concatenate([y1, y2])
    w = np.concatenate([np.full(2000, 1 / 2000), np.full(20, 1 / 20)])
    c = fit_centre(x, y, 1.0, weights=w)
    assert c.cx == pytest.approx(0.05, abs=0.01)


def test_radial_error_sign() -> None:
    c = Circle(0.0, 0.0, 1.0)
    assert radial_error([2.0, 0.5], [0.0, 0.0], c) == pytest.approx([1.0, -0.5])


def test_bad_inputs() -> None:
    with pytest.raises(InputError):
        fit_kasa([0.0, 1.0], [0.0, 1.0])
    with pytest.raises(InputError):
        fit_kasa([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 2.0, 3.0])   # collinear
    with pytest.raises(InputError):
        fit_centre([0.0, 1.0, 0.0], [1.0, 0.0, -1.0], 0.0)
