"""The recorder's live status line: messages per topic and their rates, errors, size, time."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TextIO

from lgvtool.log import topics

__all__ = ["StatusLine", "format_bytes", "format_elapsed", "format_status"]

#: Topics shown with a rate, in this order, under these short names.
_RATED = ((topics.MCU_FRAME, "mcu"), (topics.NAV_POSE, "pose"))
#: Topics shown as counts only.
_COUNTED = ((topics.MCU_RX, "mcu.rx"), (topics.NAV_RX, "nav.rx"), (topics.NAV_TX, "nav.tx"))


def format_bytes(n: int) -> str:
    """Bytes as ``812 B``, ``4.2 kB``, ``13.0 MB``, ``2.10 GB`` (powers of 1000)."""
    if n < 1000:
        return f"{n} B"
    if n < 1_000_000:
        return f"{n / 1e3:.1f} kB"
    if n < 1_000_000_000:
        return f"{n / 1e6:.1f} MB"
    return f"{n / 1e9:.2f} GB"


def format_elapsed(seconds: float) -> str:
    """Elapsed time as ``H:MM:SS``."""
    s = max(0, int(seconds))
    return f"{s // 3600}:{s % 3600 // 60:02d}:{s % 60:02d}"


def format_status(elapsed: float, counts: Mapping[str, int], rates: Mapping[str, float],
                  errors: int, size: int, devices: Mapping[str, str]) -> str:
    """One status line. ``rates`` in Hz per topic, ``size`` in bytes, ``elapsed`` in s,
    ``devices`` maps a device name to its state."""
    parts = [format_elapsed(elapsed)]
    for topic, name in _RATED:
        if topic in counts or topic in rates:
            parts.append(f"{name} {counts.get(topic, 0)} ({rates.get(topic, 0.0):.1f} Hz)")
    for topic, name in _COUNTED:
        if counts.get(topic):
            parts.append(f"{name} {counts[topic]}")
    parts.append(f"diag {counts.get(topics.DIAGNOSTICS, 0)}")
    parts.append(f"errors {errors}")
    parts.append(format_bytes(size))
    if devices:
        parts.append(" ".join(f"[{k}: {v}]" for k, v in devices.items()))
    return "  ".join(parts)


@dataclass
class StatusLine:
    """Writes the status to ``stream``: redrawn in place on a terminal, else one line every
    ``plain_every`` s. Rates are over the interval since the previous update."""

    stream: TextIO
    plain_every: float = 10.0
    _last_counts: dict[str, int] = field(default_factory=dict)
    _last_t: float | None = None
    _last_plain: float = -1e9
    _width: int = 0

    @property
    def tty(self) -> bool:
        """True when the stream is a terminal."""
        isatty = getattr(self.stream, "isatty", None)
        return bool(isatty and isatty())

    def update(self, now: float, elapsed: float, counts: Mapping[str, int], errors: int,
               size: int, devices: Mapping[str, str], *, force: bool = False) -> None:
        """Redraw (terminal) or print (otherwise, when due or ``force``). ``now`` in s."""
        rates: dict[str, float] = {}
        if self._last_t is not None and now > self._last_t:
            dt = now - self._last_t
            for topic, _ in _RATED:
                rates[topic] = (counts.get(topic, 0) - self._last_counts.get(topic, 0)) / dt
        self._last_t, self._last_counts = now, dict(counts)
        line = format_status(elapsed, counts, rates, errors, size, devices)
        if self.tty:
            pad = max(0, self._width - len(line))
            self.stream.write("\r" + line + " " * pad)
            self._width = len(line)
            self.stream.flush()
        elif force or now - self._last_plain >= self.plain_every:
            self._last_plain = now
            self.stream.write(line + "\n")
            self.stream.flush()

    def finish(self) -> None:
        """End the redrawn line (terminal)."""
        if self.tty and self._width:
            self.stream.write("\n")
            self.stream.flush()
            self._width = 0
