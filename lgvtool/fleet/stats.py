"""Mean, standard deviation and Student-t confidence intervals over seeds (no SciPy needed;
the t quantile is :func:`lgvtool.quantiles.t_quantile`)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from lgvtool.quantiles import t_quantile


@dataclass(frozen=True)
class Spread:
    """Mean of n values with their sample standard deviation and a two-sided Student-t
    confidence interval of the mean (NaN where n is too small)."""

    n: int
    mean: float
    std: float
    ci_low: float
    ci_high: float


def describe(values: Iterable[float | int | None], level: float = 0.95) -> Spread:
    """Mean, sample standard deviation (n - 1) and the ``level`` confidence interval
    mean +- t(1 - (1 - level) / 2, n - 1) * std / sqrt(n) of the finite values."""
    xs = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    n = len(xs)
    if n == 0:
        return Spread(0, math.nan, math.nan, math.nan, math.nan)
    mean = math.fsum(xs) / n
    if n == 1:
        return Spread(1, mean, math.nan, math.nan, math.nan)
    std = math.sqrt(math.fsum((x - mean) ** 2 for x in xs) / (n - 1))
    half = t_quantile(1.0 - (1.0 - level) / 2.0, n - 1) * std / math.sqrt(n)
    return Spread(n, mean, std, mean - half, mean + half)
