"""Online estimate of the NAV350 clock against the host clock: offset and drift.

The NAV350 stamps its data with a 32-bit millisecond counter. The host reads it by telegram
(``mNAVGetTimestamp``): the device samples its counter some time between the host writing the
request (``sent``) and reading the reply (``received``), so each read says

    host time of the tick  in  [sent, received]          (the tick itself is floor(ms))

Method (docs/recording.md): the counter is unwrapped (32 bits, wrapping every 49.7 days), each
read becomes the point (device s, midpoint - device s) with an uncertainty of half its round
trip plus the 1 ms tick, and a straight line ``host - device = offset + drift * (device - d0)``
is fitted by weighted least squares to the reads of the last ``window`` s, weighting each by
the inverse square of its uncertainty and dropping reads whose round trip exceeds
``rtt_factor`` times the window's shortest one (a read delayed by a busy host). The error
of the offset is bounded by half the shortest round trip used plus 0.5 ms (the tick), plus
the drift error times the age of the window; :attr:`ClockEstimate.bound_s` reports it.

When the device does not answer the clock read, the estimator can be fed one-sided reads
(``sent`` unknown: a pose whose tick is its validity time and whose reply arrived at
``received``): the fit then follows the lower envelope of ``received - device`` and its
offset includes the device's shortest processing and reply latency (a bias the log states).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

__all__ = ["ClockEstimate", "ClockEstimator", "unwrap_ms"]

_WRAP = 1 << 32
#: Reads must span this long before a drift is fitted, s.
MIN_DRIFT_SPAN = 5.0


def unwrap_ms(tick: int, previous: int | None) -> int:
    """``tick`` (32-bit ms) unwrapped next to the unwrapped ``previous`` reading."""
    if previous is None:
        return int(tick)
    delta = (int(tick) - previous) % _WRAP
    if delta >= _WRAP // 2:
        delta -= _WRAP
    return previous + delta


@dataclass(frozen=True)
class ClockEstimate:
    """host = device + offset + drift * (device - ref): all in s (drift dimensionless;
    ``drift * 1e6`` ppm, negative when the device clock runs fast). ``bound_s`` is the error
    bound of the offset at the newest read, ``samples`` the reads used, ``one_sided`` True when
    fitted to reply arrivals only."""

    offset: float
    drift: float
    ref: float
    bound_s: float
    samples: int
    one_sided: bool

    def host_time(self, device_s: float) -> float:
        """Host time (s) of an unwrapped device time (s)."""
        return device_s + self.offset + self.drift * (device_s - self.ref)

    def device_time(self, host_s: float) -> float:
        """Unwrapped device time (s) of a host time (s)."""
        return (host_s - self.offset + self.drift * self.ref) / (1.0 + self.drift)


class ClockEstimator:
    """Feed clock reads with :meth:`add`, map ticks with :meth:`host_time_of`.

    :param window: reads older than this (device s) are forgotten, s.
    :param rtt_factor: reads with a round trip above this multiple of the window's shortest
        are not used.
    :param min_samples: reads needed before an estimate is given.
    """

    def __init__(self, *, window: float = 60.0, rtt_factor: float = 3.0,
                 min_samples: int = 3) -> None:
        self.window = window
        self.rtt_factor = rtt_factor
        self.min_samples = min_samples
        self._reads: deque[tuple[float, float, float]] = deque()
        self._last_unwrapped: int | None = None
        self._one_sided = False
        self.estimate: ClockEstimate | None = None
        #: reads accepted, and restarts (clock jumped back: a device reset)
        self.reads = 0
        self.restarts = 0

    def reset(self) -> None:
        """Forget everything (the device restarted its clock)."""
        self._reads.clear()
        self._last_unwrapped = None
        self.estimate = None

    def unwrap(self, tick: int) -> int:
        """A tick unwrapped next to the newest read (without adding a read), ms."""
        return unwrap_ms(tick, self._last_unwrapped)

    def add(self, tick: int, sent: float | None, received: float) -> ClockEstimate | None:
        """A read of ``tick`` (ms) between host times ``sent`` and ``received`` (s); ``sent``
        None for a one-sided read. Returns the new estimate (None until enough reads)."""
        u = self.unwrap(tick)
        if self._last_unwrapped is not None and u < self._last_unwrapped - 1000:
            self.restarts += 1
            self.reset()
            u = int(tick)
        self._last_unwrapped = max(u, self._last_unwrapped or u)
        device = (u + 0.5) / 1000.0
        if sent is None:
            self._one_sided = True
            self._reads.append((device, received - device, 0.0))
        else:
            rtt = max(0.0, received - sent)
            self._reads.append((device, 0.5 * (sent + received) - device, rtt))
        while self._reads and self._reads[0][0] < device - self.window:
            self._reads.popleft()
        self.reads += 1
        self.estimate = self._fit()
        return self.estimate

    def host_time_of(self, tick: int) -> float | None:
        """Host time (s) of a device tick (ms), None without an estimate."""
        if self.estimate is None:
            return None
        return self.estimate.host_time((self.unwrap(tick) + 0.5) / 1000.0)

    def _fit(self) -> ClockEstimate | None:
        reads = list(self._reads)
        if len(reads) < self.min_samples:
            return None
        if self._one_sided:
            return self._envelope(reads)
        best = min(r[2] for r in reads)
        limit = max(best * self.rtt_factor, best + 0.002)
        used = [r for r in reads if r[2] <= limit]
        sigma = [0.5 * r[2] + 0.0005 for r in used]
        w = [1.0 / (s * s) for s in sigma]
        sw = sum(w)
        xm = sum(wi * r[0] for wi, r in zip(w, used, strict=True)) / sw
        ym = sum(wi * r[1] for wi, r in zip(w, used, strict=True)) / sw
        sxx = sum(wi * (r[0] - xm) ** 2 for wi, r in zip(w, used, strict=True))
        sxy = sum(wi * (r[0] - xm) * (r[1] - ym) for wi, r in zip(w, used, strict=True))
        span = max(1e-3, used[-1][0] - used[0][0])
        # over a short span the 1 ms tick makes the slope meaningless: offset only
        slope = sxy / sxx if sxx > 1e-9 and span >= MIN_DRIFT_SPAN else 0.0
        newest = reads[-1][0]
        slope_err = (0.5 * best + 0.0005) * math.sqrt(12.0 / len(used)) / span \
            if slope else 2e-4
        bound = 0.5 * best + 0.0005 + slope_err * abs(newest - xm)
        return ClockEstimate(ym, slope, xm, bound, len(used), False)

    def _envelope(self, reads: list[tuple[float, float, float]]) -> ClockEstimate | None:
        """Lower envelope: the smallest (received - device) per tenth of the window, fitted."""
        lo, hi = reads[0][0], reads[-1][0]
        bins: dict[int, tuple[float, float]] = {}
        width = max((hi - lo) / 10.0, 1e-3)
        for d, y, _ in reads:
            b = int((d - lo) / width)
            if b not in bins or y < bins[b][1]:
                bins[b] = (d, y)
        pts = sorted(bins.values())
        n = len(pts)
        xm = sum(p[0] for p in pts) / n
        ym = min(p[1] for p in pts) if n < 2 else sum(p[1] for p in pts) / n
        sxx = sum((p[0] - xm) ** 2 for p in pts)
        slope = sum((p[0] - xm) * (p[1] - ym) for p in pts) / sxx if sxx > 1e-9 else 0.0
        return ClockEstimate(ym, slope, xm, math.inf, len(pts), True)
