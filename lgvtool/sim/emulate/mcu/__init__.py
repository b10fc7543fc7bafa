"""The virtual MCU of ``simulate serve``: :mod:`~lgvtool.sim.emulate.mcu.mcu_emulator` (the
played run's frame bytes, each at its time) and :mod:`~lgvtool.sim.emulate.mcu.mcu_emulation`
(its port option and emulator, :class:`~lgvtool.sim.emulate.emulator_registry.FamilyEmulation`)."""
