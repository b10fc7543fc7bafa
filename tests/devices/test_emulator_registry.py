"""Each device family's emulation (lgvtool/sim/emulate/<family>/): the sim-side registry that
``simulate serve`` and the emulator server go through."""

from __future__ import annotations

import pytest

from lgvtool.devices.device_registry import FAMILIES, listed
from lgvtool.sim.emulate.emulator_registry import FamilyEmulation, emulation, emulations
from lgvtool.sim.emulate.mcu import mcu_emulation
from lgvtool.sim.emulate.nav200 import nav200_emulation
from lgvtool.sim.emulate.nav350 import nav350_emulation

#: every emulation satisfies the Protocol: mypy checks each module against it (``mypy tests``)
CHECKED: tuple[FamilyEmulation, ...] = (mcu_emulation, nav200_emulation, nav350_emulation)


def test_every_family_has_its_emulation_in_listed_order() -> None:
    assert [emulation(f) for f in FAMILIES] == list(CHECKED)
    assert [e.DEVICE for e in emulations()] == [r.DEVICE for r in listed()] \
        == ["nav200", "nav350", "mcu"]
    with pytest.raises(KeyError):
        emulation("nav300")


def test_the_port_options_and_where_they_serve_by_default() -> None:
    options = {e.DEVICE: e.SERVE_OPTION for e in emulations()}
    assert {d: (o.flag, o.param, o.default, o.served_at) for d, o in options.items()} == {
        "nav200": ("--nav", "nav", "pty", "pty"), "nav350": ("--nav350", "nav350", "none", None),
        "mcu": ("--mcu", "mcu", "pty", "pty")}


def test_the_emulators_and_their_own_faults() -> None:
    from devices_helpers import circle_playback

    from lgvtool.sim.emulate.mcu.mcu_emulator import VirtualMcu
    from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200
    from lgvtool.sim.emulate.nav350.nav350_emulator import VirtualNav350

    assert {e.DEVICE: e.fault_kinds() for e in emulations()} == {
        "nav200": ("reset",), "nav350": ("reset", "sfa", "error", "badsum"), "mcu": ()}
    playback = circle_playback(2.0)
    port, mcu = mcu_emulation.serve_emulator(playback, None, loop=True)
    assert port is None and isinstance(mcu, VirtualMcu) and mcu.loop
    port, nav = nav200_emulation.serve_emulator(playback, "pty")
    assert port == "pty" and isinstance(nav, VirtualNav200)
    assert nav350_emulation.serve_emulator(playback, None) == (None, None)
    port, nav350 = nav350_emulation.serve_emulator(playback, "tcp://h:1?drift_ppm=20")
    assert port == "tcp://h:1" and isinstance(nav350, VirtualNav350)
