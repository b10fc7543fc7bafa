"""How the NAV200 is emulated: the ``simulate serve --nav PORT`` option and the virtual NAV200,
a :class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation` (its emulator is imported when
made)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from lgvtool.sim.emulate.emulator_registry import SERVE_PORT_HELP, PortOption

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200

__all__ = ["DEVICE", "SERVE_OPTION", "emulator", "fault_kinds", "serve_emulator"]

DEVICE = "nav200"
#: ``simulate serve``'s option of the NAV200's port; it listens on a pseudo-terminal by default
SERVE_OPTION = PortOption("--nav", "nav", "pty",
                          help=f"Where the virtual NAV200 listens: {SERVE_PORT_HELP}")


def emulator(playback: Playback) -> VirtualNav200:
    """A :class:`~lgvtool.sim.emulate.nav200.nav200_emulator.VirtualNav200` playing
    ``playback``."""
    from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200

    return VirtualNav200(playback)


def fault_kinds() -> tuple[str, ...]:
    """The faults of its own :func:`emulator` takes (``reset``)."""
    from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200

    return VirtualNav200.FAULT_KINDS


def serve_emulator(playback: Playback, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, VirtualNav200]:
    """``simulate serve``'s NAV200: the port ``spec`` (None: not served) and its
    :func:`emulator` (made even when not served; ``loop``: unused, it only answers)."""
    return spec, emulator(playback)
