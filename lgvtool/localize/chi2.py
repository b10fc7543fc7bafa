"""Chi-square quantiles for 1 to 3 degrees of freedom (innovation gating), without SciPy."""

from __future__ import annotations

import math


def chi2_cdf(x: float, dof: int) -> float:
    """Cumulative distribution of the chi-square law with ``dof`` in {1, 2, 3}."""
    if x <= 0.0:
        return 0.0
    if dof == 1:
        return math.erf(math.sqrt(x / 2.0))
    if dof == 2:
        return 1.0 - math.exp(-x / 2.0)
    if dof == 3:
        return math.erf(math.sqrt(x / 2.0)) - math.sqrt(2.0 * x / math.pi) * math.exp(-x / 2.0)
    raise ValueError("dof must be 1, 2 or 3")


def chi2_quantile(p: float, dof: int) -> float:
    """The value below which a chi-square variable with ``dof`` falls with probability ``p``."""
    if not 0.0 < p < 1.0:
        raise ValueError("p must be in (0, 1)")
    lo, hi = 0.0, 1.0
    while chi2_cdf(hi, dof) < p:
        hi *= 2.0
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if chi2_cdf(mid, dof) < p:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
