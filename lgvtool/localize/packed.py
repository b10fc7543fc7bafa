"""Many small byte strings (message JSON) held compressed, in blocks (:class:`PackedBytes`).

A log's reflector scans are kept undecoded until an estimator needs them; as JSON they take
about 1.6 KB each, 47 MB per hour of a paper-circle log. Held here, compressed with zstd
level 1 in blocks of about 1 MB, they take about a quarter of that; a block is decompressed
only when one of its messages is asked for, and :meth:`PackedBytes.consume` hands them all
out once, freeing each block as it goes (the scans' one decoding,
:class:`lgvtool.localize.logdata.LazyScans`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import numpy as np
import zstandard
from numpy.typing import NDArray

CONSUME_ITEMS = 2048
"""Items per list of :meth:`PackedBytes.consume` after a reorder."""

#: uncompressed bytes compressed together as one block
BLOCK_BYTES = 1 << 20


class PackedBytes:
    """An append-only sequence of byte strings, stored compressed in blocks.

    ``append_block(items)`` adds one block; ``take(indices)`` returns the items asked for (in
    that order), decompressing each block once per call (the last block used is kept).
    """

    def __init__(self, level: int = 1) -> None:
        self._compress = zstandard.ZstdCompressor(level=level)
        self._decompress = zstandard.ZstdDecompressor()
        self._blocks: list[bytes] = []
        self._sizes: list[int] = []
        self._block_of: list[NDArray[np.int32]] = []
        self._start: list[NDArray[np.int64]] = []
        self._index: tuple[NDArray[np.int32], NDArray[np.int64], NDArray[np.int64]] | None = None
        self._n = 0
        self._cached: tuple[int, bytes] | None = None
        self._reordered = False
        self._pending: list[bytes] = []
        self._pending_bytes = 0

    def __len__(self) -> int:
        return self._n

    @property
    def stored_bytes(self) -> int:
        """Bytes the compressed blocks take."""
        return sum(len(b) for b in self._blocks)

    def append_block(self, items: Sequence[bytes]) -> None:
        """Add ``items``; they are compressed together with the items added before them once
        :data:`BLOCK_BYTES` are pending (and when the items are first read). Not after
        :meth:`reorder`."""
        if self._reordered:
            raise ValueError("PackedBytes: no item can be added once reordered")
        self._pending.extend(items)
        self._pending_bytes += sum(map(len, items))
        self._n += len(items)
        self._index = None
        if self._pending_bytes >= BLOCK_BYTES:
            self._seal()

    def _seal(self) -> None:
        """Compress the pending items into one block."""
        items = self._pending
        if not items:
            return
        lengths = np.fromiter(map(len, items), dtype=np.int64, count=len(items))
        starts = np.concatenate(([0], np.cumsum(lengths)))
        blob = b"".join(items)
        # a copy of exactly its size (the compressor's buffer is sized for the worst case)
        self._blocks.append(bytes(memoryview(self._compress.compress(blob))))
        self._sizes.append(len(blob))
        self._block_of.append(np.full(len(items) + 1, len(self._blocks) - 1, dtype=np.int32))
        self._start.append(starts)
        self._pending = []
        self._pending_bytes = 0

    def _flat(self) -> tuple[NDArray[np.int32], NDArray[np.int64], NDArray[np.int64]]:
        """Per item its block, start and end offset in the block's uncompressed bytes."""
        if self._index is None:
            self._seal()
            blocks = [b[:-1] for b in self._block_of]
            starts = [s[:-1] for s in self._start]
            ends = [s[1:] for s in self._start]
            z32, z64 = np.zeros(0, np.int32), np.zeros(0, np.int64)
            self._index = (np.concatenate(blocks) if blocks else z32,
                           np.concatenate(starts) if starts else z64,
                           np.concatenate(ends) if ends else z64)
        return self._index

    def _block(self, k: int) -> bytes:
        if self._cached is not None and self._cached[0] == k:
            return self._cached[1]
        data = self._decompress.decompress(self._blocks[k], max_output_size=self._sizes[k])
        self._cached = (k, data)
        return data

    def take(self, indices: Iterable[int]) -> list[bytes]:
        """The items ``indices`` (in that order)."""
        idx = np.fromiter(indices, dtype=np.int64)
        block_of, start, end = self._flat()
        if len(idx) and (idx.min() < 0 or idx.max() >= self._n):
            raise IndexError("PackedBytes index out of range")
        b, s, e = block_of[idx].tolist(), start[idx].tolist(), end[idx].tolist()
        out: list[bytes] = [b""] * len(idx)
        # each block once: the items of a block in ascending order of block
        for pos in np.argsort(block_of[idx], kind="stable").tolist():
            data = self._block(b[pos])
            out[pos] = data[s[pos]:e[pos]]
        return out

    def consume(self) -> Iterator[list[bytes]]:
        """Every item in index order, a list at a time, the store emptied as it goes (each
        compressed block is freed once its items are handed out; after a :meth:`reorder`,
        lists of :data:`CONSUME_ITEMS` items, the store emptied at the end)."""
        self._seal()
        if self._reordered:
            for a in range(0, self._n, CONSUME_ITEMS):
                yield self.take(range(a, min(a + CONSUME_ITEMS, self._n)))
        else:
            for k in range(len(self._blocks)):
                data = self._block(k)
                starts = self._start[k].tolist()
                self._blocks[k] = b""
                self._cached = None
                yield [data[starts[i]:starts[i + 1]] for i in range(len(starts) - 1)]
        self._blocks, self._sizes, self._block_of, self._start = [], [], [], []
        self._index, self._cached, self._n = None, None, 0

    def reorder(self, order: NDArray[np.int64]) -> None:
        """Put the items in the order ``order`` (a permutation of their indices)."""
        block_of, start, end = self._flat()
        self._index = (block_of[order], start[order], end[order])
        self._reordered = True
