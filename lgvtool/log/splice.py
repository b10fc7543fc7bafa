"""A chunk's message records merged with added messages as byte ranges, not message by message.

``replay`` copies its input log and adds the estimates and the view channels, all in log-time
order. :func:`spliced` takes one input chunk's records as they are stored (the columns of
:func:`lgvtool.log.mcap_chunks.record_columns`: channel, log time, offset and size of each record)
and the added messages that fall before the next chunk, and returns the merged records as one
block with its columns, for :meth:`lgvtool.log.mcap_writer.McapWriter.add_records`. The input's
records are not unpacked and packed again: runs of them that stay together are copied as
slices of the chunk, so the cost per input message is a few numpy element operations (the
added messages are framed by :func:`lgvtool.log.mcap_writer.framed_records`).

The order is the one of a message-by-message merge: by log time, an input message before an
added one at the same time, each side in its own order. Times in integer ns.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from lgvtool.log.mcap_chunks import RecordColumns
    from lgvtool.log.mcap_writer import FramedRecords


def spliced(records: bytes, columns: RecordColumns, keep: NDArray[np.bool_] | None,
            added: FramedRecords) -> FramedRecords:
    """The records of ``columns`` (those ``keep`` marks; all when None) taken from
    ``records``, merged with the ``added`` records (in time order) by log time, an input
    record first at equal times."""
    import numpy as np

    cids, times, offsets, sizes = columns
    if keep is not None:
        cids, times, offsets, sizes = cids[keep], times[keep], offsets[keep], sizes[keep]
    a_blob, a_cids, a_times, a_sizes = added
    n_in, n_add = len(times), len(a_times)
    # where each added record goes: after every input record at or before its time
    after = np.searchsorted(times, a_times, side="right")
    at_add = after + np.arange(n_add)
    at_in = np.arange(n_in) + np.searchsorted(after, np.arange(n_in), side="right")
    n = n_in + n_add
    out_cids = np.empty(n, dtype=np.uint16)
    out_times = np.empty(n, dtype=np.int64)
    out_sizes = np.empty(n, dtype=np.int64)
    source = np.empty(n, dtype=np.int8)  # 0: the input's records, 1: the added ones
    start = np.empty(n, dtype=np.int64)  # where each record starts in its own buffer
    for at, c, t, s, src, off in (
            (at_in, cids, times, sizes, 0, offsets),
            (at_add, a_cids, a_times, a_sizes, 1, np.cumsum(a_sizes) - a_sizes)):
        out_cids[at], out_times[at], out_sizes[at] = c, t, s
        source[at] = src
        start[at] = off
    # runs of records that lie one after the other in the same buffer, copied as one slice
    breaks = np.flatnonzero((source[1:] != source[:-1])
                            | (start[1:] != start[:-1] + out_sizes[:-1])) + 1
    ends = start + out_sizes
    if n == 0:
        return b"", out_cids, out_times, out_sizes
    firsts = np.concatenate(([0], breaks))
    lasts = np.concatenate((breaks, [n]))
    views = (memoryview(records), memoryview(a_blob))
    parts = [views[src][lo:hi] for src, lo, hi in zip(
        source[firsts].tolist(), start[firsts].tolist(), ends[lasts - 1].tolist(), strict=True)]
    block = b"".join(parts)
    del parts
    for v in views:
        v.release()
    return block, out_cids, out_times, out_sizes
