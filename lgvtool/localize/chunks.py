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
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.observations import ScanObservation

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


def scan_chunk(chunk: Sequence[object], ints: Callable[[ScanObservation], NDArray[np.int64]]
               ) -> ScanChunk:
    """Lay ``chunk`` out for a kernel; ``ints(scan)``: the integer column of its points."""
    kinds = np.full(len(chunk), KIND_OTHER, dtype=np.int8)
    lens = np.zeros(len(chunk) + 1, dtype=np.intp)
    scans: list[ScanObservation] = []
    for c, o in enumerate(chunk):
        if o is None:
            kinds[c] = KIND_NONE
        elif isinstance(o, ScanObservation):
            kinds[c] = KIND_SCAN
            lens[c + 1] = len(o)
            scans.append(o)
    offs = np.cumsum(lens)
    if not scans:
        e = np.zeros(0, dtype=np.complex128)
        return ScanChunk(kinds, offs, e, e, np.zeros(0), np.zeros(0, dtype=np.int64))
    return ScanChunk(
        kinds, offs,
        np.concatenate([o.q for o in scans]).astype(np.complex128, copy=False),
        np.concatenate([o.u for o in scans]).astype(np.complex128, copy=False),
        np.concatenate([o.ranges for o in scans]).astype(np.float64, copy=False),
        np.concatenate([ints(o) for o in scans]).astype(np.int64, copy=False))
