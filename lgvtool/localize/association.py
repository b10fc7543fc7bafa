"""Association of measured reflectors with the layout: by the device's id when it checks out,
else by nearest neighbour inside a gate; none, or dropped, when the gate holds nothing or two
layout reflectors alike.

A navigation device that matches reflectors to its layout (a NAV350) reports the id of the
layout reflector it matched: sometimes wrong where the geometry is ambiguous (two reflectors
close together, a shiny object beside one, a mis-surveyed layout), and none (-1, or an id not in
the layout) where it matched nothing; a NAV200 reports no ids at all. So an id is a hint to be
checked, never the association itself. For each measured reflector ``k``, given its squared
distance ``d2[k, j]`` to every layout reflector ``j`` (a squared Mahalanobis distance, or m^2:
the rule is the same) and a squared gate ``gate2``:

1. with an id (``known[k] >= 0``, the layout index of the id): the id's reflector, if it is
   inside the gate (``d2[k, known[k]] <= gate2``);
2. otherwise (no id, or the id failed its gate): the nearest layout reflector ``j1``, if it is
   inside the gate, unless a second one ``j2`` is inside the gate as well at less than
   ``ratio`` times the distance of the nearest (``d2[k, j2] < ratio^2 d2[k, j1]``): then the
   measurement is ambiguous and dropped;
3. none when nothing is inside the gate.

Not-a-number distances count as infinite. Ties go to the first layout reflector (as
``numpy.argmin``). The estimators apply the same rule: ``ekf`` against its pose estimate in
Mahalanobis distance (:class:`lgvtool.localize.ekf.Ekf`), ``pf`` per particle in metres with a
gate radius per reflector from its noise (:mod:`lgvtool.localize.particle_filter`); their
compiled kernels repeat it in loops.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: how a measured reflector was associated (:func:`associate`'s second result)
NONE, BY_ID, NEAREST, AMBIGUOUS = 0, 1, 2, 3
HOW = {NONE: "none in the gate", BY_ID: "by its id", NEAREST: "nearest in the gate",
       AMBIGUOUS: "ambiguous"}


def associate(d2: FloatArray, known: IntArray, gate2: float, ratio: float
              ) -> tuple[IntArray, NDArray[np.int8]]:
    """Associate measured reflectors with layout reflectors (the rule of the module doc).

    :param d2: (K, J) squared distance of measured reflector ``k`` to layout reflector ``j``
        (squared Mahalanobis distance, dimensionless, or m^2).
    :param known: (K,) layout index of each measured reflector's id, -1 for none (no id, or an
        id that is not in the layout).
    :param gate2: the squared gate, in the unit of ``d2``.
    :param ratio: ambiguity ratio of distances (not squared), at least 1: a second layout
        reflector inside the gate nearer than ``ratio`` times the nearest makes the measurement
        ambiguous (1: never ambiguous).
    :returns: ``(j, how)``: per measured reflector the layout index (-1: none) and how it was
        associated (:data:`BY_ID`, :data:`NEAREST`, :data:`NONE`, :data:`AMBIGUOUS`).
    """
    d = np.asarray(d2, dtype=np.float64)
    n_obs, n_map = d.shape
    known = np.asarray(known, dtype=np.int64)
    out = np.full(n_obs, -1, dtype=np.int64)
    how = np.full(n_obs, NONE, dtype=np.int8)
    if n_map == 0 or n_obs == 0:
        return out, how
    d = np.where(np.isnan(d), np.inf, d)
    rows = np.arange(n_obs)
    has = (known >= 0) & (known < n_map)
    by_id = has & (d[rows, np.where(has, known, 0)] <= gate2)
    best = np.argmin(d, axis=1)
    d1 = d[rows, best]
    second = np.partition(d, 1, axis=1)[:, 1] if n_map > 1 else np.full(n_obs, np.inf)
    inside = d1 <= gate2
    ambiguous = inside & (second <= gate2) & (second < (ratio * ratio) * d1)
    nearest = ~by_id & inside & ~ambiguous
    out[by_id] = known[by_id]
    out[nearest] = best[nearest]
    how[by_id] = BY_ID
    how[nearest] = NEAREST
    how[~by_id & ambiguous] = AMBIGUOUS
    return out, how


def associate_points(points: NDArray[np.complex128], layout: NDArray[np.complex128],
                     known: IntArray, gate_m: float, ratio: float
                     ) -> tuple[IntArray, NDArray[np.int8]]:
    """:func:`associate` of measured points (complex ``x + iy``, m, in the layout's frame: the
    measurements put into the world at a pose) with layout reflectors (complex, m), by
    Euclidean distance with a gate of ``gate_m`` metres."""
    p = np.asarray(points, dtype=np.complex128)
    lay = np.asarray(layout, dtype=np.complex128)
    e = lay[None, :] - p[:, None]
    d2 = e.real * e.real + e.imag * e.imag
    return associate(d2, known, gate_m * gate_m, ratio)


def safe_radius(half_sep: FloatArray, gate_m: FloatArray | float, ratio: float) -> FloatArray:
    """Per layout reflector ``c`` with half the distance to its nearest neighbour ``h``
    (``half_sep``, m): the distance (m) from ``c`` within which a point provably has ``c`` as
    its nearest layout reflector, inside a gate of ``gate_m`` m, and unambiguously so (every
    other reflector is at least ``2 h - d`` from a point at ``d`` from ``c``: beyond the gate
    when ``d < 2 h - gate``, at least ``ratio`` times as far when ``d <= 2 h / (1 + ratio)``).
    A point nearer than this needs no search of the layout."""
    h = np.asarray(half_sep, dtype=np.float64)
    g = np.asarray(gate_m, dtype=np.float64)
    unambiguous = np.maximum(2.0 * h - g, 2.0 * h / (1.0 + ratio))
    out: FloatArray = np.maximum(np.minimum(np.minimum(h, g), unambiguous), 0.0)
    return out
