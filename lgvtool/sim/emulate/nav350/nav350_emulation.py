"""How the NAV350 is emulated: the ``simulate serve --nav350 PORT[?CLOCK]`` option and the
virtual NAV350, a :class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation` (its emulator
is imported when made)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from lgvtool.sim.emulate.emulator_registry import PortOption

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.nav350.nav350_emulator import VirtualNav350

__all__ = ["DEVICE", "SERVE_OPTION", "emulator", "fault_kinds", "serve_emulator",
           "split_port_spec"]

DEVICE = "nav350"
#: ``simulate serve``'s option of the NAV350's port; not served by default
SERVE_OPTION = PortOption("--nav350", "nav350", "none",
                          help="Where a virtual NAV350 listens (SOPAS CoLa-A and CoLa-B): "
                               "tcp://HOST:PORT, 'pty' or 'none'; '?drift_ppm=50&offset_ms=987654' "
                               "sets its millisecond clock.")


def emulator(playback: Playback, **clock: float) -> VirtualNav350:
    """A :class:`~lgvtool.sim.emulate.nav350.nav350_emulator.VirtualNav350` playing
    ``playback`` (``clock``: ``drift_ppm``, ``offset_ms``)."""
    from lgvtool.sim.emulate.nav350.nav350_emulator import VirtualNav350

    return VirtualNav350(playback, **clock)  # type: ignore[arg-type]


def split_port_spec(spec: str) -> tuple[str, dict[str, float]]:
    """``simulate serve --nav350 PORT?drift_ppm=..&offset_ms=..``: the port and the clock
    settings of the emulator (:func:`emulator`); InputError for a bad setting."""
    from lgvtool.sim.emulate.nav350.nav350_emulator import split_port_spec as split

    return split(spec)


def fault_kinds() -> tuple[str, ...]:
    """The faults of its own :func:`emulator` takes (``reset``, ``sfa``, ``error``,
    ``badsum``)."""
    from lgvtool.sim.emulate.nav350.nav350_emulator import VirtualNav350

    return VirtualNav350.FAULT_KINDS


def serve_emulator(playback: Playback, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, VirtualNav350 | None]:
    """``simulate serve``'s NAV350: the port of ``spec`` (:func:`split_port_spec`; None: not
    served, and no emulator) and its :func:`emulator` with the spec's clock settings
    (``loop``: unused, it only answers and streams on request)."""
    if spec is None:
        return None, None
    port, clock = split_port_spec(spec)
    return port, emulator(playback, **clock)
