"""Each device family's emulator, and how ``simulate serve`` finds it.

The simulator sits above the device families: a family (``lgvtool/devices/<family>/``,
:mod:`lgvtool.devices.device_registry`) knows nothing of emulators, and its emulation lives here,
in ``lgvtool/sim/emulate/<family>/``: an emulator module and an emulation module
``<family>_emulation.py`` that satisfies :class:`FamilyEmulation`:

- ``DEVICE``: the family (one of :data:`~lgvtool.devices.device_registry.FAMILIES`);
- ``SERVE_OPTION``: its ``simulate serve`` port option (:class:`PortOption`);
- ``serve_emulator(playback, spec, *, loop)``: the port and the :class:`Emulator`;
- ``fault_kinds()``: the faults of its own the emulator takes (its ``FAULT_KINDS``).

:class:`~lgvtool.sim.emulate.emulator_server.EmulatorServer` and ``simulate serve`` go through
:func:`emulation` and :func:`emulations`; emulations are imported on first use, their emulators
when made.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol, cast

from lgvtool.devices import device_registry

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.endpoints import Endpoint

__all__ = ["SERVE_PORT_HELP", "Emulator", "FamilyEmulation", "Pacer", "PortOption", "emulation",
           "emulations"]

#: The help of a ``simulate serve`` port option, after "Where the virtual DEVICE listens: ".
SERVE_PORT_HELP = "'pty' (a pseudo-terminal), tcp://HOST:PORT (port 0: any free one) or 'none'."


@dataclass(frozen=True)
class PortOption:
    """A family's ``simulate serve`` port option: ``flag PORT`` (``--nav PORT``), passed to
    :class:`~lgvtool.sim.emulate.emulator_server.EmulatorServer` as ``param``; ``default``:
    where it is served unless told ('none': not served)."""

    flag: str
    param: str
    default: str
    help: str
    metavar: str = "PORT"

    @property
    def served_at(self) -> str | None:
        """The port spec of :attr:`default` (None: not served)."""
        return None if self.default == "none" else self.default


class Emulator(Protocol):
    """A virtual device of ``simulate serve``: the server calls :meth:`serve` each turn and
    hands it the faults of :attr:`FAULT_KINDS`."""

    @property
    def FAULT_KINDS(self) -> tuple[str, ...]:
        """The device faults of ``simulate serve`` it takes (:meth:`apply_fault`)."""

    def serve(self, ep: Endpoint | None, now: float, t: float | None,
              log: Callable[[str, bytes], None], silent: Callable[[], bool]) -> None:
        """One turn: serve ``ep`` (None: not served) at host time ``now`` s and run time ``t``
        s (None: the clock has not started); ``log(direction, data)`` records the traffic,
        ``silent()`` says whether the device is silenced."""

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        """A fault of :attr:`FAULT_KINDS` at run time ``t`` s."""


class Pacer(Protocol):
    """An emulator that paces the run: the run has been played once every pacer has
    ``finished``, and the server wakes at their :meth:`next_time`."""

    @property
    def finished(self) -> bool:
        """Everything has been played (never when looping)."""

    def next_time(self) -> float | None:
        """Run time of its next output, s (None: none)."""


class FamilyEmulation(Protocol):
    """What a family's emulation module declares (see the module docstring)."""

    @property
    def DEVICE(self) -> str:
        """The family emulated."""

    @property
    def SERVE_OPTION(self) -> PortOption:
        """Its ``simulate serve`` port option."""

    def serve_emulator(self, playback: Playback, spec: str | None, *, loop: bool = False
                       ) -> tuple[str | None, Emulator | None]:
        """The port of ``spec`` (None: not served) and the emulator playing ``playback``
        (None: none)."""

    def fault_kinds(self) -> tuple[str, ...]:
        """The faults of its own its emulator takes."""


def emulation(family: str) -> FamilyEmulation:
    """The emulation of ``family`` (one of :data:`~lgvtool.devices.device_registry.FAMILIES`;
    KeyError otherwise)."""
    device_registry.registration(family)
    return cast(FamilyEmulation,
                importlib.import_module(f"lgvtool.sim.emulate.{family}.{family}_emulation"))


def emulations() -> list[FamilyEmulation]:
    """The emulations of every family, in the order devices are named to people
    (:func:`~lgvtool.devices.device_registry.listed`)."""
    return [emulation(r.DEVICE) for r in device_registry.listed()]
