"""Observations a chunk at a time, laid out as the compiled replay loops take them.

A chunk is a list of consecutive observations (None: a time at which the estimator only
moves). :func:`scan_chunk` lays it out as flat arrays: a kind per entry, and the points of its
reflector scans one after the other with the offsets of each scan's, so that one kernel call
(``pf_kernels.pf_track``, ``ekf_kernels.track``) can run through many observations.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from itertools import islice
from typing import Any, TypeVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.observations import ScanObservation, ScanPoints

#: kinds of chunk entries: no observation (only move), a reflector scan, anything else (the
#: estimator's own step)
KIND_NONE, KIND_SCAN, KIND_OTHER = 0, 1, 2
#: observations per chunk
CHUNK = 512

_T = TypeVar("_T")


@dataclass(frozen=True)
class ScanChunk:
    """A chunk's entries: ``kinds`` (``KIND_*``), and scan ``j``'s points
    ``offs[j]:offs[j + 1]`` of ``q`` (body frame, complex m), ``u`` (unit rays, body frame),
    ``ranges`` (m) and ``ints`` (an integer per point: reflector ids, or map indices)."""

    kinds: NDArray[np.int8]
    offs: NDArray[np.intp]
    q: NDArray[np.complex128]
    u: NDArray[np.complex128]
    ranges: NDArray[np.float64]
    ints: NDArray[np.int64]


def chunks(observations: Sequence[_T], size: int = CHUNK) -> Iterator[list[_T]]:
    """``observations`` as consecutive lists of at most ``size`` (taken as they are reached:
    a lazy stream builds only what a chunk needs)."""
    it = iter(observations)
    while chunk := list(islice(it, size)):
        yield chunk


def scan_chunk(chunk: Sequence[object],
               ints: Callable[[ScanObservation | ScanPoints], NDArray[np.int64]]
               ) -> ScanChunk:
    """Lay ``chunk`` out for a kernel; ``ints(points)``: the integer column of a scan's points
    (or of a :class:`ScanPoints` block's). Consecutive scans of one block are taken from the
    block as one slice (no copy per scan)."""
    kinds = np.full(len(chunk), KIND_OTHER, dtype=np.int8)
    lens = np.zeros(len(chunk) + 1, dtype=np.intp)
    # runs of points: [block or scan, first scan index, end scan index] (-1: a lone scan)
    runs: list[list[Any]] = []
    for c, o in enumerate(chunk):
        if o is None:
            kinds[c] = KIND_NONE
        elif isinstance(o, ScanObservation):
            kinds[c] = KIND_SCAN
            lens[c + 1] = len(o)
            last = runs[-1] if runs else None
            if o.block is None:
                runs.append([o, -1, -1])
            elif last is not None and last[0] is o.block and last[2] == o.index:
                last[2] = o.index + 1
            else:
                runs.append([o.block, o.index, o.index + 1])
    offs = np.cumsum(lens)
    if not runs:
        e = np.zeros(0, dtype=np.complex128)
        return ScanChunk(kinds, offs, e, e, np.zeros(0), np.zeros(0, dtype=np.int64))
    parts: list[tuple[Any, ...]] = []
    for src, a, b in runs:
        ints_of = ints(src)
        if a < 0:
            parts.append((src.q, src.u, src.ranges, ints_of))
        else:
            lo, hi = src.bounds[a], src.bounds[b]
            parts.append((src.q[lo:hi], src.u[lo:hi], src.ranges[lo:hi], ints_of[lo:hi]))
    if len(parts) == 1:
        q, u, r, i = parts[0]
        return ScanChunk(kinds, offs, np.ascontiguousarray(q, dtype=np.complex128),
                         np.ascontiguousarray(u, dtype=np.complex128),
                         np.ascontiguousarray(r, dtype=np.float64),
                         np.ascontiguousarray(i, dtype=np.int64))
    cols = list(zip(*parts, strict=True))
    return ScanChunk(kinds, offs, np.concatenate(cols[0]).astype(np.complex128, copy=False),
                     np.concatenate(cols[1]).astype(np.complex128, copy=False),
                     np.concatenate(cols[2]).astype(np.float64, copy=False),
                     np.concatenate(cols[3]).astype(np.int64, copy=False))
