"""The one quantile solver: chi-square and Student-t quantiles against printed tables and,
where SciPy is installed, against SciPy."""

from __future__ import annotations

import math

import pytest

from lgvtool.quantiles import bisect_quantile, chi2_cdf, chi2_quantile, t_cdf, t_quantile

# chi-square quantiles (p, dof, value) to 9 significant digits from the standard tables
CHI2_TABLE = ((0.95, 1, 3.84145882), (0.99, 2, 9.21034037), (0.99, 3, 11.3448667),
              (0.95, 5, 11.0704977), (0.5, 9, 8.34283269), (0.975, 20, 34.1696069),
              (0.05, 2, 0.102586589))
# Student-t quantiles (p, df, value) to 7 decimals from the standard tables
T_TABLE = ((0.975, 1, 12.7062047), (0.975, 2, 4.3026527), (0.95, 5, 2.0150484),
           (0.995, 10, 3.1692727), (0.975, 30, 2.0422725), (0.9, 120, 1.2886462))


@pytest.mark.parametrize(("p", "dof", "q"), CHI2_TABLE)
def test_chi2_against_the_table(p: float, dof: int, q: float) -> None:
    assert chi2_quantile(p, dof) == pytest.approx(q, rel=1e-8)  # the table's 9 digits
    assert chi2_cdf(chi2_quantile(p, dof), dof) == pytest.approx(p, abs=1e-12)


@pytest.mark.parametrize(("p", "df", "q"), T_TABLE)
def test_t_against_the_table(p: float, df: float, q: float) -> None:
    assert t_quantile(p, df) == pytest.approx(q, abs=1e-7)  # the table's 7 decimals
    assert t_quantile(1.0 - p, df) == -t_quantile(p, df)
    assert t_cdf(t_quantile(p, df), df) == pytest.approx(p, abs=1e-10)


def test_the_solver_brackets_and_refuses() -> None:
    # the bracket grows from [0, 1]: the 0.9 quantile of an exponential law of mean 10
    q = bisect_quantile(lambda x: 1.0 - math.exp(-x / 10.0), 0.9)
    assert q == pytest.approx(10.0 * math.log(10.0), rel=1e-12)
    assert bisect_quantile(lambda x: 0.0, 0.5) == math.inf  # never reached
    assert t_quantile(0.5, 3) == 0.0
    for bad in (0.0, 1.0, -0.1):
        with pytest.raises(ValueError):
            chi2_quantile(bad, 2)
        with pytest.raises(ValueError):
            t_quantile(bad, 2)
    with pytest.raises(ValueError):
        chi2_quantile(0.5, 0)
    with pytest.raises(ValueError):
        t_quantile(0.9, 0)


def test_against_scipy() -> None:
    stats = pytest.importorskip("scipy.stats")
    for p in (0.01, 0.5, 0.9, 0.99, 0.999):
        for dof in (1, 2, 3, 4, 7, 13, 40):
            assert chi2_quantile(p, dof) == pytest.approx(float(stats.chi2.ppf(p, dof)), rel=1e-9)
        for df in (1, 2.5, 4, 9, 30, 200):
            assert t_quantile(p, df) == pytest.approx(float(stats.t.ppf(p, df)), rel=1e-9, abs=1e-12)
