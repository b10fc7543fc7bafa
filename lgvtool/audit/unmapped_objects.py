"""Detections that match no layout reflector, clustered into objects (the audit's ``unmapped``).

A log's unmatched detections (map frame, m) are put on a grid of ``unmapped_radius_m`` cells;
occupied cells that touch (the eight neighbours) form one cluster. Each cluster keeps only
moments (count, mean, scatter; and those of its time blocks' means), so clusters of many logs
pool: clusters whose centres lie within two cells of each other are one object. An object seen
at least ``unmapped_min_sightings`` times is listed. Pure: arrays in, arrays out.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.audit.audit_moments import Moments, block_moments, standard_error
from lgvtool.audit.audit_settings import AuditSettings

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["UnmappedEvidence", "UnmappedObject", "listed_objects", "pooled_unmapped",
           "unmapped_evidence"]

MAX_CLUSTERS = 2000
"""Most clusters a log keeps (the largest): a log full of passing reflections stays small."""


@dataclass(frozen=True)
class UnmappedEvidence:
    """Clusters of unmatched detections: the moments of their positions (x, y m) and of their
    time blocks' mean positions."""

    points: Moments
    blocks: Moments

    def __len__(self) -> int:
        return len(self.points.n)


@dataclass(frozen=True)
class UnmappedObject:
    """A recurring detection that matches no layout reflector: where it is (m), how often it
    was seen, and the 1-sigma of its position per axis (m, the larger of the two)."""

    x: float
    y: float
    sightings: int
    sigma_m: float


def _components(pairs: list[tuple[int, int]], n: int) -> IntArray:
    """Connected components of ``n`` nodes joined by ``pairs``: a label per node."""
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in pairs:
        ra, rb = root(a), root(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    roots = np.array([root(i) for i in range(n)], dtype=np.int64)
    _, labels = np.unique(roots, return_inverse=True)
    return labels.astype(np.int64)


def unmapped_evidence(x: FloatArray, y: FloatArray, block: IntArray,
                      settings: AuditSettings) -> UnmappedEvidence:
    """The clusters of the unmatched detections at (x, y) (m) seen in the time blocks
    ``block`` (see the module doc)."""
    cell = settings.unmapped_radius_m
    if len(x) == 0:
        return UnmappedEvidence(Moments.empty(0, 2), Moments.empty(0, 2))
    cx = np.floor(np.asarray(x) / cell).astype(np.int64)
    cy = np.floor(np.asarray(y) / cell).astype(np.int64)
    cells, inv = np.unique(np.stack([cx, cy], axis=1), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    index = {(int(a), int(b)): i for i, (a, b) in enumerate(cells.tolist())}
    pairs = [(i, j) for (a, b), i in index.items()
             for da in (-1, 0, 1) for db in (-1, 0, 1)
             if (j := index.get((a + da, b + db), -1)) > i]
    label = _components(pairs, len(cells))[inv]
    groups = int(label.max()) + 1
    values = np.stack([x, y], axis=1)
    ev = UnmappedEvidence(Moments.of(label, values, groups),
                          block_moments(label, values, np.asarray(block, np.int64), groups))
    return _largest(ev, MAX_CLUSTERS)


def _take(m: Moments, rows: IntArray) -> Moments:
    return Moments(m.n[rows], m.mean[rows], m.m2[rows])


def _largest(ev: UnmappedEvidence, most: int) -> UnmappedEvidence:
    """The ``most`` clusters seen most often."""
    if len(ev) <= most:
        return ev
    keep = np.sort(np.argsort(-ev.points.n, kind="stable")[:most])
    return UnmappedEvidence(_take(ev.points, keep), _take(ev.blocks, keep))


def _grouped(m: Moments, label: IntArray, groups: int) -> Moments:
    """The moments of the groups ``label`` of ``m``'s groups merged (the parallel formula for
    many sets at once: counts add, means weigh by count, scatters add with each set's mean's
    spread about the merged mean)."""
    k = m.mean.shape[1]
    n = np.bincount(label, weights=m.n, minlength=groups).astype(np.float64)
    safe = np.maximum(n, 1.0)
    mean = np.stack([np.bincount(label, weights=m.n * m.mean[:, a], minlength=groups)
                     for a in range(k)], axis=1) / safe[:, None]
    d = m.mean - mean[label]
    m2 = np.zeros((groups, k, k))
    for a in range(k):
        for b in range(k):
            m2[:, a, b] = np.bincount(label, weights=m.m2[:, a, b] + m.n * d[:, a] * d[:, b],
                                      minlength=groups)
    return Moments(n, mean, m2)


def pooled_unmapped(parts: Sequence[UnmappedEvidence], settings: AuditSettings
                    ) -> UnmappedEvidence:
    """The clusters of several logs pooled: clusters whose centres lie within two grid cells
    (``2 unmapped_radius_m``) of each other, directly or through others, are one."""
    parts = [p for p in parts if len(p)]
    if not parts:
        return UnmappedEvidence(Moments.empty(0, 2), Moments.empty(0, 2))
    points = Moments(*(np.concatenate([getattr(p.points, f) for p in parts])
                       for f in ("n", "mean", "m2")))
    blocks = Moments(*(np.concatenate([getattr(p.blocks, f) for p in parts])
                       for f in ("n", "mean", "m2")))
    c = points.mean
    d2 = ((c[:, None, :] - c[None, :, :]) ** 2).sum(axis=2)
    reach = (2.0 * settings.unmapped_radius_m) ** 2
    a, b = np.nonzero(np.triu(d2 <= reach, 1))
    label = _components(list(zip(a.tolist(), b.tolist(), strict=True)), len(c))
    groups = int(label.max()) + 1
    pooled = UnmappedEvidence(_grouped(points, label, groups), _grouped(blocks, label, groups))
    return _largest(pooled, MAX_CLUSTERS)


def listed_objects(ev: UnmappedEvidence, settings: AuditSettings) -> list[UnmappedObject]:
    """The clusters seen at least ``unmapped_min_sightings`` times, most seen first."""
    if not len(ev):
        return []
    sigma = standard_error(ev.points, ev.blocks)
    out = []
    for g in np.argsort(-ev.points.n, kind="stable").tolist():
        n = int(ev.points.n[g])
        if n < settings.unmapped_min_sightings:
            continue
        s = float(np.nanmax(sigma[g])) if np.any(np.isfinite(sigma[g])) else float("nan")
        out.append(UnmappedObject(float(ev.points.mean[g, 0]), float(ev.points.mean[g, 1]), n,
                                  s))
    return out
