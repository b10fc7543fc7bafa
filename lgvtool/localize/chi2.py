"""Chi-square distribution and quantiles for any whole number of degrees of freedom
(innovation gating, landmark-fix checks), without SciPy."""

from __future__ import annotations

import math


def chi2_cdf(x: float, dof: int) -> float:
    """Cumulative distribution of the chi-square law with ``dof`` (a whole number >= 1)
    degrees of freedom: P(1) and P(2) in closed form, then
    P(k + 2) = P(k) - (x/2)^(k/2) exp(-x/2) / Gamma(k/2 + 1)."""
    if dof < 1 or int(dof) != dof:
        raise ValueError("dof must be a whole number of at least 1")
    if x <= 0.0:
        return 0.0
    half = x / 2.0
    k = 2 if dof % 2 == 0 else 1
    p = 1.0 - math.exp(-half) if k == 2 else math.erf(math.sqrt(half))
    while k < dof:
        p -= math.exp((k / 2.0) * math.log(half) - half - math.lgamma(k / 2.0 + 1.0))
        k += 2
    return min(max(p, 0.0), 1.0)


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
