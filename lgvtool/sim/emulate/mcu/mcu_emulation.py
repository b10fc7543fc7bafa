"""How the MCU is emulated: the ``simulate serve --mcu PORT`` option and the virtual MCU, a
:class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation` (its emulator is imported when
made)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from lgvtool.sim.emulate.emulator_registry import SERVE_PORT_HELP, PortOption

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.mcu.mcu_emulator import VirtualMcu

__all__ = ["DEVICE", "SERVE_OPTION", "emulator", "fault_kinds", "serve_emulator"]

DEVICE = "mcu"
#: ``simulate serve``'s option of the MCU's port; it streams on a pseudo-terminal by default
SERVE_OPTION = PortOption("--mcu", "mcu", "pty",
                          help=f"Where the virtual MCU streams: {SERVE_PORT_HELP}")


def emulator(playback: Playback, *, loop: bool = False) -> VirtualMcu:
    """A :class:`~lgvtool.sim.emulate.mcu.mcu_emulator.VirtualMcu` playing ``playback``."""
    from lgvtool.sim.emulate.mcu.mcu_emulator import VirtualMcu

    return VirtualMcu(playback, loop=loop)


def fault_kinds() -> tuple[str, ...]:
    """The faults of its own :func:`emulator` takes (none)."""
    from lgvtool.sim.emulate.mcu.mcu_emulator import VirtualMcu

    return VirtualMcu.FAULT_KINDS


def serve_emulator(playback: Playback, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, VirtualMcu]:
    """``simulate serve``'s MCU: the port ``spec`` (None: not served) and its :func:`emulator`,
    made even when not served (its stream decides when the run has been played)."""
    return spec, emulator(playback, loop=loop)
