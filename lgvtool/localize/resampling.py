"""Resampling of weighted particle sets, and the paper's redistribution step.

Weights are normalised (they sum to 1). Every random draw comes from the caller's
``numpy.random.Generator``.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Area

FloatArray = NDArray[np.float64]


def effective_sample_size(weights: FloatArray) -> float:
    """``1 / sum(w^2)`` of normalised weights: ``n`` for equal weights, 1 for a single one."""
    return float(1.0 / np.dot(weights, weights))


def low_variance(weights: FloatArray, n: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """Low-variance (systematic) resampling: ``n`` indices from one uniform offset.

    Particle ``i`` is copied ``floor(n w_i)`` or ``ceil(n w_i)`` times, so the expected count is
    ``n w_i`` with the least possible spread (Thrun, Burgard and Fox, Probabilistic Robotics,
    table 4.4).
    """
    c = np.cumsum(weights)
    c[-1] = 1.0
    u = (rng.random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(c, u, side="right"), len(weights) - 1)


def multinomial(weights: FloatArray, n: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """``n`` independent draws with probabilities ``weights``."""
    c = np.cumsum(weights)
    c[-1] = 1.0
    return np.minimum(np.searchsorted(c, rng.random(n), side="right"), len(weights) - 1)


def uniform_poses(rng: np.random.Generator, n: int, area: Area
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``n`` poses uniform over ``area`` (m) with uniform heading in [-pi, pi) (rad)."""
    u = rng.random((3, n))
    return (area.x_min + u[0] * area.width, area.y_min + u[1] * area.height,
            (u[2] * 2.0 - 1.0) * math.pi)


def redistribute(z: NDArray[np.complex128], th: FloatArray, weights: FloatArray,
                 rng: np.random.Generator, area: Area, *, top_fraction: float,
                 local_fraction: float, spread_m: float, heading_spread_rad: float
                 ) -> tuple[NDArray[np.complex128], FloatArray, int]:
    """The paper's redistribution (section 3.2).

    The ``top_fraction`` of particles with the highest weights are the parents; a
    ``local_fraction`` of the new set is drawn around parents chosen uniformly among them,
    uniformly within ``+-spread_m`` in x and y (m) and ``+-heading_spread_rad`` in heading
    (rad); the rest is uniform over the work area with uniform heading. The set keeps its size.
    Positions are complex ``x + iy``. Returns the new positions, headings (not wrapped) and
    the number of local particles (they come first).
    """
    plan = RedistributionPlan(len(z), area, top_fraction=top_fraction,
                              local_fraction=local_fraction, spread_m=spread_m,
                              heading_spread_rad=heading_spread_rad)
    new_z, new_th = plan.apply(z, th, weights, rng)
    return new_z, new_th, plan.n_local


class RedistributionPlan:
    """The constant part of the paper's redistribution for a set of ``m`` particles: how many
    parents and local particles, and the half widths of every particle's uniform draw (around
    its parent, or over the work area and every heading)."""

    def __init__(self, m: int, area: Area, *, top_fraction: float, local_fraction: float,
                 spread_m: float, heading_spread_rad: float) -> None:
        self.m = m
        self.n_top = min(m, max(1, math.ceil(top_fraction * m)))
        self.n_local = n_local = min(m, round(local_fraction * m))
        half = np.empty((3, m))
        half[0, :n_local] = half[1, :n_local] = spread_m
        half[2, :n_local] = heading_spread_rad
        half[0, n_local:] = 0.5 * area.width
        half[1, n_local:] = 0.5 * area.height
        half[2, n_local:] = math.pi
        self.width, self.low = 2.0 * half, -half
        centre = complex(0.5 * (area.x_min + area.x_max), 0.5 * (area.y_min + area.y_max))
        self.far_z = np.full(m - n_local, centre)
        self.far_th = np.zeros(m - n_local)

    def apply(self, z: NDArray[np.complex128], th: FloatArray, weights: FloatArray,
              rng: np.random.Generator) -> tuple[NDArray[np.complex128], FloatArray]:
        """New positions and headings (local particles first)."""
        m, n_top = self.m, self.n_top
        order = np.argpartition(weights, m - n_top)[m - n_top:] if n_top < m else np.arange(m)
        u = rng.random((4, m))
        parents = order[(u[0, :self.n_local] * n_top).astype(np.intp)]
        off = u[1:] * self.width
        off += self.low
        new_z = np.concatenate((z[parents], self.far_z))
        new_z += off[0] + 1j * off[1]
        new_th = np.concatenate((th[parents], self.far_th))
        new_th += off[2]
        return new_z, new_th
