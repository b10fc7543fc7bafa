"""Run a scenario: settings in, every device-side and host-side fact of the run out.

Order of the settings, later ones winning: the defaults, the scenario's presets, the
``[simulator]`` table of the configuration file, then ``--set`` overrides (``vehicle.*`` keys
change the configuration's vehicle). All randomness comes from one
``numpy.random.default_rng(seed)``, split with ``spawn`` into one stream per part (landmarks,
MCU, MCU link, NAV head, NAV link, faults, drive: the steering wobble, then the docking errors)
so that switching one mechanism off does not reshuffle the draws of the others.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, replace

import numpy as np

from lgvtool.config import Config, Vehicle, config_from_dict, default_config
from lgvtool.devices.nav200.nav200_device import Nav200Device
from lgvtool.errors import ConfigError, InputError
from lgvtool.json_types import JSONObject
from lgvtool.sim import docking, mcu_model, mcu_simlink, nav200_simlink, nav_model
from lgvtool.sim import event_stream as ev
from lgvtool.sim import faults as faultlib
from lgvtool.sim.docking import StationVisit
from lgvtool.sim.faults import FaultEvent, Occlusions
from lgvtool.sim.kinematics import TrueDrive, departures, integrate
from lgvtool.sim.mcu_model import McuOutput
from lgvtool.sim.scenarios import Plan, Scenario, get_scenario
from lgvtool.sim.settings import (
    IDEAL_WORLD,
    WORLD_MODEL,
    InstallSettings,
    SimSettings,
    apply_overrides,
    flatten,
)
from lgvtool.sim.site_model import Landmarks, Site, build_site
from lgvtool.sim.station_poses import Station, setup_stations
from lgvtool.timestamps import seconds_to_ns

STREAMS = ("landmarks", "mcu", "mcu_link", "nav", "nav_link", "faults", "drive")
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
            overrides: Mapping[str, object] | None = None,
            duration: float | None = None) -> Setup:
    """Resolve the scenario, configuration and settings; ConfigError/InputError when bad."""
    sc = get_scenario(scenario)
    cfg = config or default_config()
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {duration}")
    given: dict[str, object] = dict(sc.presets)
    given.update(flatten(cfg.simulator))
    given.update(overrides or {})
    world = IDEAL_WORLD if given.get("sim.world") == "ideal" else {}
    merged: dict[str, object] = {k: v for k, v in world.items() if not k.startswith("scenario.")
                              or k.partition(".")[2] in sc.defaults}
    merged.update(given)
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
    """What the vehicle is told: the scenario's plan with the docking controller's manoeuvre
    at each station (:mod:`lgvtool.sim.docking`)."""
    truth: TrueDrive
    """The true drive (its path of O: :attr:`TrueDrive.path`, the ground truth)."""
    site: Site
    """The true site (reflectors as they stand, the floor): the simulator's alone."""
    occlusions: Occlusions
    scans: nav_model.Scans
    solutions: nav_model.Solutions
    device: Nav200Device
    mcu: McuOutput
    mcu_traffic: mcu_simlink.McuTraffic
    nav_traffic: nav200_simlink.NavTraffic
    faults: tuple[FaultEvent, ...]
    """Every injected fault, in time order."""
    stations: tuple[Station, ...] = ()
    """The scenario's stations, their nominal poses (:mod:`lgvtool.sim.station_poses`)."""
    visits: tuple[StationVisit, ...] = ()
    """Every stop of the run at a station, with the docking controller's error, in time
    order."""

    @property
    def settings(self) -> SimSettings:
        """The effective simulator settings."""
        return self.setup.settings

    @property
    def landmarks(self) -> Landmarks:
        """What the head can detect, with the true identities (:attr:`site`)."""
        return self.site.landmarks

    @property
    def observations(self) -> str:
        """What reflector observations the log carries (the 'simulator' metadata's
        ``observations``): ``"nav350-landmarks"`` (the NAV350's landmarks, its own timestamps
        and ids), ``"paper-scans"`` (a NAV200's reflector scans, logged as the paper's
        experiment had them: ``sim.paper_scans``; no NAV200 host protocol delivers them) or
        ``"none"`` (a NAV200 log: poses only)."""
        if self.settings.sim.nav_device == "nav350":
            return "nav350-landmarks"
        return "paper-scans" if self.settings.sim.paper_scans else "none"

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

    def identification_counts(self) -> dict[str, int]:
        """How the device identified what it saw: ``nav_observations`` (detections),
        ``nav_ids_wrong`` (given the id of another reflector than the one seen, or of a
        reflector for the shiny object) and ``nav_ids_absent`` (given no id)."""
        seen = self.scans.seen
        given = ev.device_ids(self)
        true_ids = self.landmarks.ids[None, :]
        return {"nav_observations": int(seen.sum()),
                "nav_ids_wrong": int((seen & (given != ev.NO_ID) & (given != true_ids)).sum()),
                "nav_ids_absent": int((seen & (given == ev.NO_ID)).sum())}

    def metadata(self) -> JSONObject:
        """The 'simulator' metadata record: scenario, seed, every setting, what was injected."""
        nav = self.nav_traffic
        return {
            "scenario": self.setup.scenario.name,
            "seed": self.seed,
            "world": {"model": WORLD_MODEL, "preset": self.settings.sim.world},
            "observations": self.observations,
            "duration_s": self.duration,
            "start_epoch_s": self.settings.sim.start_epoch_s,
            "settings": self.settings.to_dict(),
            "vehicle": {k: getattr(self.config.vehicle, k) for k in
                        ("h", "track", "nav_x", "nav_y")},
            "reference": {**self.plan.reference},
            "start_pose": {"x": self.plan.x0, "y": self.plan.y0, "heading": self.plan.heading0},
            "faults_injected": {**self.fault_counts()},
            "counts": {
                "mcu_frames_sent": len(self.mcu),
                "nav_revolutions": len(self.scans),
                "nav_valid_solutions": int(self.solutions.valid.sum()),
                "nav_polls": len(nav.poll_times),
                "occlusion_stretches": self.occlusions.count,
                "false_reflector_detections": int(self.scans.seen[:, self.landmarks.is_false]
                                                  .sum()),
                **self.identification_counts(),
            },
            "false_reflector": _false_position(self.landmarks),
            "random_streams": list(STREAMS),
            **({"site_faults": self.site_faults()} if self.site_faults() else {}),
            **({"stations": [st.to_json() for st in self.stations]} if self.stations else {}),
        }

    def site_faults(self) -> JSONObject:
        """The site's faults as they truly are (the ``simulator`` metadata's ``site_faults``,
        absent when there are none), for an audit to be scored against: ``missing`` (layout
        ids), ``moved`` (id, dx, dy m: true minus layout position), ``weak`` (id,
        detection), ``extra`` (every object not in the layout, the older
        ``faults.false_reflector`` one first: x, y m, detection, and ``seen``: revolutions in
        which the head saw it)."""
        out = self.settings.site.faults()
        marks = self.landmarks
        extra = np.nonzero(marks.is_false)[0]
        if len(extra):
            out["extra"] = [{"x": float(marks.x[j]), "y": float(marks.y[j]),
                             "detection": float(marks.detection[j]),
                             "seen": int(self.scans.seen[:, j].sum())} for j in extra]
        return out


