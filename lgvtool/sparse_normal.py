"""Sparse normal equations: formed from a Jacobian, scaled, and factorised in a given order.

The one least-squares machinery of lgvtool's batch adjustments (``calibrate``,
:mod:`lgvtool.calibrate.solve`; ``layout refine``, :mod:`lgvtool.audit.layout_refine`): the
normal matrix ``JᵀJ`` of a sparse Jacobian, formed a slice of rows at a time
(:func:`normal_matrix`), its columns scaled to unit norm (:func:`scaled_normal`), and a sparse
LU factorisation (SuperLU, ``scipy.sparse.linalg.splu``) that eliminates the unknowns in the
order the caller gives, pivoting on the diagonal (:class:`Factor`): a pose chain in time order
with its few dense unknowns last factorises without fill beyond the band and the border
(docs/calibration.md, "Solver" and "Long drives").

Needs scipy (the ``calibrate`` extra); imported only by the modules that solve.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

__all__ = ["NORMAL_SLICE_ENTRIES", "Factor", "normal_matrix", "row_slices", "scaled_normal"]

NORMAL_SLICE_ENTRIES = 1 << 21
"""Jacobian entries (about 24 MB) whose part of the normal matrix, or of a covariance's
scores, is formed at a time."""


def scaled_normal(j: sp.csr_matrix) -> tuple[sp.csc_matrix, FloatArray]:
    """The normal matrix of ``j`` with its columns scaled to unit norm, ``D jᵀj D`` with
    ``D = diag(1 / norms)``, and the norms (1 for an empty column). The scaling is applied to
    the normal matrix, so no scaled copy of the (much larger) Jacobian is made."""
    h = normal_matrix(j)
    diagonal = h.diagonal()
    norms = np.sqrt(np.where(diagonal > 0, diagonal, 1.0))
    h.data /= norms[h.indices]  # rows
    h.data /= np.repeat(norms, np.diff(h.indptr))  # columns
    return h, norms


def normal_matrix(j: sp.csr_matrix) -> sp.csc_matrix:
    """``jᵀj``, formed from slices of :data:`NORMAL_SLICE_ENTRIES` entries of ``j``'s rows, so
    that only a slice, never the whole Jacobian, is copied into the column-major form that the
    product takes. The slices' parts are added pairwise (as the digits of a binary counter),
    so each entry of the sum is added about log2(slices) times, not once per slice."""
    partial: list[tuple[int, sp.csc_matrix]] = []  # (level, sum of 2**level slices' parts)
    for part in (s.T @ s for _r0, _r1, s in row_slices(j)):
        level = 0
        while partial and partial[-1][0] == level:
            part = partial.pop()[1] + part
            level += 1
        partial.append((level, part))
    if not partial:
        return sp.csc_matrix((j.shape[1], j.shape[1]))
    total = partial.pop()[1]
    while partial:
        total = total + partial.pop()[1]
    return total.tocsc()


def row_slices(j: sp.csr_matrix) -> Iterator[tuple[int, int, sp.csr_matrix]]:
    """Consecutive runs of ``j``'s rows, each of about :data:`NORMAL_SLICE_ENTRIES` entries
    (a row is never split): first row, end row and the rows as a matrix of their own (scipy
    copies a small part of a larger array), so only one slice is ever copied at a time."""
    indptr = j.indptr
    cuts = np.searchsorted(indptr, np.arange(NORMAL_SLICE_ENTRIES, j.nnz, NORMAL_SLICE_ENTRIES))
    bounds = np.unique(np.concatenate([[0], cuts, [j.shape[0]]]))
    for r0, r1 in zip(bounds[:-1].tolist(), bounds[1:].tolist(), strict=True):
        lo, hi = int(indptr[r0]), int(indptr[r1])
        yield r0, r1, sp.csr_matrix((j.data[lo:hi], j.indices[lo:hi], indptr[r0:r1 + 1] - lo),
                                    shape=(r1 - r0, j.shape[1]))


class Factor:
    """Sparse LU of the symmetric positive definite normal matrix ``h`` with its rows and
    columns taken in ``order`` (the unknowns in the order they are eliminated), pivoting on
    the diagonal. :meth:`solve` takes and returns vectors (or columns of them) in the state's
    order."""

    def __init__(self, h: sp.csc_matrix, order: NDArray[np.int64]) -> None:
        self.order = order
        permuted = h[order][:, order].tocsc()
        self.lu = spla.splu(permuted, permc_spec="NATURAL", diag_pivot_thresh=0.0,
                            options={"SymmetricMode": True})

    def solve(self, b: FloatArray) -> FloatArray:
        """``h^-1 b``."""
        out = np.empty_like(b)
        out[self.order] = self.lu.solve(b[self.order])
        return out
