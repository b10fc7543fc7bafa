"""The scenario catalogue: what the vehicle drives, and the settings each scenario presets.

A scenario turns its parameters (``scenario.*`` settings, SI unless the key says ``_deg``)
and an optional duration into a :class:`Plan`: the start pose of O, the drive commands on
the integration grid and the stops at stations (where the vehicle docks,
:mod:`lgvtool.sim.docking`; their nominal poses: :mod:`lgvtool.sim.station_poses`). Faults and
device settings that a scenario implies are *presets*, applied before the user's own
``--config`` and ``--set`` values.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from lgvtool.config import Vehicle
from lgvtool.declared import as_dict, make, setting
from lgvtool.errors import ConfigError, InputError
from lgvtool.sim.kinematics import Controls
from lgvtool.sim.routes import Leg, StationStop, lay_out, sample, straight, turn
from lgvtool.suggest import unknown_tail

MAX_REPEATS = 10_000.0
"""Most laps or rotations of a scenario (8 rotations of the paper's circle take 100 s)."""


@dataclass(frozen=True)
class Plan:
    """Start pose of O and drive commands of a scenario."""

    x0: float
    """Start x of O, m."""
    y0: float
    """Start y of O, m."""
    heading0: float
    """Start heading, rad."""
    controls: Controls
    reference: dict[str, float] = field(default_factory=dict)
    """What the scenario promises, for evaluation: e.g. circle centre and radius, m."""
    stops: tuple[StationStop, ...] = ()
    """The stops at stations that the run completes (arrives and drives off again, or stands
    to the end), in time order; none for a scenario without stations."""


Builder = Callable[[Mapping[str, float], Vehicle, float | None, float], Plan]


@dataclass(frozen=True)
class Scenario:
    """A named scenario: its description, its parameters (a group of declared settings,
    :mod:`lgvtool.declared`, with this scenario's defaults), presets and builder."""

    name: str
    description: str
    base: object
    """The scenario's parameters at their defaults (:class:`CircleParameters`,
    :class:`WarehouseParameters`)."""
    build: Builder
    presets: Mapping[str, object] = field(default_factory=dict)
    stations: tuple[str, ...] = ()
    """The names of the stations its route stops at, in the order of their first visit (none:
    a scenario without stations)."""

    @property
    def defaults(self) -> dict[str, float]:
        """The parameters' defaults by key."""
        return {k: float(v) for k, v in as_dict(self.base).items() if isinstance(v, int | float)}

    def parameters(self, overrides: Mapping[str, object]) -> dict[str, float]:
        """Defaults updated with ``overrides``, each checked by its declaration; ConfigError
        for an unknown key or a bad value."""
        group = make(type(self.base), "scenario", overrides, base=self.base, what="setting",
                     more="{n} settings of " + self.name + "; lgvtool simulate --list lists them")
        return {k: float(v) for k, v in as_dict(group).items() if isinstance(v, int | float)}


# --------------------------------------------------------------------------- circle

@dataclass(frozen=True)
class CircleParameters:
    """The ``scenario.*`` settings of the circle scenarios (``paper-circle``, ``fast``,
    ``degraded``)."""

    speed: float = setting(0.36, "drive wheel speed v_d, m/s (paper: 36 cm/s)", unit="m/s", minimum=0.0,
                           min_open=True, maximum=10.0)
    steering_deg: float = setting(60.0, "steering angle, deg (paper: 60)", unit="deg", minimum=-90.0,
                                  maximum=90.0, min_open=True, max_open=True)
    rotations: float = setting(8.0, "full rotations of O (paper: 8); ignored when --duration "
                               "is given", minimum=0.0, min_open=True, maximum=MAX_REPEATS)
    overrun_deg: float = setting(10.0, "planned turn past the last rotation, so that a vehicle "
                                 "turning a little less than planned completes it, deg",
                                 minimum=0.0, maximum=360.0)
    standstill_s: float = setting(5.0, "standstill at the start, s", minimum=0.0)
    leadout_s: float = setting(3.0, "standstill at the end, s", minimum=0.0)
    accel: float = setting(0.3, "drive wheel acceleration, m/s^2", minimum=0.0, min_open=True,
                           maximum=100.0)
    centre_x: float = setting(11.0, "circle centre x, m")
    centre_y: float = setting(9.0, "circle centre y, m")
    start_heading_deg: float = setting(0.0, "heading at the start, deg", minimum=-360.0,
                                       maximum=360.0)


def _positive(params: Mapping[str, float], *keys: str) -> None:
    for key in keys:
        if params[key] <= 0:
            raise ConfigError(f"scenario.{key} must be positive, got {params[key]}")


def build_circle(params: Mapping[str, float], vehicle: Vehicle, duration: float | None,
                 rate_hz: float) -> Plan:
    """The paper's experiment: steer to a fixed angle at standstill, drive circles, stop.

    The drive goes on ``overrun_deg`` past the last planned rotation: the true vehicle turns a
    little less (or more) than the plan's kinematics say (``drive.*``), and must still complete
    every rotation (0.1 % less yaw rate is 2.9 deg short after eight)."""
    _positive(params, "speed", "accel", "rotations")
    delta = math.radians(params["steering_deg"])
    if not 0.0 < abs(delta) < math.pi / 2:
        raise ConfigError("scenario.steering_deg must be in (0, 90) in magnitude")
    if params["standstill_s"] < 0 or params["leadout_s"] < 0:
        raise ConfigError("scenario.standstill_s and scenario.leadout_s must not be negative")
    if not 0.0 <= params["overrun_deg"] <= 360.0:
        raise ConfigError(f"scenario.overrun_deg must be in [0, 360], got {params['overrun_deg']}")
    speed, accel = params["speed"], params["accel"]
    lead_in, lead_out = params["standstill_s"], params["leadout_s"]
    if duration is None:
        turn = 2.0 * math.pi * params["rotations"] + math.radians(params["overrun_deg"])
        travel = turn * vehicle.h / math.sin(abs(delta))
    else:
        moving = duration - lead_in - lead_out
        if moving <= 0:
            raise InputError(f"--duration {duration:g} s leaves no time to drive after the "
                             f"{lead_in:g} s standstill and {lead_out:g} s lead-out")
        if moving >= 2 * speed / accel:
            travel = speed * (moving - speed / accel)
        else:
            travel = accel * (moving / 2) ** 2
    profile = lay_out([straight(travel, speed, steering=delta)], accel, start_time=lead_in)
    total = duration if duration is not None else profile.end_time + lead_out
    controls = sample(profile, total, rate_hz)
    radius = vehicle.circle_radius(delta)
    th0 = math.radians(params["start_heading_deg"])
    side = 1.0 if delta > 0 else -1.0  # centre to the left of O for a left turn
    cx, cy = params["centre_x"], params["centre_y"]
    x0 = cx + side * radius * math.sin(th0)
    y0 = cy - side * radius * math.cos(th0)
    return Plan(x0=x0, y0=y0, heading0=th0, controls=controls,
                reference={"centre_x": cx, "centre_y": cy, "radius": radius,
                           "steering_angle": delta, "drive_speed": speed,
                           "moving_from_s": lead_in, "moving_until_s": profile.end_time})


# --------------------------------------------------------------------------- warehouse

@dataclass(frozen=True)
class WarehouseParameters:
    """The ``scenario.*`` settings of ``warehouse``."""

    speed: float = setting(0.8, "drive wheel speed on straights, m/s", minimum=0.0,
                           min_open=True, maximum=10.0)
    turn_speed: float = setting(0.4, "drive wheel speed in turns, m/s", minimum=0.0,
                                min_open=True, maximum=10.0)
    reverse_speed: float = setting(0.3, "drive wheel speed when reversing, m/s", minimum=0.0,
                                   min_open=True, maximum=10.0)
    accel: float = setting(0.3, "drive wheel acceleration, m/s^2", minimum=0.0, min_open=True,
                           maximum=100.0)
    steering_deg: float = setting(60.0, "steering angle held in a turn, deg", minimum=0.0,
                                  maximum=90.0, min_open=True, max_open=True)
    steering_rate_deg_per_m: float = setting(
        60.0, "steering change per metre of drive wheel travel, deg/m", unit="deg/m",
        minimum=0.0, min_open=True)
    length_a: float = setting(10.0, "long straights, m", minimum=0.0, min_open=True)
    length_b: float = setting(6.0, "short straights (each holds a station halfway: the pick "
                              "station on the first, the drop station on the second), m",
                              minimum=0.0, min_open=True)
    reverse_length: float = setting(2.0, "reverse leg after the pick station, m", minimum=0.0,
                                    min_open=True)
    pick_dwell_s: float = setting(3.0, "standstill at the pick station (load handling), s",
                                  minimum=0.0, min_open=True)
    drop_dwell_s: float = setting(4.0, "standstill at the drop station (setting the load "
                                  "down), s", minimum=0.0, min_open=True)
    laps: float = setting(2.0, "laps of the route; ignored when --duration is given",
                          minimum=0.0, min_open=True, maximum=MAX_REPEATS)
    standstill_s: float = setting(5.0, "standstill at the start, s", minimum=0.0)
    leadout_s: float = setting(3.0, "standstill at the end, s", minimum=0.0)
    start_x: float = setting(6.0, "start of O, x, m")
    start_y: float = setting(4.0, "start of O, y, m")
    start_heading_deg: float = setting(0.0, "start heading, deg", minimum=-360.0,
                                       maximum=360.0)


PICK = "pick"
"""The warehouse's pick station: halfway along the first short side, left after a reverse leg."""
DROP = "drop"
"""The warehouse's drop station: halfway along the second short side, left forward."""


REVERSE_PAUSE_S = 1.0
"""The standstill at the end of the warehouse's reverse leg, s: a pause, not a station (shorter
than the 2 s a standstill detector would need)."""


def _warehouse_lap(params: Mapping[str, float], vehicle: Vehicle) -> list[Leg]:
    """One lap: a rectangle of long and short straights joined by left 90-degree turns; halfway
    along the first short side the vehicle stops at the pick station, reverses out, stops for
    1 s (not a station) and drives on; halfway along the second it stops at the drop station
    and drives on."""
    speed, tspeed, rspeed = params["speed"], params["turn_speed"], params["reverse_speed"]
    delta = math.radians(params["steering_deg"])
    per_m = math.radians(params["steering_rate_deg_per_m"])
    quarter = turn(math.pi / 2, delta, per_m, vehicle.h, tspeed)
    a, b, rev = params["length_a"], params["length_b"], params["reverse_length"]
    half = b / 2
    return [
        straight(a, speed),
        quarter,
        straight(half, speed, dwell=params["pick_dwell_s"], station=PICK),
        straight(rev, rspeed, direction=-1, dwell=REVERSE_PAUSE_S),
        straight(rev, rspeed),
        straight(b - half, speed),
        quarter,
        straight(a, speed),
        quarter,
        straight(half, speed, dwell=params["drop_dwell_s"], station=DROP),
        straight(b - half, speed),
        quarter,
    ]


def build_warehouse(params: Mapping[str, float], vehicle: Vehicle, duration: float | None,
                    rate_hz: float) -> Plan:
    """Laps of a warehouse route: straights, 90-degree turns, a pick and a drop station and a
    reverse leg."""
    _positive(params, "speed", "turn_speed", "reverse_speed", "accel", "steering_rate_deg_per_m",
              "length_a", "length_b", "reverse_length", "laps")
    delta = math.radians(params["steering_deg"])
    if not 0.0 < delta < math.pi / 2:
        raise ConfigError("scenario.steering_deg must be in (0, 90)")
    for key in ("pick_dwell_s", "drop_dwell_s"):
        if params[key] <= 0:
            raise ConfigError(f"scenario.{key} must be positive")
    try:
        lap = _warehouse_lap(params, vehicle)
    except ValueError as exc:
        raise ConfigError(f"scenario: {exc}") from None
    lead_in, lead_out = params["standstill_s"], params["leadout_s"]
    accel = params["accel"]
    if duration is None:
        laps = max(1, round(params["laps"]))
    else:
        moving = duration - lead_in - lead_out
        one = lay_out(lap, accel, resolution=0.01).end_time
        laps = max(1, math.floor(moving / one)) if moving > 0 else 1
    profile = lay_out(lap * laps, accel, start_time=lead_in)
    total = duration if duration is not None else profile.end_time + lead_out
    controls = sample(profile, total, rate_hz)
    return Plan(x0=params["start_x"], y0=params["start_y"],
                heading0=math.radians(params["start_heading_deg"]), controls=controls,
                reference={"laps": float(laps), "moving_from_s": lead_in,
                           "moving_until_s": profile.end_time},
                stops=tuple(s for s in profile.stops if s.arrive_s < total))


# --------------------------------------------------------------------------- catalogue

CIRCLE_PRESETS: dict[str, object] = {"drive.path_control_m": 0.0}
"""The circle scenarios hold the steering angle, as the paper's experiment did: no path
controller brings the vehicle back to the planned circle."""

DEGRADED_PRESETS: dict[str, object] = {
    **CIRCLE_PRESETS,
    "faults.mcu_drop_rate": 0.02,
    "faults.mcu_corrupt_rate": 0.02,
    "faults.nav_request_drop_rate": 0.02,
    "faults.nav_reply_drop_rate": 0.02,
    "faults.nav_corrupt_rate": 0.03,
    "faults.nav_invalid_rate": 0.03,
    "faults.occlusion_fraction": 0.15,
    "faults.occlusion_mean_s": 6.0,
    # a shiny object 0.3 m along the south wall from reflector 3 of the paper's hall (10.2644,
    # 0.05): where the older faults.false_reflector put it, seen on 60 % of revolutions
    "site.extra": ({"x": 10.2644 + 0.3, "y": 0.05, "detection": 0.6},),
}
"""Fault settings of the ``degraded`` scenario (its shiny object is one ``site.extra``
object: beside reflector 3 of the paper's hall, not of another layout)."""

SCENARIOS: dict[str, Scenario] = {
    "paper-circle": Scenario(
        name="paper-circle",
        description=("The paper's experiment: 25 m x 20 m hall with 20 wall reflectors, drive "
                     "wheel at 36 cm/s, steering fixed at 60 deg, eight full rotations of O on "
                     "a circle of radius h/tan(60 deg) (and 10 deg more), after a 5 s "
                     "standstill, then a 3 s lead-out."),
        base=CircleParameters(),
        build=build_circle,
        presets=CIRCLE_PRESETS,
    ),
    "warehouse": Scenario(
        name="warehouse",
        description=("Two laps of a 10 m x 6 m rectangular route at 0.8 m/s with left "
                     "90-degree turns at 0.4 m/s; on each lap a 3 s stop at the pick station, "
                     "a 2 m reverse leg and back, and a 4 s stop at the drop station; the "
                     "vehicle docks at each station to within its docking controller's "
                     "repeatability (drive.dock_*)."),
        base=WarehouseParameters(),
        build=build_warehouse,
        stations=(PICK, DROP),
    ),
    "fast": Scenario(
        name="fast",
        description="paper-circle at twice the speed: drive wheel at 72 cm/s.",
        base=CircleParameters(speed=0.72),
        build=build_circle,
        presets=CIRCLE_PRESETS,
    ),
    "degraded": Scenario(
        name="degraded",
        description=("paper-circle over bad links and a cluttered hall: 2 % of MCU frames "
                     "dropped and 2 % corrupted, 2 % of NAV requests and 2 % of replies lost, "
                     "3 % of replies corrupted, 3 % 'no valid position', every reflector hidden "
                     "15 % of the time in ~6 s stretches, and a shiny object beside reflector "
                     "3 that the head takes for a reflector."),
        base=CircleParameters(),
        build=build_circle,
        presets=DEGRADED_PRESETS,
    ),
}
"""Every scenario by name."""


def get_scenario(name: str) -> Scenario:
    """The scenario called ``name``; InputError naming the known ones otherwise."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise InputError(f"unknown scenario '{name}'" + unknown_tail(name, SCENARIOS)) from None
