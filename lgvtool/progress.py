"""The one progress bar of lgvtool: long commands (evaluate, import, sweep, view, calibrate, ...)
show their progress on stderr with it, and each has ``--no-progress``.

On a terminal the bar is redrawn in place at most ten times a second; otherwise (a pipe, a CI
log) one line is printed at each tenth of the work and at the end, so logs stay short. With
``delay_s`` nothing is drawn until the work has taken that long, so quick runs stay quiet.
Stages: :meth:`Progress.stage` changes the label and starts a new count (read, filter, report).

Use::

    with Progress(total, "evaluate", enabled=not no_progress) as bar:
        for item in work:
            ...
            bar.advance()
"""

from __future__ import annotations

import sys
import time
from types import TracebackType
from typing import TextIO

__all__ = ["PIPE_DELAY_S", "Progress"]

#: least time before a delayed bar draws on a pipe rather than a terminal, s
PIPE_DELAY_S = 10.0


def _clock(seconds: float) -> str:
    s = int(max(seconds, 0.0) + 0.5)
    h, rem = divmod(s, 3600)
    m, s = divmod(rem, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """Count finished (and failed) work out of ``total`` and show it on ``stream`` (stderr).

    :param total: amount of work expected (tasks, observations, seconds of data, ...).
    :param label: word shown before the bar.
    :param stream: where to draw (default ``sys.stderr``).
    :param interval_s: least time between two redraws on a terminal, s.
    :param unit: shown after the counts (e.g. ``"s"``).
    :param enabled: False draws nothing (``--no-progress``); counting still works.
    :param delay_s: draw nothing before the work has taken this long, s.
    """

    def __init__(self, total: int, label: str = "tasks", *, stream: TextIO | None = None,
                 interval_s: float = 0.1, unit: str = "", enabled: bool = True,
                 delay_s: float = 0.0) -> None:
        self.total = max(int(total), 0)
        self.label = label
        self.stream = stream if stream is not None else sys.stderr
        self.interval_s = interval_s
        self.unit = unit
        self.enabled = enabled
        isatty = getattr(self.stream, "isatty", None)
        self._tty = bool(isatty and isatty())
        #: a pipe (a CI log) gets lines only from a command that takes long; an error of a bad
        #: input, found in the first seconds, then stays the only line on stderr
        self.delay_s = delay_s if self._tty or delay_s == 0 else max(delay_s, PIPE_DELAY_S)
        self.done = 0
        self.failed = 0
        self._start = time.monotonic()
        self._stage_start = self._start
        self._last_draw = 0.0
        self._last_tenth = -1
        self._drawn = False
        self._closed = False

    def advance(self, n: int = 1, *, failed: bool = False) -> None:
        """Count ``n`` more units of work done (``failed``: one task ended with an error)."""
        self.done += int(n)
        self.failed += int(failed)
        self._maybe_draw()

    def set(self, done: int) -> None:
        """Set the amount of work done."""
        self.done = int(done)
        self._maybe_draw()

    def stage(self, label: str, total: int) -> None:
        """Start a new stage of the work: a new label and total, the count back to 0."""
        if self._drawn and self._tty and self.enabled:
            self.stream.write("\r" + self.line() + "\x1b[K\n")
            self.stream.flush()
        self.label, self.total, self.done = label, max(int(total), 0), 0
        self._last_tenth = -1
        self._stage_start = time.monotonic()
        self._maybe_draw()

    def line(self) -> str:
        """The current state as one line of text (no newline)."""
        now = time.monotonic()
        elapsed = now - self._start
        frac = min(self.done / self.total, 1.0) if self.total else 1.0
        width = 28
        filled = round(frac * width)
        bar = "#" * filled + "." * (width - filled)
        unit = f" {self.unit}" if self.unit else ""
        text = f"{self.label} [{bar}] {self.done}/{self.total}{unit}"
        if self.failed:
            text += f", {self.failed} failed"
        text += f", {_clock(elapsed)}"
        if 0 < self.done < self.total:
            eta = (now - self._stage_start) / self.done * (self.total - self.done)
            text += f", about {_clock(eta)} left"
        return text

    def _maybe_draw(self) -> None:
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self._start < self.delay_s:
            return
        if self._tty:
            if now - self._last_draw >= self.interval_s or self.done >= self.total:
                self._last_draw = now
                self._drawn = True
                self.stream.write("\r" + self.line() + "\x1b[K")
                self.stream.flush()
            return
        if self.done == 0 and self.total:  # a line saying nothing is done yet tells nothing
            return
        tenth = min((10 * self.done) // self.total, 10) if self.total else 10
        if tenth != self._last_tenth and (tenth > self._last_tenth or self.done >= self.total):
            self._last_tenth = tenth
            self._drawn = True
            self.stream.write(self.line() + "\n")
            self.stream.flush()

    def close(self, failed: bool = False) -> None:
        """Finish the bar (a newline on a terminal). Idempotent. ``failed``: the work stopped
        on an error, which the command reports itself: a terminal gets only the newline, a pipe
        nothing more (so the error stays the last line, and the only one after the bar)."""
        if self._closed:
            return
        self._closed = True
        if not (self.enabled and self._drawn):
            return
        if self._tty:
            self.stream.write("\n" if failed else "\r" + self.line() + "\x1b[K\n")
            self.stream.flush()
        elif not failed and self._last_tenth < 10 and self.done < self.total:
            self.stream.write(self.line() + " (stopped)\n")
            self.stream.flush()

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(failed=exc_type is not None)