def _false_position(marks: Landmarks) -> JSONObject | None:
    idx = np.nonzero(marks.is_false)[0]
    if len(idx) == 0:
        return None
    return {"x": float(marks.x[idx[0]]), "y": float(marks.y[idx[0]])}


def _landmark_faults(sim_marks: Landmarks, occl: Occlusions, scans: nav_model.Scans,
                     solutions: nav_model.Solutions) -> list[FaultEvent]:
    out: list[FaultEvent] = []
    for j, (starts, ends) in enumerate(zip(occl.starts, occl.ends, strict=True)):
        rid = ev.NO_ID if sim_marks.is_false[j] else int(sim_marks.ids[j])  # the layout id
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
             overrides: Mapping[str, object] | None = None,
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


def true_drive(setup: Setup, vehicle: Vehicle, rng: np.random.Generator
               ) -> tuple[Plan, TrueDrive, tuple[StationVisit, ...]]:
    """The drive of a run: the plan of its scenario with the docking controller's manoeuvre at
    each station, the true drive of ``vehicle`` (the true one, :func:`true_vehicle`) on it,
    and the visits of the stations with their docking errors. ``rng``: the run's ``drive``
    stream (the steering wobble first, then the docking errors)."""
    s = setup.settings
    plan = setup.scenario.build(setup.parameters, vehicle, setup.duration, s.sim.rate_hz)
    drive = departures(s.drive, plan.controls.t, rng)
    errors = docking.draw_errors(s.drive, len(plan.stops), rng)
    plan = replace(plan, controls=docking.dock(plan.controls, plan.stops, errors,
                                               s.drive.dock_approach_m, vehicle.h))
    visits = tuple(StationVisit(stop.station, stop.arrive_s, stop.leave_s, e)
                   for stop, e in zip(plan.stops, errors, strict=True))
    truth = integrate(plan.controls, vehicle, plan.x0, plan.y0, plan.heading0, drive,
                      int(s.sim.start_epoch_s) * 1_000_000_000)
    return plan, truth, visits


def run(setup: Setup, seed: int) -> Simulation:
    """Run a resolved setup with ``seed``."""
    s = setup.settings
    cfg = setup.config
    vehicle = true_vehicle(cfg.vehicle, s.install)
    rngs = dict(zip(STREAMS, np.random.default_rng(seed).spawn(len(STREAMS)), strict=True))
    plan, truth, visits = true_drive(setup, vehicle, rngs["drive"])
    site = build_site(cfg.reflectors, cfg.area, s.site, s.faults, rngs["landmarks"])
    marks = site.landmarks
    occl = faultlib.occlusions(len(marks), truth.duration, s.faults.occlusion_fraction,
                               s.faults.occlusion_mean_s, rngs["faults"])
    scans = nav_model.measure(truth, vehicle, s.nav, site, occl, s.nav_noise, rngs["nav"])
    scans, solutions = nav_model.locate(scans, truth, vehicle, s.nav, marks)
    device = nav200_simlink.simulated_device(solutions, cfg.reflectors)
    mcu = mcu_model.simulate(truth, vehicle, s.mcu, s.mcu_noise, rngs["mcu"], s.drive)
    mcu_traffic = mcu_simlink.simulate(mcu, s.mcu, s.faults, s.mcu_noise, rngs["mcu_link"],
                                    rngs["faults"])
    nav_traffic = nav200_simlink.simulate(device, s.nav, s.faults, truth.duration, s.nav_noise,
                                    rngs["nav_link"], rngs["faults"])
    all_faults = [*_landmark_faults(marks, occl, scans, solutions), *mcu_traffic.faults,
                  *nav_traffic.faults]
    all_faults.sort(key=lambda f: f.t)
    return Simulation(setup=setup, seed=seed, plan=plan, truth=truth, site=site,
                      occlusions=occl, scans=scans, solutions=solutions, device=device,
                      mcu=mcu, mcu_traffic=mcu_traffic, nav_traffic=nav_traffic,
                      faults=tuple(all_faults), stations=setup_stations(setup), visits=visits)
