"""A small progress bar on stderr for long runs of tasks.

On a terminal the bar is redrawn in place at most ten times a second; otherwise (a pipe, a CI
log) one line is printed at each tenth of the work and at the end, so logs stay short.
"""

from __future__ import annotations

import sys
import time
from typing import TextIO


def _clock(seconds: float) -> str:
    s = int(max(seconds, 0.0) + 0.5)
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """Count finished and failed tasks out of ``total`` and show it on ``stream`` (stderr).

    :param total: number of tasks expected.
    :param label: word shown before the bar.
    :param stream: where to draw (default ``sys.stderr``).
    :param interval_s: least time between two redraws on a terminal, s.
    """

    def __init__(self, total: int, label: str = "tasks", *, stream: TextIO | None = None,
                 interval_s: float = 0.1) -> None:
        self.total = max(int(total), 0)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.interval_s = interval_s
        self.done = 0
        self.failed = 0
        self._start = time.monotonic()
        self._last_draw = 0.0
        self._last_tenth = -1
        self._closed = False
        isatty = getattr(self.stream, "isatty", None)
        self._tty = bool(isatty and isatty())

    def advance(self, *, failed: bool = False) -> None:
        """Count one more finished task (``failed``: it ended with an error)."""
        self.done += 1
        self.failed += int(failed)
        self._maybe_draw()

    def line(self) -> str:
        """The current state as one line of text (no newline)."""
        elapsed = time.monotonic() - self._start
        frac = self.done / self.total if self.total else 1.0
        width = 28
        filled = round(frac * width)
        bar = "#" * filled + "." * (width - filled)
        text = f"{self.label} [{bar}] {self.done}/{self.total}"
        if self.failed:
            text += f", {self.failed} failed"
        text += f", {_clock(elapsed)}"
        if 0 < self.done < self.total:
            eta = elapsed / self.done * (self.total - self.done)
            text += f", about {_clock(eta)} left"
        return text

    def _maybe_draw(self) -> None:
        if self._tty:
            now = time.monotonic()
            if now - self._last_draw >= self.interval_s or self.done >= self.total:
                self._last_draw = now
                self.stream.write("\r" + self.line() + "\x1b[K")
                self.stream.flush()
            return
        tenth = (10 * self.done) // self.total if self.total else 10
        if tenth != self._last_tenth and (tenth > self._last_tenth or self.done >= self.total):
            self._last_tenth = tenth
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def close(self) -> None:
        """Finish the bar (a newline on a terminal). Idempotent."""
        if self._closed:
            return
        self._closed = True
        if self._tty:
            self.stream.write("\r" + self.line() + "\x1b[K\n")
            self.stream.flush()
        elif self._last_tenth < 10 and self.done < self.total:
            self.stream.write(self.line() + " (stopped)\n")
            self.stream.flush()
