"""The simulator: ground truth, sensor models, faults, scenarios, and the log they make.

Modules, one purpose each:

- :mod:`~lgvtool.sim.kinematics`: the tricycle model, integrated as exact arcs;
- :mod:`~lgvtool.sim.routes`, :mod:`~lgvtool.sim.scenarios`: routes, speed profiles and the
  scenario catalogue;
- :mod:`~lgvtool.sim.docking`: the docking controller (where the vehicle comes to rest at a
  station, each visit with its own error); :mod:`~lgvtool.sim.station_poses`: a scenario's
  stations and their nominal poses (``scenario_stations``);
- :mod:`~lgvtool.sim.mcu_model`: encoders, gyro, drive unit and MCU clock (its serial link is
  :mod:`~lgvtool.sim.mcu_simlink`);
- :mod:`~lgvtool.sim.nav_model`: the NAV200 head (one instant per reflector) and its pose fit
  (the device answering the host is the family's shared model,
  :mod:`lgvtool.devices.nav200.nav200_device`, polled by :mod:`~lgvtool.sim.nav200_simlink`);
  :mod:`~lgvtool.sim.nav350_simlink`: the NAV350 mode (the recorder's own NAV350 session against
  the family's shared model, :mod:`lgvtool.devices.nav350.nav350_device`);
- :mod:`~lgvtool.sim.serial_timing`: serial timing and read chunking;
  :mod:`~lgvtool.sim.faults`: landmarks, occlusions and injected faults;
- :mod:`~lgvtool.sim.settings`: every setting and ``--set`` overrides;
- :mod:`~lgvtool.sim.simulation`: resolve settings and run; :mod:`~lgvtool.sim.event_stream`:
  the run as a time-ordered device-side event stream (for emulators);
  :mod:`~lgvtool.sim.logfile`: the run as a log;
- :mod:`~lgvtool.sim.emulate`: the run (or a log) served as virtual devices, each family's
  emulator in ``sim/emulate/<family>/``.

The simulator sits above the device families (:mod:`lgvtool.devices`): it imports their device
models, codecs and sessions, and no device module imports it.

Typical use::

    from lgvtool.sim import simulate, write_log
    sim = simulate("paper-circle", seed=1, overrides={"nav.skew": False})
    write_log(sim, "run.mcap")
    for event in sim.events():   # TruthSample, McuSend, NavScan, NavSolution in time order
        ...
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.sim.event_stream import McuSend, NavScan, NavSolution, Observation, TruthSample
    from lgvtool.sim.logfile import LogSummary, write_log
    from lgvtool.sim.scenarios import SCENARIOS, Scenario, get_scenario
    from lgvtool.sim.settings import SimSettings, apply_overrides
    from lgvtool.sim.simulation import Setup, Simulation, resolve, run, simulate

_EXPORTS: dict[str, str] = {
    "McuSend": "lgvtool.sim.event_stream",
    "NavScan": "lgvtool.sim.event_stream",
    "NavSolution": "lgvtool.sim.event_stream",
    "Observation": "lgvtool.sim.event_stream",
    "TruthSample": "lgvtool.sim.event_stream",
    "LogSummary": "lgvtool.sim.logfile",
    "write_log": "lgvtool.sim.logfile",
    "Setup": "lgvtool.sim.simulation",
    "Simulation": "lgvtool.sim.simulation",
    "resolve": "lgvtool.sim.simulation",
    "run": "lgvtool.sim.simulation",
    "simulate": "lgvtool.sim.simulation",
    "SCENARIOS": "lgvtool.sim.scenarios",
    "Scenario": "lgvtool.sim.scenarios",
    "get_scenario": "lgvtool.sim.scenarios",
    "SimSettings": "lgvtool.sim.settings",
    "apply_overrides": "lgvtool.sim.settings",
}
"""Public name -> module; imported on first use so that importing a subpackage stays light."""

__all__ = [
    "SCENARIOS",
    "LogSummary",
    "McuSend",
    "NavScan",
    "NavSolution",
    "Observation",
    "Scenario",
    "Setup",
    "SimSettings",
    "Simulation",
    "TruthSample",
    "apply_overrides",
    "get_scenario",
    "resolve",
    "run",
    "simulate",
    "write_log",
]


def __getattr__(name: str) -> object:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'lgvtool.sim' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
