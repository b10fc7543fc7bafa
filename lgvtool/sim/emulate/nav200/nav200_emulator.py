"""The virtual NAV200 of ``simulate serve``: the device model on a byte stream.

:class:`VirtualNav200` is the shared :class:`~lgvtool.devices.nav200.nav200_device.Nav200Device`
playing a :class:`~lgvtool.sim.emulate.emulator_playback.Playback` (a scenario or a log),
with the request decoder of its serial line: host bytes in, reply telegrams out.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from lgvtool.devices.nav200.nav200_device import Nav200Device, Nav200Source
from lgvtool.devices.nav200.nav200_stream import Nav200RequestDecoder
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S

if TYPE_CHECKING:
    from lgvtool.sim.emulate.endpoints import Endpoint

__all__ = ["VirtualNav200"]


class VirtualNav200(Nav200Device):
    """The device side of a NAV200 link, driven by a playback.

    :param playback: the run whose pose solutions and map the device reports.
    :param omega_scale: wire units of a Pw/PV yaw rate per rad/s (see :class:`Nav200Device`).
    """

    #: the device faults of ``simulate serve`` it takes (:meth:`apply_fault`)
    FAULT_KINDS: tuple[str, ...] = ("reset",)

    def __init__(self, playback: Nav200Source,
                 omega_scale: float = OMEGA_UNITS_PER_RAD_S) -> None:
        super().__init__(playback, omega_scale)
        self.playback = playback
        self._decoder = Nav200RequestDecoder()

    def reset(self) -> None:
        """Power cycle: back to standby with the settings forgotten (the map is kept), and
        the line's half-received telegram dropped."""
        super().reset()
        self._decoder = Nav200RequestDecoder()

    def feed(self, data: bytes, t: float) -> list[bytes]:
        """Bytes from the host at ``t`` s in, reply telegrams out (garbage is ignored)."""
        return [self.answer(req, t) for req in self._decoder.feed(data)]

    def serve(self, ep: Endpoint | None, now: float, t: float | None,
              log: Callable[[str, bytes], None], silent: Callable[[], bool]) -> None:
        """One turn of ``simulate serve``: answer what the host sent on ``ep`` (None: not
        served) at host time ``now`` s and run time ``t`` s (None: the clock has not started,
        answered as at 0); ``log(direction, data)`` records the traffic, ``silent()`` makes
        the device deaf and mute."""
        if ep is None:
            return
        for _ in range(8):
            data = ep.read()
            if not data:
                break
            log("received", data)
            if silent():
                continue  # deaf and mute
            for reply in self.feed(data, 0.0 if t is None else t):
                if ep.write(reply, now):
                    log("sent", reply)

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        """A fault of :data:`FAULT_KINDS` at run time ``t`` s: ``reset`` power cycles it."""
        if kind == "reset":
            self.reset()
