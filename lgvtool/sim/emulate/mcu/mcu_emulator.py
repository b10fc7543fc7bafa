"""A virtual MCU: the played run's frame bytes, each at its time."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from lgvtool.sim.emulate.emulator_playback import Playback

if TYPE_CHECKING:
    from lgvtool.sim.emulate.endpoints import Endpoint

__all__ = ["VirtualMcu"]


class VirtualMcu:
    """Hands out the MCU bytes that are due by a given time.

    :param playback: the run to play.
    :param loop: start over after the end (the run's time line repeats, shifted by its
        duration; the frames repeat byte for byte, so the sequence number jumps back).
    """

    #: the device faults of ``simulate serve`` it takes: none of its own
    FAULT_KINDS: tuple[str, ...] = ()

    def __init__(self, playback: Playback, *, loop: bool = False) -> None:
        self.playback = playback
        self.loop = loop
        self._i = 0
        self._offset = 0.0
        self._period = max(playback.duration, 0.1)

    @property
    def finished(self) -> bool:
        """True once every chunk has been handed out (never when looping)."""
        return not self.loop and self._i >= len(self.playback.mcu)

    def next_time(self) -> float | None:
        """Time (s) of the next chunk, or None when finished."""
        chunks = self.playback.mcu
        if not chunks:
            return None
        if self._i >= len(chunks):
            if not self.loop:
                return None
            return self._offset + self._period + chunks[0].t
        return self._offset + chunks[self._i].t

    def due(self, t: float) -> list[bytes]:
        """Every chunk due at or before ``t`` s not handed out yet, in order."""
        chunks = self.playback.mcu
        out: list[bytes] = []
        while chunks:
            if self._i >= len(chunks):
                if not self.loop:
                    break
                self._i = 0
                self._offset += self._period
            chunk = chunks[self._i]
            if self._offset + chunk.t > t:
                break
            out.append(chunk.data)
            self._i += 1
        return out

    def serve(self, ep: Endpoint | None, now: float, t: float | None,
              log: Callable[[str, bytes], None], silent: Callable[[], bool]) -> None:
        """One turn of ``simulate serve``: once the clock runs (``t`` s not None), write the
        chunks due by ``t`` to ``ep`` at host time ``now`` s; they are handed out (the
        schedule advances) even when ``ep`` is None (not served) or ``silent()``;
        ``log(direction, data)`` records the traffic."""
        if t is None:
            return
        chunks = self.due(t)
        if ep is None or silent():
            return
        for chunk in chunks:
            if ep.write(chunk, now):
                log("sent", chunk)

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        """No fault of its own (:data:`FAULT_KINDS` is empty): nothing to do."""
