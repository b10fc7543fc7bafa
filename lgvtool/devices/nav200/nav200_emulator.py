"""The virtual NAV200 of ``simulate serve``: the device model on a byte stream.

:class:`VirtualNav200` is the shared :class:`~lgvtool.devices.nav200.nav200_device.Nav200Device`
playing a :class:`~lgvtool.sim.emulate.emulator_playback.Playback` (a scenario or a log),
with the request decoder of its serial line: host bytes in, reply telegrams out.
"""

from __future__ import annotations

from lgvtool.devices.nav200.nav200_device import Nav200Device, Nav200Source
from lgvtool.devices.nav200.nav200_stream import Nav200RequestDecoder
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S

__all__ = ["VirtualNav200"]


class VirtualNav200(Nav200Device):
    """The device side of a NAV200 link, driven by a playback.

    :param playback: the run whose pose solutions and map the device reports.
    :param omega_scale: wire units of a Pw/PV yaw rate per rad/s (see :class:`Nav200Device`).
    """

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
