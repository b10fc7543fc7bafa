"""Run a scenario: settings in, every device-side and host-side fact of the run out.

Order of the settings, later ones winning: the defaults, the scenario's presets, the
``[simulator]`` table of the configuration file, then ``--set`` overrides (``vehicle.*`` keys
change the configuration's vehicle). All randomness comes from one
``numpy.random.default_rng(seed)``, split with ``spawn`` into one stream per part (landmarks,
MCU, MCU link, NAV head, NAV link, faults) so that switching one mechanism off does not
reshuffle the draws of the others.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from lgvtool.config import Config, Vehicle, config_from_dict, default_config
from lgvtool.devices.nav200.nav200_device import Nav200Device
from lgvtool.errors import ConfigError, InputError
from lgvtool.sim import event_stream as ev
from lgvtool.sim import faults as faultlib
from lgvtool.sim import mcu_model, mcu_simlink, nav200_simlink, nav_model
from lgvtool.sim.faults import FaultEvent, Landmarks, Occlusions
from lgvtool.sim.kinematics import Trajectory, integrate
from lgvtool.sim.mcu_model import McuOutput
from lgvtool.sim.scenarios import Plan, Scenario, get_scenario
from lgvtool.sim.settings import InstallSettings, SimSettings, apply_overrides, flatten
from lgvtool.timestamps import seconds_to_ns

STREAMS = ("landmarks", "mcu", "mcu_link", "nav", "nav_link", "faults")
"""Names of the random streams spawned from the seed, in spawn order."""


@dataclass(frozen=True)
class Setup:
    """The resolved inputs of a run."""

    scenario: Scenario
    config: Config
    settings: SimSettings
    parameters: dict[str, float]
    duration: float | None


def resolve(scenario: str, *, config: Config | None = None,
            overrides: Mapping[str, Any] | None = None,
            duration: float | None = None) -> Setup:
    """Resolve the scenario, configuration and settings; ConfigError/InputError when bad."""
    sc = get_scenario(scenario)
    cfg = config or default_config()
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {duration}")
    merged: dict[str, Any] = dict(sc.presets)
    merged.update(flatten(cfg.simulator))
    merged.update(overrides or {})
    vehicle = {k.partition(".")[2]: v for k, v in merged.items() if k.startswith("vehicle.")}
    rest = {k: v for k, v in merged.items() if not k.startswith("vehicle.")}
    if vehicle:
        try:
            cfg = config_from_dict({"vehicle": vehicle}, base=cfg)
        except ConfigError as exc:
            raise ConfigError(f"--set: {exc}") from None
    settings = apply_overrides(SimSettings(), rest)
    if not cfg.reflectors:
        raise ConfigError("the configuration has no reflectors for the NAV200 to see")
    params = sc.parameters(settings.scenario)
    settings = replace(settings, scenario=params)
    cfg = replace(cfg, simulator=settings.to_dict(installation=False))
    return Setup(scenario=sc, config=cfg, settings=settings, parameters=params,
                 duration=duration)


@dataclass(frozen=True)
class Simulation:
    """Everything about one simulated run (times in s from the start of the run)."""

    setup: Setup
    seed: int
    plan: Plan
    truth: Trajectory
    landmarks: Landmarks
    occlusions: Occlusions
    scans: nav_model.Scans
    solutions: nav_model.Solutions
    device: Nav200Device
    mcu: McuOutput
    mcu_traffic: mcu_simlink.McuTraffic
    nav_traffic: nav200_simlink.NavTraffic
    faults: tuple[FaultEvent, ...]
    """Every injected fault, in time order."""

    @property
    def settings(self) -> SimSettings:
        """The effective simulator settings."""
        return self.setup.settings

    @property
    def config(self) -> Config:
        """The effective configuration (vehicle, map; ``simulator`` holds the settings)."""
        return self.setup.config

    @property
    def vehicle(self) -> Vehicle:
        """The vehicle as built (:func:`true_vehicle`): the configuration's plus ``install.*``."""
        return true_vehicle(self.config.vehicle, self.settings.install)

    @property
    def duration(self) -> float:
        """Length of the run, s."""
        return self.truth.duration

    @property
    def start_ns(self) -> int:
        """Host time of simulation time 0, ns since the Unix epoch."""
        return int(self.settings.sim.start_epoch_s) * 1_000_000_000

    def host_ns(self, t: float) -> int:
        """Host time of simulation time ``t`` s, integer ns since the Unix epoch."""
        return self.start_ns + seconds_to_ns(t)

    def fault_counts(self) -> dict[str, int]:
        """How many faults of each kind were injected."""
        return dict(sorted(Counter(f.kind for f in self.faults).items()))

    def events(self, truth_rate_hz: float | None = None) -> Iterator[ev.Event]:
        """The device-side event stream (:func:`lgvtool.sim.event_stream.stream`)."""
        return ev.stream(self, truth_rate_hz)

    def metadata(self) -> dict[str, Any]:
        """The 'simulator' metadata record: scenario, seed, every setting, what was injected."""
        nav = self.nav_traffic
        return {
            "scenario": self.setup.scenario.name,
            "seed": self.seed,
            "duration_s": self.duration,
            "start_epoch_s": self.settings.sim.start_epoch_s,
            "settings": self.settings.to_dict(),
            "vehicle": {k: getattr(self.config.vehicle, k) for k in
                        ("h", "track", "nav_x", "nav_y")},
            "reference": self.plan.reference,
            "start_pose": {"x": self.plan.x0, "y": self.plan.y0, "heading": self.plan.heading0},
            "faults_injected": self.fault_counts(),
            "counts": {
                "mcu_frames_sent": len(self.mcu),
                "nav_revolutions": len(self.scans),
                "nav_valid_solutions": int(self.solutions.valid.sum()),
                "nav_polls": len(nav.poll_times),
                "occlusion_stretches": self.occlusions.count,
                "false_reflector_detections": int(self.scans.seen[:, self.landmarks.is_false]
                                                  .sum()),
            },
            "false_reflector": _false_position(self.landmarks),
            "random_streams": list(STREAMS),
        }


