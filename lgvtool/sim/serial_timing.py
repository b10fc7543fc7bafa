"""Serial links: how long bytes take on the wire, and in which chunks a host read returns them.

A UART sends one character every ``bits / baud`` seconds (10 bits for 8N1, 11 for 8E1). The
host's read returns whatever the driver has buffered: here a telegram arrives in one read, or,
with probability ``split_probability``, in two reads cut at a random byte. Each read returns a
little after its last byte is on the wire (``latency`` plus a uniform ``jitter``), and reads of
one port never go back in time.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.sim.kinematics import FloatArray

BITS_8N1 = 10
"""Bits per character with 8 data bits, no parity, 1 stop bit (plus the start bit)."""
BITS_8E1 = 11
"""Bits per character with 8 data bits, even parity, 1 stop bit (plus the start bit)."""


def wire_time(n_bytes: int | NDArray[np.int64], baud: int, bits: int) -> FloatArray:
    """Time that ``n_bytes`` characters take on the wire, s."""
    return np.asarray(n_bytes, dtype=np.float64) * bits / baud


@dataclass(frozen=True)
class Chunk:
    """Bytes returned by one host read, at host time ``t`` (s since the simulation start)."""

    t: float
    data: bytes


@dataclass(frozen=True)
class Delivery:
    """How a sequence of telegrams reaches the host, decided for all of them at once."""

    split_at: NDArray[np.int64]
    """Byte index at which each telegram is cut into two reads, 0 for a single read."""
    first_read: FloatArray
    """Time the first read returns (the only one when not split), s."""
    second_read: FloatArray
    """Time the second read returns (equal to ``first_read`` when not split), s."""

    def chunks(self, i: int, data: bytes) -> list[Chunk]:
        """The reads that deliver telegram ``i`` with bytes ``data``."""
        cut = int(self.split_at[i])
        if cut <= 0:
            return [Chunk(float(self.first_read[i]), data)]
        return [Chunk(float(self.first_read[i]), data[:cut]),
                Chunk(float(self.second_read[i]), data[cut:])]


def deliver(start: FloatArray, sizes: NDArray[np.int64], baud: int, bits: int, latency: float,
            jitter: float, split_probability: float, rng: np.random.Generator) -> Delivery:
    """Reads of telegrams whose first byte goes on the wire at ``start`` (s), ``sizes`` bytes
    each. Draws a fixed number of random numbers per telegram, whatever the settings."""
    n = len(start)
    u_split = rng.random(n)
    u_cut = rng.random(n)
    u_j1 = rng.random(n)
    u_j2 = rng.random(n)
    sizes = np.asarray(sizes, dtype=np.int64)
    split = (u_split < split_probability) & (sizes > 1)
    cut = np.where(split, 1 + np.floor(u_cut * np.maximum(sizes - 1, 1)).astype(np.int64), 0)
    end = start + wire_time(sizes, baud, bits)
    mid = start + wire_time(cut, baud, bits)
    first = np.where(split, mid, end) + latency + jitter * u_j1
    second = np.where(split, end + latency + jitter * u_j2, first)
    # one port: a read never returns before the previous one
    both = np.maximum.accumulate(np.column_stack([first, second]).ravel())
    both = both.reshape(n, 2) if n else np.zeros((0, 2))
    return Delivery(split_at=cut, first_read=both[:, 0], second_read=both[:, 1])
