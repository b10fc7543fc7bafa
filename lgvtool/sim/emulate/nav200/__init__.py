"""The virtual NAV200 of ``simulate serve``: :mod:`~lgvtool.sim.emulate.nav200.nav200_emulator`
(the family's device model on a byte stream) and
:mod:`~lgvtool.sim.emulate.nav200.nav200_emulation` (its port option and emulator,
:class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation`)."""
