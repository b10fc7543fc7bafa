"""Pooled moments: count, mean and scatter of vectors in groups, merged exactly.

The audit's evidence of a log is kept as these sufficient statistics, never as raw arrays, so
that the evidence of many logs (on the fleet engine's workers) pools into what one long log
would have given: :meth:`Moments.merged` combines two sets by Chan's parallel formula (no
cancellation however far the means lie from zero: times in days since the epoch, positions in
m).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["Moments", "block_moments", "standard_error"]


@dataclass(frozen=True)
class Moments:
    """Per group g (of ``groups``): the count ``n[g]`` of k-vectors, their ``mean[g]`` (k) and
    the sum of the outer products of their deviations from it, ``m2[g]`` (k x k); in the unit
    of the vectors (m2 in its square)."""

    n: FloatArray
    mean: FloatArray
    m2: FloatArray

    @classmethod
    def empty(cls, groups: int, k: int) -> Moments:
        """No vector in any of ``groups`` groups of k-vectors."""
        return cls(np.zeros(groups), np.zeros((groups, k)), np.zeros((groups, k, k)))

    @classmethod
    def of(cls, group: IntArray, values: FloatArray, groups: int) -> Moments:
        """The moments of ``values`` (n, k) in the groups ``group`` (n, each in
        ``range(groups)``)."""
        v = np.asarray(values, dtype=np.float64)
        g = np.asarray(group, dtype=np.int64)
        k = v.shape[1]
        n = np.bincount(g, minlength=groups).astype(np.float64)
        safe = np.maximum(n, 1.0)
        mean = np.stack([np.bincount(g, weights=v[:, a], minlength=groups) / safe
                         for a in range(k)], axis=1) if k else np.zeros((groups, 0))
        d = v - mean[g]
        m2 = np.zeros((groups, k, k))
        for a in range(k):
            for b in range(a, k):
                m2[:, a, b] = m2[:, b, a] = np.bincount(g, weights=d[:, a] * d[:, b],
                                                        minlength=groups)
        return cls(n, mean, m2)

    def merged(self, other: Moments) -> Moments:
        """The moments of both sets of vectors together (same groups, same k)."""
        if self.n.shape != other.n.shape or self.mean.shape != other.mean.shape:
            raise ValueError("moments of different groups cannot be merged")
        n = self.n + other.n
        safe = np.maximum(n, 1.0)
        delta = other.mean - self.mean
        mean = self.mean + delta * (other.n / safe)[:, None]
        w = (self.n * other.n / safe)[:, None, None]
        m2 = self.m2 + other.m2 + w * delta[:, :, None] * delta[:, None, :]
        return Moments(n, mean, m2)

    def covariance(self) -> FloatArray:
        """Sample covariance per group (k x k, unit squared); NaN with fewer than 2 vectors."""
        with np.errstate(invalid="ignore", divide="ignore"):
            out: FloatArray = np.where((self.n >= 2.0)[:, None, None],
                                       self.m2 / np.maximum(self.n - 1.0, 1.0)[:, None, None],
                                       np.nan)
        return out


def block_moments(group: IntArray, values: FloatArray, block: IntArray, groups: int
                  ) -> Moments:
    """Moments, per group (``groups`` of them), of the means of ``values`` (rows, the vectors'
    unit) over each (group, time block): what :func:`standard_error` takes as ``blocks``."""
    if len(group) == 0:
        return Moments.empty(groups, values.shape[1])
    key = np.stack([group, block], axis=1)
    uniq, inv = np.unique(key, axis=0, return_inverse=True)
    means = Moments.of(inv.reshape(-1), values, len(uniq)).mean
    return Moments.of(uniq[:, 0], means, groups)


def standard_error(points: Moments, blocks: Moments) -> FloatArray:
    """Standard error per group and axis (group x k, the vectors' unit) of the mean of the
    ``points``, which arrived in the time ``blocks`` whose means ``blocks`` holds (the same
    groups): the scatter of the block means over their count when there are four blocks or
    more (neighbouring points share their errors; blocks far apart do not), never below the
    points' own scatter over their count; with fewer blocks the points' scatter over the
    number of blocks (as if each block were one point: conservative). NaN with fewer than
    two points."""
    within = np.diagonal(points.covariance(), axis1=1, axis2=2)
    between = np.diagonal(blocks.covariance(), axis1=1, axis2=2)
    nb = np.maximum(blocks.n, 1.0)[:, None]
    npts = np.maximum(points.n, 1.0)[:, None]
    many = (blocks.n >= 4.0)[:, None]
    with np.errstate(invalid="ignore"):
        var = np.where(many, np.maximum(between / nb, within / npts), within / nb)
    out: FloatArray = np.sqrt(var)
    return out
