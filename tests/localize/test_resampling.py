"""Resampling, redistribution and KLD-sampling."""

from __future__ import annotations

import math

import numpy as np

from lgvtool.config import Area
from lgvtool.localize.kld import kld_bound, kld_count, occupied_bins
from lgvtool.localize.resampling import (
    effective_sample_size,
    low_variance,
    multinomial,
    redistribute,
)


def test_low_variance_keeps_expected_counts() -> None:
    rng = np.random.default_rng(1)
    w = rng.random(50)
    w /= w.sum()
    n = 1000
    for _ in range(20):
        counts = np.bincount(low_variance(w, n, rng), minlength=50)
        assert counts.sum() == n
        assert np.all(counts >= np.floor(n * w) - 1e-9)
        assert np.all(counts <= np.ceil(n * w) + 1e-9)


def test_multinomial_mean_matches_weights() -> None:
    rng = np.random.default_rng(2)
    w = np.array([0.5, 0.3, 0.2])
    counts = np.bincount(multinomial(w, 200_000, rng), minlength=3) / 200_000
    assert np.allclose(counts, w, atol=0.005)


def test_effective_sample_size() -> None:
    assert math.isclose(effective_sample_size(np.full(10, 0.1)), 10.0)
    assert math.isclose(effective_sample_size(np.array([1.0, 0.0, 0.0])), 1.0)


def test_redistribution_fractions_and_ranges() -> None:
    rng = np.random.default_rng(3)
    area = Area(0.0, 25.0, 0.0, 20.0)
    m = 200
    z = np.full(m, 100.0 + 100.0j)  # far outside the area: local particles are recognisable
    th = np.zeros(m)
    w = np.zeros(m)
    top = np.arange(0, m, 4)  # the top 25 %
    w[top] = np.linspace(1.0, 2.0, len(top))
    z[top] = 100.0 + 1j * (100.0 + np.arange(len(top)))
    w /= w.sum()
    new_z, new_th, n_local = redistribute(z, th, w, rng, area, top_fraction=0.25,
                                          local_fraction=0.95, spread_m=0.25,
                                          heading_spread_rad=0.1)
    assert len(new_z) == m and n_local == 190
    local, far = new_z[:n_local], new_z[n_local:]
    parent_y = np.round(local.imag - 100.0)
    assert np.all(np.abs(local.real - 100.0) <= 0.25)
    assert np.all(np.abs(local.imag - 100.0 - parent_y) <= 0.25 + 1e-12)
    assert np.all(np.abs(new_th[:n_local]) <= 0.1)
    assert np.all((far.real >= 0) & (far.real <= 25) & (far.imag >= 0) & (far.imag <= 20))
    assert np.all(np.abs(new_th[n_local:]) <= math.pi)
    # parents are drawn from the top quarter only, and spread over it
    assert set(parent_y.astype(int)) <= set(range(len(top)))
    assert len(set(parent_y.astype(int))) > len(top) // 2


def test_kld_count_grows_with_spread() -> None:
    rng = np.random.default_rng(4)
    counts = []
    for spread in (0.05, 0.5, 2.0, 8.0):
        n = 20_000
        x, y = rng.normal(10, spread, n), rng.normal(10, spread, n)
        th = rng.normal(0, min(3.0, spread), n)
        from lgvtool.localize.kld import bin_keys

        keys = bin_keys(x, y, th, 0.25, 0.1)
        counts.append(kld_count(keys, 0.02, 0.01, 100, n))
        assert occupied_bins(x, y, th, 0.25, 0.1) >= 1
    assert counts == sorted(counts) and counts[-1] > 5 * counts[0]


def test_kld_bound_is_monotonic() -> None:
    k = np.arange(2, 500)
    b = kld_bound(k, 0.05, 0.01)
    assert np.all(np.diff(b) > 0)


def test_kld_count_is_the_first_draw_that_meets_the_bound() -> None:
    """The sequential rule, checked draw by draw against the bound of the bins seen so far."""
    rng = np.random.default_rng(11)
    for n_bins, m, n_min in ((30, 2000, 10), (400, 3000, 50), (5, 500, 1), (2000, 1500, 100)):
        keys = rng.integers(0, n_bins, m).astype(np.int64)
        seen: set[int] = set()
        expected = m
        for i, key in enumerate(keys.tolist()):
            seen.add(key)
            need = 1.0 if len(seen) <= 1 else float(kld_bound(len(seen), 0.05, 0.01))
            if i + 1 >= max(need, n_min):
                expected = i + 1
                break
        assert kld_count(keys, 0.05, 0.01, n_min, m) == min(max(expected, n_min), m)
