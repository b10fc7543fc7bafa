"""Resampling of weighted particle sets, and the paper's redistribution step.

Weights are normalised (they sum to 1). The resamplers are pure functions of the weights and
the uniform numbers drawn (:func:`systematic_resample`, :func:`multinomial_resample`; as
FilterPy's ``filterpy.monte_carlo``) returning the indexes of the particles kept;
:func:`low_variance` and :func:`multinomial` draw those numbers from the caller's
``numpy.random.Generator`` first.
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


def systematic_resample(weights: FloatArray, n: int, u0: float) -> NDArray[np.intp]:
    """Low-variance (systematic) resampling: the indexes of ``n`` draws from the normalised
    ``weights`` at the positions ``(u0 + i) / n``, ``u0`` one uniform number in [0, 1).

    Particle ``i`` is drawn ``floor(n w_i)`` or ``ceil(n w_i)`` times, so the expected count is
    ``n w_i`` with the least possible spread (Thrun, Burgard and Fox, Probabilistic Robotics,
    table 4.4; FilterPy's ``systematic_resample``, with the count and the draw given): a
    position selects the first particle whose cumulative weight exceeds it.
    """
    c = np.cumsum(weights)
    c[-1] = 1.0
    u = (u0 + np.arange(n)) / n
    return np.minimum(np.searchsorted(c, u, side="right"), len(weights) - 1)


def multinomial_resample(weights: FloatArray, u: FloatArray) -> NDArray[np.intp]:
    """Multinomial resampling: the index drawn by each uniform number of ``u`` (in [0, 1)),
    independently, with the probabilities ``weights`` (normalised): the first particle whose
    cumulative weight exceeds it (FilterPy's ``multinomial_resample``, the draws given)."""
    c = np.cumsum(weights)
    c[-1] = 1.0
    return np.minimum(np.searchsorted(c, u, side="right"), len(weights) - 1)


def low_variance(weights: FloatArray, n: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """:func:`systematic_resample` of ``n`` from one ``rng.random()``."""
    return systematic_resample(weights, n, rng.random())


def multinomial(weights: FloatArray, n: int, rng: np.random.Generator) -> NDArray[np.intp]:
    """:func:`multinomial_resample` of ``rng.random(n)``: ``n`` independent draws."""
    return multinomial_resample(weights, rng.random(n))


#: the resamplers by the name of ``pf``'s ``resampler`` setting
RESAMPLERS = {"low-variance": low_variance, "multinomial": multinomial}


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


class RedistributionDraws:
    """The random part of ``count`` consecutive redistributions, drawn in one call (the same
    numbers, in the same order, as ``count`` draws of one redistribution each).

    Per redistribution ``b``: ``slots[b]`` (which of the parents, in the order of the top
    weights, each local particle descends from), ``local_z[b]`` and ``local_th[b]`` (the
    offsets of the local particles from their parents, m and rad), ``far_z[b]`` and
    ``far_th[b]`` (the uniform particles, m and rad). With ``packed`` instead, the same laid
    out for particles packed as rows ``(z, rot, 1)`` (``rot = exp(i th)``): the new set is
    ``parents * scale[b] + shift[b]``, with ``parents`` the rows ``slots_all[b]`` of the
    parents in the order of the top weights (the uniform particles take any parent and a
    scale of 0). With ``raw``, only the uniform numbers ``u`` (count, 4, M) that all of these
    are made of, for :func:`lgvtool.localize.pf_kernels.paper_resample`.
    """

    __slots__ = ("_plan", "count", "far_th", "far_z", "local_th", "local_z", "raw", "scale",
                 "shift", "slots", "slots_all", "u")

    def __init__(self, plan: RedistributionPlan, rng: np.random.Generator, count: int, *,
                 packed: bool = False, raw: bool = False) -> None:
        m, n_local = plan.m, plan.n_local
        self.count = count
        self._plan = plan
        self.raw = raw
        if raw:
            self.u = rng.random((count, 4, m))
            return
        if not packed:
            u = rng.random((count, 4, m))
            off = u[:, 1:] * plan.width
            off += plan.low
            self.slots = (u[:, 0, :n_local] * plan.n_top).astype(np.intp)
            offz = off[:, 0] + 1j * off[:, 1]
            self.local_z = offz[:, :n_local]
            self.local_th = off[:, 2, :n_local]
            self.far_z = plan.far_z + offz[:, n_local:]
            self.far_th = plan.far_th + off[:, 2, n_local:]
            return
        # the parts that do not change from one draw to the next
        self.slots_all = np.zeros((count, m), dtype=np.intp)
        self.scale = np.zeros((count, m, 3), dtype=np.complex128)
        self.scale[:, :n_local, 0] = 1.0
        self.scale[:, :, 2] = 1.0
        self.shift = np.zeros((count, m, 3), dtype=np.complex128)
        self.refill(rng)

    def refill(self, rng: np.random.Generator) -> None:
        """Draw the next ``count`` redistributions into the arrays of this (packed) draw."""
        if self.raw:
            rng.random(out=self.u)
            return
        plan = self._plan
        n_local = plan.n_local
        u = rng.random((self.count, 4, plan.m))
        self.slots_all[:, :n_local] = u[:, 0, :n_local] * plan.n_top  # truncated, as astype
        off = u[:, 1:]
        off *= plan.width
        off += plan.low
        turn = np.exp(1j * off[:, 2])
        self.scale[:, :n_local, 1] = turn[:, :n_local]
        z = self.shift[:, :, 0]
        z.real = off[:, 0]
        z.imag = off[:, 1]
        z[:, n_local:] += plan.far_z
        self.shift[:, n_local:, 1] = turn[:, n_local:]


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
        #: the centre of the work area (complex, m)
        self.centre = centre = complex(0.5 * (area.x_min + area.x_max),
                                       0.5 * (area.y_min + area.y_max))
        self.far_z = np.full(m - n_local, centre)
        self.far_th = np.zeros(m - n_local)
        self._all = np.arange(m)
        #: where :meth:`top` partitions the weights (0: every particle is a parent)
        self.kth = m - self.n_top
        #: the same for :func:`lgvtool.localize.pf_kernels.paper_resample`: the widths and
        #: lows of a local particle (x, y m, heading rad) and of a uniform one, the centre
        #: (x, y m), the number of parents and of local particles
        self.kernel_plan = np.array([*self.width[:, 0], *self.low[:, 0], *self.width[:, -1],
                                     *self.low[:, -1], centre.real, centre.imag, self.n_top,
                                     n_local], dtype=np.float64)

    def draw(self, rng: np.random.Generator, count: int = 1, *, packed: bool = False,
             raw: bool = False) -> RedistributionDraws:
        """The random numbers of the next ``count`` redistributions (with ``packed``, also
        laid out for :meth:`apply_packed`; with ``raw``, only the uniform numbers, for
        :func:`lgvtool.localize.pf_kernels.paper_resample`)."""
        return RedistributionDraws(self, rng, count, packed=packed, raw=raw)

    def apply(self, z: NDArray[np.complex128], th: FloatArray, weights: FloatArray,
              rng: np.random.Generator) -> tuple[NDArray[np.complex128], FloatArray]:
        """New positions and headings (local particles first)."""
        return self.apply_drawn(z, th, weights, self.draw(rng), 0)

    def apply_drawn(self, z: NDArray[np.complex128], th: FloatArray, weights: FloatArray,
                    draws: RedistributionDraws, b: int
                    ) -> tuple[NDArray[np.complex128], FloatArray]:
        """New positions and headings (local particles first) from redistribution ``b`` of
        numbers drawn ahead."""
        m, n_local = self.m, self.n_local
        parents = self.top(weights)[draws.slots[b]]
        new_z = np.empty(m, dtype=np.complex128)
        np.add(z[parents], draws.local_z[b], out=new_z[:n_local])
        new_z[n_local:] = draws.far_z[b]
        new_th = np.empty(m)
        np.add(th[parents], draws.local_th[b], out=new_th[:n_local])
        new_th[n_local:] = draws.far_th[b]
        return new_z, new_th

    def apply_packed(self, state: NDArray[np.complex128], weights: FloatArray,
                     draws: RedistributionDraws, b: int, out: NDArray[np.complex128]) -> None:
        """:meth:`apply_drawn` on particles packed as the rows of ``state`` (M, 3): columns
        ``z`` (m), ``rot`` (heading rotor ``exp(i th)``) and ones; writes ``out`` (M, 3). The
        weights need not be normalised. A heading offset multiplies the parent's rotor by
        ``exp(i offset)``."""
        state.take(self.top(weights)[draws.slots_all[b]], axis=0, out=out)
        np.multiply(out, draws.scale[b], out=out)
        np.add(out, draws.shift[b], out=out)

    def top(self, weights: FloatArray) -> NDArray[np.intp]:
        """Indices of the ``n_top`` heaviest particles, in the order of numpy's
        ``argpartition`` (the parents' order, on which the redistribution depends)."""
        kth = self.kth
        return weights.argpartition(kth)[kth:] if kth > 0 else self._all
