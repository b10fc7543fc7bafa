"""Device emulators: a simulated or logged run served as a virtual NAV200, NAV350 and MCU.

The virtual devices are their families' emulators, one folder per family
(``lgvtool/sim/emulate/<family>/``: ``<family>_emulator.py`` and ``<family>_emulation.py``,
found through :mod:`~lgvtool.sim.emulate.emulator_registry`); this package serves them:

- :mod:`~lgvtool.sim.emulate.emulator_registry`: each family's emulation (its port option and
  emulator), the :class:`~lgvtool.sim.emulate.emulator_registry.Emulator` interface;
- :mod:`~lgvtool.sim.emulate.emulator_playback`: the run to play (from a scenario or a log);
- :mod:`~lgvtool.sim.emulate.endpoints`: pseudo-terminals and TCP ports;
- :mod:`~lgvtool.sim.emulate.emulator_server`: the real-time loop, fault injection, the transcript;
- :mod:`~lgvtool.sim.emulate.serve`: the ``lgvtool simulate serve`` command.

Example (a test or a notebook)::

    from lgvtool.sim.emulate import EmulatorServer, playback_from_scenario

    with EmulatorServer(playback_from_scenario("paper-circle", duration=20), speed=4).start() as s:
        print(s.urls)          # {'nav200': 'serial:///tmp/...', 'mcu': 'serial:///tmp/...'}
"""

from lgvtool.sim.emulate.emulator_playback import (
    McuChunk,
    Playback,
    playback_from_log,
    playback_from_scenario,
)
from lgvtool.sim.emulate.emulator_server import EmulatorServer, Fault, TranscriptEntry, parse_fault

__all__ = [
    "EmulatorServer",
    "Fault",
    "McuChunk",
    "Playback",
    "TranscriptEntry",
    "parse_fault",
    "playback_from_log",
    "playback_from_scenario",
]
