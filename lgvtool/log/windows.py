"""Messages of many streams, encoded one window of log time at a time and merged in order.

A :class:`Source` keeps the numeric rows of one topic (small) and an encoder of any subset of
them; :class:`WindowedMerge` yields, window by window, the rows of every source whose log time
falls in the window, encoded then and sorted by (log time, source rank, row). The batches are
what :meth:`lgvtool.log.writer.LogWriter.copy_from` merges with a log's own messages, so only
one window's JSON texts exist at a time. The output does not depend on the window length.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

WINDOW_NS = 600_000_000_000
"""Log time encoded at once: 10 minutes, in ns."""

Encoder = Callable[["NDArray[np.intp]"], tuple[Sequence[int], list[bytes]]]
"""Rows (increasing indexes) -> (log times in ns, JSON texts) of their messages; a row may give
no message (e.g. a non-finite pose), never more than one."""


class Source(NamedTuple):
    """One topic's messages to be: ``times`` (ns) of its rows and their ``encode``-r."""

    topic: str
    times: NDArray[np.int64]
    encode: Encoder


def source(topic: str, times: Sequence[int] | NDArray[np.int64], encode: Encoder) -> Source:
    """A :class:`Source` with ``times`` as int64 ns."""
    import numpy as np

    return Source(topic, np.asarray(times, dtype=np.int64).reshape(-1), encode)


def constant(topic: str, times: Sequence[int], datas: Sequence[bytes]) -> Source:
    """A source of messages already encoded (a few: the whole list is kept)."""
    import numpy as np

    t = np.asarray(times, dtype=np.int64).reshape(-1)
    kept = list(datas)
    return Source(topic, t, lambda idx: (t[idx].tolist(), [kept[i] for i in idx.tolist()]))


Batch = tuple[list[str], list[bytes], list[int]]


class WindowedMerge:
    """Iterable of batches (topics, JSON texts, log times in ns) of ``sources``, one per window
    of ``window_ns`` of log time, in increasing time; within a batch sorted by (log time,
    source rank, row). ``count``: the messages yielded so far."""

    def __init__(self, sources: Sequence[Source], window_ns: int = WINDOW_NS) -> None:
        if window_ns <= 0:
            raise ValueError("window_ns must be positive")
        self._topics = {s.topic for s in sources}
        self.sources = [s for s in sources if len(s.times)]
        self.window_ns = int(window_ns)
        self.count = 0

    @property
    def topics(self) -> set[str]:
        """The topics the sources write (also those without rows)."""
        return set(self._topics)

    def __iter__(self) -> Iterator[Batch]:
        import numpy as np

        if not self.sources:
            return
        ordered = [bool(np.all(s.times[1:] >= s.times[:-1])) for s in self.sources]
        lo = min(int(s.times.min()) for s in self.sources)
        # the windows holding a row (a gap in the log costs nothing)
        used = np.unique(np.concatenate([(s.times - lo) // self.window_ns
                                         for s in self.sources]))
        for k in used.tolist():
            start = lo + k * self.window_ns
            end = start + self.window_ns
            names: list[str] = []
            datas: list[bytes] = []
            times: list[NDArray[np.int64]] = []
            ranks: list[NDArray[np.int64]] = []
            for rank, (s, asc) in enumerate(zip(self.sources, ordered, strict=True)):
                if asc:
                    a, b = np.searchsorted(s.times, (start, end), side="left")
                    idx = np.arange(a, b, dtype=np.intp)
                else:
                    idx = np.flatnonzero((s.times >= start) & (s.times < end))
                if not len(idx):
                    continue
                t_out, d_out = s.encode(idx)
                names.extend([s.topic] * len(d_out))
                datas.extend(d_out)
                times.append(np.asarray(t_out, dtype=np.int64))
                ranks.append(np.full(len(d_out), rank, dtype=np.int64))
            if not datas:
                continue
            t_all = np.concatenate(times)
            order = np.lexsort((np.concatenate(ranks), t_all)).tolist()
            self.count += len(order)
            yield (list(map(names.__getitem__, order)), list(map(datas.__getitem__, order)),
                   t_all[order].tolist())
