"""The emulation of the test-only fourth device family ``fake`` (:mod:`fourth_family`): a
:class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation`, its port option declared and
its emulator a greeter that echoes."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from lgvtool.sim.emulate.emulator_registry import PortOption

DEVICE = "fake"
SERVE_OPTION = PortOption("--fake", "fake", "none", help="Where the fake device listens.")


class FakeEmulator:
    """Sends :data:`GREETING` once the run's clock has started; echoes what it receives."""

    FAULT_KINDS: tuple[str, ...] = ()
    GREETING = b"fake says hello"

    def __init__(self) -> None:
        self.greeted = False

    def serve(self, ep: Any, now: float, t: float | None, log: Callable[[str, bytes], None],
              silent: Callable[[], bool]) -> None:
        if ep is None or t is None:
            return
        if not self.greeted and ep.write(self.GREETING, now):
            self.greeted = True
            log("sent", self.GREETING)
        data = ep.read()
        if data:
            log("received", data)
            if ep.write(data, now):
                log("sent", data)

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        raise AssertionError("the fake device takes no faults of its own")


def fault_kinds() -> tuple[str, ...]:
    return FakeEmulator.FAULT_KINDS


def serve_emulator(playback: Any, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, FakeEmulator]:
    return spec, FakeEmulator()