def _false_position(marks: Landmarks) -> dict[str, float] | None:
    idx = np.nonzero(marks.is_false)[0]
    if len(idx) == 0:
        return None
    return {"x": float(marks.x[idx[0]]), "y": float(marks.y[idx[0]])}


def _landmark_faults(sim_marks: Landmarks, occl: Occlusions, scans: nav_model.Scans,
                     solutions: nav_model.Solutions) -> list[FaultEvent]:
    out: list[FaultEvent] = []
    for j, (starts, ends) in enumerate(zip(occl.starts, occl.ends, strict=True)):
        rid = int(sim_marks.ids[j])
        what = "shiny object" if sim_marks.is_false[j] else f"reflector {rid}"
        for s, e in zip(starts, ends, strict=True):
            out.append(FaultEvent(float(s), "simulator", "reflector_occluded",
                                  f"{what} hidden for {e - s:.1f} s",
                                  {"reflector_id": rid, "duration_s": float(e - s)}))
    for k in np.nonzero(solutions.false_used)[0]:
        out.append(FaultEvent(float(solutions.available[k]), "simulator", "false_reflector_used",
                              "the NAV200 took the shiny object for a reflector in its fit",
                              {"scan_start_s": float(scans.start[k])}))
    return out


def simulate(scenario: str, *, seed: int = 0, config: Config | None = None,
             overrides: Mapping[str, Any] | None = None,
             duration: float | None = None) -> Simulation:
    """Simulate ``scenario`` (see :data:`lgvtool.sim.scenarios.SCENARIOS`) with ``seed``.

    :param config: vehicle, area and reflector map (default: the paper's hall).
    :param overrides: ``{"section.key": value}`` settings (``--set``), incl. ``vehicle.*``.
    :param duration: length of the run, s (default: the scenario's own).
    """
    setup = resolve(scenario, config=config, overrides=overrides, duration=duration)
    return run(setup, seed)


def true_vehicle(vehicle: Vehicle, install: InstallSettings) -> Vehicle:
    """The vehicle as it is built: the configured one with the ``install.*`` errors added (the
    wheel radii's errors are applied by the MCU model, :mod:`lgvtool.sim.mcu_model`)."""
    if install == InstallSettings():
        return vehicle
    return replace(vehicle, nav_x=vehicle.nav_x + install.nav_dx_mm * 1e-3,
                   nav_y=vehicle.nav_y + install.nav_dy_mm * 1e-3,
                   nav_yaw=vehicle.nav_yaw + math.radians(install.nav_yaw_deg),
                   track=vehicle.track + install.track_error_mm * 1e-3)


def run(setup: Setup, seed: int) -> Simulation:
    """Run a resolved setup with ``seed``."""
    s = setup.settings
    cfg = setup.config
    vehicle = true_vehicle(cfg.vehicle, s.install)
    rngs = dict(zip(STREAMS, np.random.default_rng(seed).spawn(len(STREAMS)), strict=True))
    plan = setup.scenario.build(setup.parameters, vehicle, setup.duration, s.sim.rate_hz)
    truth = integrate(plan.controls, vehicle, plan.x0, plan.y0, plan.heading0)
    marks = faultlib.landmarks(cfg.reflectors, cfg.area, s.faults, s.nav.map_sigma_mm * 1e-3,
                               rngs["landmarks"])
    occl = faultlib.occlusions(len(marks), truth.duration, s.faults.occlusion_fraction,
                               s.faults.occlusion_mean_s, rngs["faults"])
    scans = nav_model.measure(truth, vehicle, s.nav, marks, occl, s.nav_noise,
                              s.faults.false_detection_probability, rngs["nav"])
    solutions = nav_model.solve(scans, truth, vehicle, s.nav, marks)
    device = nav200_simlink.simulated_device(solutions, cfg.reflectors)
    mcu = mcu_model.simulate(truth, vehicle, s.mcu, s.mcu_noise, rngs["mcu"])
    mcu_traffic = mcu_simlink.simulate(mcu, s.mcu, s.faults, s.mcu_noise, rngs["mcu_link"],
                                    rngs["faults"])
    nav_traffic = nav200_simlink.simulate(device, s.nav, s.faults, truth.duration, s.nav_noise,
                                    rngs["nav_link"], rngs["faults"])
    all_faults = [*_landmark_faults(marks, occl, scans, solutions), *mcu_traffic.faults,
                  *nav_traffic.faults]
    all_faults.sort(key=lambda f: f.t)
    return Simulation(setup=setup, seed=seed, plan=plan, truth=truth, landmarks=marks,
                      occlusions=occl, scans=scans, solutions=solutions, device=device,
                      mcu=mcu, mcu_traffic=mcu_traffic, nav_traffic=nav_traffic,
                      faults=tuple(all_faults))
