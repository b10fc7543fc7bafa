"""What the head can see, and the faults injected on purpose.

- :func:`landmarks`: the reflectors as they really stand (the device's stored map may differ by
  a survey error) plus, optionally, a shiny object that the head takes for a reflector.
- :func:`occlusions`: stretches of time in which a reflector is hidden (pallets, people).
- :func:`choose` and :func:`flip_bit`: which frames a link loses or corrupts, and how.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Area, Reflector
from lgvtool.errors import ConfigError
from lgvtool.sim.kinematics import FloatArray
from lgvtool.sim.settings import FaultSettings

FALSE_ID = -1
"""Id of the shiny false reflector in reflector scans."""


@dataclass(frozen=True)
class FaultEvent:
    """A fault the simulator injected, at time ``t`` (s), for /diagnostics."""

    t: float
    source: str
    kind: str
    message: str
    details: dict[str, object] = field(default_factory=dict)


@dataclass(frozen=True)
class Landmarks:
    """Everything the head can detect, in one array per field (index = landmark).

    ``x``/``y`` are where the landmarks really are (m); ``map_x``/``map_y`` where the device's
    stored map puts the reflectors (NaN for the false one); ``ids`` the map id or -1.
    """

    ids: NDArray[np.int64]
    x: FloatArray
    y: FloatArray
    map_x: FloatArray
    map_y: FloatArray
    is_false: NDArray[np.bool_]

    def __len__(self) -> int:
        return len(self.ids)


def _wall_tangent(r: Reflector, area: Area) -> tuple[float, float]:
    """Unit vector along the wall nearest to reflector ``r`` (counter-clockwise round the hall)."""
    gaps = {
        (1.0, 0.0): r.y - area.y_min,   # south wall, run east
        (0.0, 1.0): area.x_max - r.x,   # east wall, run north
        (-1.0, 0.0): area.y_max - r.y,  # north wall, run west
        (0.0, -1.0): r.x - area.x_min,  # west wall, run south
    }
    return min(gaps, key=lambda k: gaps[k])


def landmarks(reflectors: Sequence[Reflector], area: Area, faults: FaultSettings,
              map_sigma: float, rng: np.random.Generator) -> Landmarks:
    """The landmarks of a run.

    The reflectors really stand at their map position plus a survey error of ``map_sigma`` m
    per axis (drawn even when zero, so other draws do not shift). With
    ``faults.false_reflector`` a shiny object is added at (false_x, false_y), or, when those are
    NaN, ``false_offset`` m along the wall from reflector ``false_near_id``.
    """
    n = len(reflectors)
    ids = np.array([r.id for r in reflectors], dtype=np.int64)
    mx = np.array([r.x for r in reflectors], dtype=np.float64)
    my = np.array([r.y for r in reflectors], dtype=np.float64)
    survey = rng.standard_normal((2, n)) * map_sigma
    x, y = mx + survey[0], my + survey[1]
    is_false = np.zeros(n, dtype=bool)
    if faults.false_reflector:
        if math.isfinite(faults.false_x) and math.isfinite(faults.false_y):
            fx, fy = faults.false_x, faults.false_y
        else:
            near = [r for r in reflectors if r.id == faults.false_near_id]
            if not near:
                raise ConfigError(f"faults.false_near_id {faults.false_near_id} is not a "
                                  "reflector of the map")
            ux, uy = _wall_tangent(near[0], area)
            fx = near[0].x + faults.false_offset * ux
            fy = near[0].y + faults.false_offset * uy
        ids = np.append(ids, FALSE_ID)
        x, y = np.append(x, fx), np.append(y, fy)
        mx, my = np.append(mx, np.nan), np.append(my, np.nan)
        is_false = np.append(is_false, True)
    return Landmarks(ids=ids, x=x, y=y, map_x=mx, map_y=my, is_false=is_false)


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
