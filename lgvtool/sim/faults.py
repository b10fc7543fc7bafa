"""The faults injected on purpose (the true site itself is :mod:`lgvtool.sim.site_model`).

- :func:`occlusions`: stretches of time in which a reflector is hidden (pallets, people).
- :func:`choose` and :func:`flip_bit`: which frames a link loses or corrupts, and how.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from lgvtool.json_types import JSONObject
from lgvtool.sim.kinematics import FloatArray


@dataclass(frozen=True)
class FaultEvent:
    """A fault the simulator injected, at time ``t`` (s), for /diagnostics."""

    t: float
    source: str
    kind: str
    message: str
    details: JSONObject = field(default_factory=dict)
    """What the /diagnostics message's ``details`` say (ids, durations s, ...)."""


@dataclass(frozen=True)
class Occlusions:
    """Per landmark, the sorted stretches [start, end) s in which it is hidden."""

    starts: tuple[FloatArray, ...]
    ends: tuple[FloatArray, ...]

    def hidden(self, landmark: NDArray[np.intp], times: FloatArray) -> NDArray[np.bool_]:
        """True where landmark ``landmark[i]`` is hidden at ``times[i]`` (arrays of one shape)."""
        out = np.zeros(np.shape(times), dtype=bool)
        for j, (s, e) in enumerate(zip(self.starts, self.ends, strict=True)):
            if len(s) == 0:
                continue
            sel = landmark == j
            t = times[sel]
            k = np.searchsorted(s, t, side="right") - 1
            out[sel] = (k >= 0) & (t < e[np.maximum(k, 0)])
        return out

    @property
    def count(self) -> int:
        """Number of stretches over all landmarks."""
        return sum(len(s) for s in self.starts)


def occlusions(n_landmarks: int, duration: float, fraction: float, mean_s: float,
               rng: np.random.Generator) -> Occlusions:
    """Alternating visible/hidden stretches with exponential lengths: hidden ones of mean
    ``mean_s`` s, visible ones of mean ``mean_s (1 - fraction) / fraction`` s, so each landmark
    is hidden ``fraction`` of the time on average. No stretches when ``fraction`` is 0."""
    if fraction <= 0 or duration <= 0:
        empty = tuple(np.zeros(0) for _ in range(n_landmarks))
        return Occlusions(starts=empty, ends=empty)
    visible_mean = mean_s * (1.0 - fraction) / fraction
    m = int(duration / (mean_s + visible_mean) * 2 + 10)
    starts, ends = [], []
    for _ in range(n_landmarks):
        gaps = rng.exponential(visible_mean, m)
        lengths = rng.exponential(mean_s, m)
        first = rng.uniform(0.0, visible_mean)  # a random phase of the first visible stretch
        s = first + np.cumsum(np.concatenate([[0.0], (lengths + gaps)[:-1]]))
        e = s + lengths
        keep = s < duration
        starts.append(s[keep])
        ends.append(np.minimum(e[keep], duration))
    return Occlusions(starts=tuple(starts), ends=tuple(ends))


def choose(rate: float, n: int, rng: np.random.Generator) -> NDArray[np.bool_]:
    """A Bernoulli(``rate``) mask of ``n`` items (always draws ``n`` numbers)."""
    return rng.random(n) < rate


def flip_bit(data: bytes, lo: int, hi: int, rng: np.random.Generator) -> tuple[bytes, int, int]:
    """``data`` with one random bit flipped in a byte of index [lo, hi); returns the bytes, the
    byte index and the bit number."""
    index = int(rng.integers(lo, hi))
    bit = int(rng.integers(0, 8))
    out = bytearray(data)
    out[index] ^= 1 << bit
    return bytes(out), index, bit
