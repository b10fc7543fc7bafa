"""The stations of a scenario: where its route stops for load handling, as planned.

A station's nominal pose is where the plan brings the vehicle's origin O to rest there (the
kinematic plan, before the docking controller's error, :mod:`lgvtool.sim.docking`): every
visit of the station aims at it, and the true stop of each visit is that pose plus the
visit's docking error and what the true drive adds (``drive.*``). The ``simulator`` metadata
record of a simulated log lists them (``stations``: name, x, y m, heading_deg), and
:func:`scenario_stations` gives them for a scenario and its settings without running it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lgvtool.angles import wrap_scalar
from lgvtool.config import Config, Vehicle
from lgvtool.json_types import JSONObject
from lgvtool.sim.kinematics import integrate
from lgvtool.sim.scenarios import Plan

if TYPE_CHECKING:  # simulation imports this module
    from lgvtool.sim.simulation import Setup


@dataclass(frozen=True)
class Station:
    """A station's nominal pose: where O comes to rest there by the plan."""

    name: str
    """The station's name (``pick``, ``drop`` on ``warehouse``)."""
    x: float
    """x of O at the nominal stop, m."""
    y: float
    """y of O at the nominal stop, m."""
    heading: float
    """Heading of the vehicle at the nominal stop, rad, in (-pi, pi]."""

    def to_json(self) -> JSONObject:
        """The station as the ``simulator`` metadata lists it: name, x and y (m), heading_deg
        (deg)."""
        return {"name": self.name, "x": self.x, "y": self.y,
                "heading_deg": math.degrees(self.heading)}


def nominal_stations(plan: Plan, vehicle: Vehicle) -> tuple[Station, ...]:
    """The stations of ``plan`` (its drive commands without docking errors), in the order of
    their first visit: the pose of O, integrated kinematically for ``vehicle`` (m, rad), in the
    middle of that visit's standstill. Empty for a plan without stops."""
    first: dict[str, float] = {}
    for stop in plan.stops:
        first.setdefault(stop.station, 0.5 * (stop.arrive_s + min(stop.leave_s,
                                                                  float(plan.controls.t[-1]))))
    if not first:
        return ()
    drive = integrate(plan.controls, vehicle, plan.x0, plan.y0, plan.heading0)
    x, y, heading = drive.pose_at(np.array(list(first.values())))
    return tuple(Station(name, float(x[i]), float(y[i]), wrap_scalar(float(heading[i])))
                 for i, name in enumerate(first))


def setup_stations(setup: Setup) -> tuple[Station, ...]:
    """The stations of a resolved run (:func:`lgvtool.sim.simulation.resolve`): those of one
    lap of its scenario (every lap visits the same ones) with its settings and true vehicle;
    none, without building anything, for a scenario without stations."""
    from lgvtool.sim.simulation import true_vehicle

    if not setup.scenario.stations:
        return ()
    params = dict(setup.parameters)
    if "laps" in params:
        params["laps"] = 1.0
    vehicle = true_vehicle(setup.config.vehicle, setup.settings.install)
    plan = setup.scenario.build(params, vehicle, None, setup.settings.sim.rate_hz)
    return nominal_stations(plan, vehicle)


def scenario_stations(scenario: str, overrides: Mapping[str, object] | None = None, *,
                      config: Config | None = None) -> tuple[Station, ...]:
    """The stations of ``scenario`` (nominal poses of O: x, y m, heading rad), in the order the
    route first visits them; empty for a scenario without stations.

    :param overrides: settings as :func:`lgvtool.sim.simulation.simulate` takes them
        (``{"scenario.length_b": 8.0, "vehicle.h": 1.3}``); a key without a section is a
        scenario parameter (``{"length_b": 8.0}``). The stations depend on the scenario's
        parameters and the vehicle's wheelbase (the turns), nothing else.
    :param config: the configuration (default: the paper's vehicle and hall).
    :raises InputError: an unknown scenario; ConfigError: a bad setting.
    """
    from lgvtool.sim.simulation import resolve

    given = {(k if "." in k else f"scenario.{k}"): v for k, v in (overrides or {}).items()}
    return setup_stations(resolve(scenario, config=config, overrides=given))
