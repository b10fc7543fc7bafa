"""The observations of one estimator as a lazy sequence (:class:`ObservationStream`).

A one-hour paper-circle log holds 28 800 reflector scans; as body-frame geometry
(:class:`ScanObservation`) they take about 40 MB per estimator that uses every scan. The
stream knows every observation's time from the start (the scans' start times and periods are
decoded once), but builds the scans' geometry block by block as the estimator reaches them
and keeps only the most recent blocks, so memory no longer grows with the log's length. The
observations, their order (NAV poses and scans merged by time, stably, poses first on ties)
and every value are those the whole-list construction gives.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Iterator, Sequence
from typing import Generic, Protocol, TypeVar, overload

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.observations import PoseObservation, ScanObservation

Obs = PoseObservation | ScanObservation
FloatArray = NDArray[np.float64]
#: the first item of a :class:`Tail` (a marker, None, or an observation)
_F = TypeVar("_F")
_G = TypeVar("_G")
#: an observation a :class:`BlockwiseMap` prepares, and what it prepares of it
_O = TypeVar("_O")
_V = TypeVar("_V")


class Timed(Protocol):
    """Anything with a time ``t`` (s): an observation, or a marker of a time."""

    @property
    def t(self) -> float: ...


#: scans whose geometry is built at a time
BLOCK_SCANS = 512
#: scans whose geometry is kept at most (older blocks are dropped, rebuilt if asked again)
KEEP_SCANS = 8192


class ObservationStream(Sequence[Obs]):
    """NAV poses and reflector scans in time order; scan geometry built on demand.

    :param poses: the pose observations, in time order.
    :param scan_t: the observation time of each scan (s), in the order ``build`` numbers them.
    :param build: the geometry of scans ``[a, b)``: ``b - a`` scan observations whose times
        are ``scan_t[a:b]``.
    """

    def __init__(self, poses: Sequence[PoseObservation], scan_t: FloatArray,
                 build: Callable[[int, int], list[ScanObservation]]) -> None:
        self._poses = list(poses)
        self._build = build
        self._n_scans = len(scan_t)
        keys = np.concatenate([np.array([p.t for p in self._poses], dtype=np.float64),
                               np.asarray(scan_t, dtype=np.float64)])
        order = np.argsort(keys, kind="stable")
        #: the time of each observation, s (sorted)
        self.times: FloatArray = keys[order]
        self._order: list[int] = order.tolist()
        self._blocks: OrderedDict[int, list[ScanObservation]] = OrderedDict()

    def __len__(self) -> int:
        return len(self._order)

    def _scan(self, s: int) -> ScanObservation:
        b = s // BLOCK_SCANS
        block = self._blocks.get(b)
        if block is None:
            a = b * BLOCK_SCANS
            block = self._build(a, min(a + BLOCK_SCANS, self._n_scans))
            self._blocks[b] = block
            while len(self._blocks) * BLOCK_SCANS > KEEP_SCANS:
                self._blocks.popitem(last=False)
        else:
            self._blocks.move_to_end(b)
        return block[s - b * BLOCK_SCANS]

    def _item(self, j: int) -> Obs:
        n = len(self._poses)
        return self._poses[j] if j < n else self._scan(j - n)

    @overload
    def __getitem__(self, k: int) -> Obs: ...

    @overload
    def __getitem__(self, k: slice) -> list[Obs]: ...

    def __getitem__(self, k: int | slice) -> Obs | list[Obs]:
        if isinstance(k, slice):
            return [self._item(self._order[i]) for i in range(*k.indices(len(self)))]
        return self._item(self._order[k])

    def __iter__(self) -> Iterator[Obs]:
        for j in self._order:
            yield self._item(j)


class Tail(Sequence[_F | Obs], Generic[_F]):
    """``first`` (at ``first_t`` s) followed by ``rest[start:]`` (a stream or a list), with
    their times."""

    def __init__(self, first: _F, first_t: float, rest: Sequence[Obs], start: int) -> None:
        self._first = first
        self._rest = rest
        self._start = start
        self.times: FloatArray = np.concatenate([[float(first_t)], times_of(rest)[start:]])

    def with_first(self, first: _G) -> Tail[_G]:
        """The same sequence with another first item."""
        return Tail(first, float(self.times[0]), self._rest, self._start)

    def __len__(self) -> int:
        return 1 + len(self._rest) - self._start

    @overload
    def __getitem__(self, k: int) -> _F | Obs: ...

    @overload
    def __getitem__(self, k: slice) -> list[_F | Obs]: ...

    def __getitem__(self, k: int | slice) -> _F | Obs | list[_F | Obs]:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        if k < 0:
            k += len(self)
        if not 0 <= k < len(self):
            raise IndexError("observation index out of range")
        return self._first if k == 0 else self._rest[self._start + k - 1]

    def __iter__(self) -> Iterator[_F | Obs]:
        yield self._first
        for i in range(self._start, len(self._rest)):
            yield self._rest[i]


def times_of(observations: Sequence[Timed]) -> FloatArray:
    """The time (s) of each observation: the stream's own array, else read from each."""
    times = getattr(observations, "times", None)
    if times is not None:
        return np.asarray(times, dtype=np.float64)
    return np.array([o.t for o in observations], dtype=np.float64)


def scan_times(start: FloatArray, period: FloatArray, *, deskew: bool) -> FloatArray:
    """The observation time of scans (s): the end of the revolution when de-skewed, else its
    middle (as :func:`lgvtool.localize.observations.scan_observations` sets them)."""
    return np.asarray(start + period if deskew else start + 0.5 * period, dtype=np.float64)


class BlockwiseMap(Generic[_O, _V]):
    """``prepare(observations)`` (a dict keyed by index in the list given) computed one block
    of ``block`` observations at a time as :meth:`get` reaches it; only the current block is
    kept. For per-observation preparations whose result for one observation does not depend
    on the others (the values are those of one call over all observations)."""

    def __init__(self, prepare: Callable[[Sequence[_O]], dict[int, _V]],
                 observations: Sequence[_O], block: int = BLOCK_SCANS) -> None:
        self._prepare = prepare
        self._observations = observations
        self._size = block
        self._start = -1
        self._block: dict[int, _V] = {}

    def get(self, i: int) -> _V | None:
        """The prepared item of observation ``i`` (None if there is none)."""
        start = i - i % self._size
        if start != self._start:
            part = self._observations[start:start + self._size]
            self._block = {start + k: v for k, v in self._prepare(list(part)).items()}
            self._start = start
        return self._block.get(i)


__all__ = ["BLOCK_SCANS", "KEEP_SCANS", "BlockwiseMap", "ObservationStream", "Tail", "Timed",
           "scan_times", "times_of"]
