"""The virtual NAV350 of ``simulate serve``: :mod:`~lgvtool.sim.emulate.nav350.nav350_emulator`
(the family's device model behind the SOPAS protocol, with its faults),
:mod:`~lgvtool.sim.emulate.nav350.nav350_emulation` (its port option and emulator,
:class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation`) and
:mod:`~lgvtool.sim.emulate.nav350.nav350_loopback` (the recorder against the emulator, end to
end)."""
