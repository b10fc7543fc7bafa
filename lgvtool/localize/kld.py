"""KLD-sampling: how many particles a belief needs (Fox, "Adapting the sample size in
particle filters through KLD-sampling", IJRR 2003; the rule AMCL uses).

With ``k`` histogram bins holding at least one particle, ``n`` particles bound the
Kullback-Leibler divergence between the sampled and the true belief by ``epsilon`` with
probability ``1 - delta``:

``n = (k - 1) / (2 epsilon) * (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_{1-delta})^3``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from statistics import NormalDist

import numpy as np
from numpy.typing import NDArray


def kld_bound(k: int | NDArray[np.int64], epsilon: float, delta: float
              ) -> NDArray[np.float64]:
    """Particles needed for ``k`` occupied bins (array or scalar); 1 where ``k <= 1``."""
    z = NormalDist().inv_cdf(1.0 - delta)
    km1 = np.maximum(np.asarray(k, dtype=np.float64) - 1.0, 1e-12)
    a = 2.0 / (9.0 * km1)
    n = km1 / (2.0 * epsilon) * (1.0 - a + np.sqrt(a) * z) ** 3
    return np.where(np.asarray(k) <= 1, 1.0, n)


def bin_keys(x: NDArray[np.float64], y: NDArray[np.float64], th: NDArray[np.float64],
             bin_xy: float, bin_th: float) -> NDArray[np.int64]:
    """One integer per pose naming its histogram bin (``bin_xy`` m, ``bin_th`` rad)."""
    ix = np.floor(x / bin_xy).astype(np.int64)
    iy = np.floor(y / bin_xy).astype(np.int64)
    it = np.floor((th + math.pi) / bin_th).astype(np.int64)
    return (ix * 1_000_003 + iy) * 4099 + it


def occupied_bins(x: NDArray[np.float64], y: NDArray[np.float64], th: NDArray[np.float64],
                  bin_xy: float, bin_th: float) -> int:
    """Number of distinct bins the poses fall in."""
    return int(np.unique(bin_keys(x, y, th, bin_xy, bin_th)).size)


def kld_count(keys_in_draw_order: NDArray[np.int64], epsilon: float, delta: float,
              n_min: int, n_max: int) -> int:
    """Sample size chosen by sequential KLD-sampling over draws whose bins are given in the
    order they were drawn: the first ``n`` with ``n >= bound(bins among the first n)``, clamped
    to ``[n_min, n_max]``."""
    m = len(keys_in_draw_order)
    if m == 0:
        return n_min
    _, first = np.unique(keys_in_draw_order, return_index=True)
    new_bin = np.zeros(m, dtype=np.int64)
    new_bin[first] = 1
    k = np.cumsum(new_bin)
    # the bound depends on the count of bins only: computed once per count (k[-1] of them,
    # far fewer than the draws), then looked up per draw
    need = kld_bound(np.arange(1, int(k[-1]) + 1), epsilon, delta)[k - 1]
    n = np.arange(1, m + 1)
    ok = np.nonzero(n >= np.maximum(need, n_min))[0]
    chosen = int(ok[0]) + 1 if len(ok) else m
    return int(min(max(chosen, n_min), n_max))



@dataclass(frozen=True)
class KldSizing:
    """A filter's KLD-sampling: error bound ``epsilon`` with probability ``1 - delta``, between
    ``n_min`` and ``cap`` particles, over bins of ``bin_m`` (x and y, m) by ``bin_rad``
    (heading, rad)."""

    epsilon: float
    delta: float
    n_min: int
    cap: int
    bin_m: float
    bin_rad: float

    @cached_property
    def need(self) -> NDArray[np.float64]:
        """The particles needed for 1 to :attr:`cap` occupied bins (:func:`kld_bound`), made
        once (the compiled resampling looks each count up)."""
        return kld_bound(np.arange(1, self.cap + 1), self.epsilon, self.delta)

    def count(self, x: NDArray[np.float64], y: NDArray[np.float64],
              th: NDArray[np.float64]) -> int:
        """The sample size for poses drawn in this order (x, y m, heading rad):
        :func:`kld_count` of their bins."""
        return kld_count(bin_keys(x, y, th, self.bin_m, self.bin_rad), self.epsilon,
                         self.delta, self.n_min, self.cap)
