"""Routes as legs of drive-wheel travel, and their time profile as drive commands.

A route is a list of legs. Each leg fixes, as functions of the drive wheel's travel along it,
the steering angle (piecewise linear) and the direction (forward or reverse), plus a speed
limit and an optional stop with a dwell at its end, which may be a station's (the vehicle docks
there: :mod:`lgvtool.sim.docking`). Because the heading change of the
tricycle is ``(1/h) * integral of sin(delta) d(travel)``, the geometry of the path does not
depend on the speed profile: turns come out exact whatever the acceleration.

The speed profile is the fastest one under the limits and a constant acceleration ``accel``,
computed on a fine grid of travel with running minima (no Python loop over points): the squared
speed at travel p is the smallest of ``limit_j^2 + 2 accel |p - p_j|`` over all grid points j.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lgvtool.errors import ConfigError
from lgvtool.sim.kinematics import Controls, FloatArray


@dataclass(frozen=True)
class Leg:
    """One stretch of a route.

    :param length: drive wheel travel along the leg, m (positive).
    :param steering: knots (travel from the leg start m, steering angle rad), piecewise linear.
    :param direction: +1 forward, -1 reverse.
    :param max_speed: limit of the drive wheel speed, m/s.
    :param dwell: standstill at the end of the leg, s; > 0 forces a stop there.
    :param station: the name of the station at which the leg's stop is ('' none: a stop, no
        station); a station's leg needs a dwell.
    """

    length: float
    steering: tuple[tuple[float, float], ...]
    direction: int = 1
    max_speed: float = 0.5
    dwell: float = 0.0
    station: str = ""

    @property
    def is_straight(self) -> bool:
        """True when the steering angle is 0 all along the leg."""
        return all(delta == 0.0 for _, delta in self.steering)


def straight(length: float, max_speed: float, *, direction: int = 1, dwell: float = 0.0,
             steering: float = 0.0, station: str = "") -> Leg:
    """A leg at a constant steering angle (0: straight), ``length`` m of drive wheel travel,
    ending at ``station`` ('' none) when it has one."""
    if station and dwell <= 0:
        raise ValueError(f"the stop at station {station!r} needs a dwell")
    return Leg(length=length, steering=((0.0, steering), (length, steering)),
               direction=direction, max_speed=max_speed, dwell=dwell, station=station)


def turn(angle: float, steering_max: float, steering_per_m: float, h: float,
         max_speed: float) -> Leg:
    """A forward turn by ``angle`` rad (CCW positive): steer in at ``steering_per_m`` rad per m
    of travel up to ``steering_max`` rad, hold, steer out; the hold is sized so that the heading
    changes by exactly ``angle``. ``h`` is the wheelbase O to drive wheel, m."""
    sign = 1.0 if angle >= 0 else -1.0
    d = abs(steering_max)
    ramp = d / steering_per_m
    ramp_turn = (1.0 - math.cos(d)) / (h * steering_per_m)  # heading change of one ramp, rad
    hold = (abs(angle) - 2.0 * ramp_turn) * h / math.sin(d)
    if hold < 0:
        raise ValueError("turn too small for its steering ramps")
    length = 2.0 * ramp + hold
    knots = ((0.0, 0.0), (ramp, sign * d), (ramp + hold, sign * d), (length, 0.0))
    return Leg(length=length, steering=knots, direction=1, max_speed=max_speed)


@dataclass(frozen=True)
class StationStop:
    """One stop of a route at a station, where the vehicle docks (:mod:`lgvtool.sim.docking`).

    The straight travel on either side of the stop bounds how far back the docking controller
    may start its approach and how far on it may bring the vehicle back to the route.
    """

    station: str
    """The station's name."""
    travel: float
    """Drive wheel travel from the start of the route to the stop, m."""
    arrive_s: float
    """Time at which the vehicle comes to a standstill there, s."""
    leave_s: float
    """Time at which it drives off again, s."""
    straight_before: float
    """Straight travel (steering 0) of the leg ending at the stop, m (0: its leg turns)."""
    straight_after: float
    """Straight travel of the leg after the stop, m (0: it turns, or the route ends)."""
    direction_before: int
    """Direction of the leg ending at the stop: +1 forward, -1 reverse."""
    direction_after: int
    """Direction of the leg after it (that of the leg before when the route ends there)."""


@dataclass(frozen=True)
class Profile:
    """A route laid out in time: drive wheel travel p(t) at nodes, plus what the legs define."""

    t_nodes: FloatArray
    """Times of the nodes, s (non-decreasing; a dwell repeats a travel value)."""
    p_nodes: FloatArray
    """Drive wheel travel at the nodes, m (non-decreasing)."""
    leg_starts: FloatArray
    """Travel at which each leg starts, m."""
    directions: FloatArray
    """Direction of each leg, +1 or -1."""
    steer_p: FloatArray
    """Travel of the steering knots, m."""
    steer_delta: FloatArray
    """Steering angle at the knots, rad."""
    stops: tuple[StationStop, ...] = ()
    """The stops at stations, in route order."""

    @property
    def end_time(self) -> float:
        """Time at which the last node is reached, s."""
        return float(self.t_nodes[-1])


def lay_out(legs: list[Leg], accel: float, start_time: float = 0.0,
            resolution: float = 0.002) -> Profile:
    """Time profile of ``legs`` from standstill at ``start_time`` to standstill at the end.

    ``accel`` is the acceleration and deceleration of the drive wheel, m/s^2; ``resolution``
    the spacing of the travel grid, m (coarsened to keep at most ~2 million points).
    """
    if not legs:
        raise ValueError("a route needs at least one leg")
    total = sum(leg.length for leg in legs)
    dp = max(resolution, total / 2_000_000)
    starts = np.concatenate([[0.0], np.cumsum([leg.length for leg in legs])])
    counts = [max(1, math.ceil(leg.length / dp)) for leg in legs]
    pieces = [np.linspace(starts[i], starts[i + 1], counts[i] + 1)[:-1] for i in range(len(legs))]
    p = np.concatenate([*pieces, [starts[-1]]])
    limit = np.empty_like(p)
    node_leg = np.repeat(np.arange(len(legs)), counts)
    limit[:-1] = np.array([leg.max_speed for leg in legs])[node_leg]
    limit[-1] = 0.0
    boundary = np.concatenate([[0], np.cumsum(counts)])  # node index of each leg start / end
    limit[0] = 0.0
    dwell_at = np.zeros_like(p)
    for i in range(len(legs) - 1):
        j = boundary[i + 1]
        stop = legs[i].dwell > 0 or legs[i].direction != legs[i + 1].direction
        limit[j] = 0.0 if stop else min(legs[i].max_speed, legs[i + 1].max_speed)
        dwell_at[j] = max(legs[i].dwell, 0.5 if legs[i].direction != legs[i + 1].direction else 0)
    dwell_at[-1] = 0.0
    lim2 = limit ** 2
    fwd = 2 * accel * p + np.minimum.accumulate(lim2 - 2 * accel * p)
    bwd = -2 * accel * p + np.minimum.accumulate((lim2 + 2 * accel * p)[::-1])[::-1]
    speed = np.sqrt(np.maximum(np.minimum(np.minimum(fwd, bwd), lim2), 0.0))
    seg = np.diff(p)
    dt = 2.0 * seg / np.maximum(speed[:-1] + speed[1:], 1e-12)
    t_arrive = start_time + np.concatenate([[0.0], np.cumsum(dt)])
    shift = np.concatenate([[0.0], np.cumsum(dwell_at)[:-1]])
    t_arrive = t_arrive + shift  # a node is reached after all dwells before it
    stops = np.nonzero(dwell_at > 0)[0]
    t_nodes = np.insert(t_arrive, stops + 1, t_arrive[stops] + dwell_at[stops])
    p_nodes = np.insert(p, stops + 1, p[stops])
    station_stops: list[StationStop] = []
    for i, leg in enumerate(legs):
        if not leg.station:
            continue
        j = int(boundary[i + 1])
        after = legs[i + 1] if i + 1 < len(legs) else None
        arrive = float(t_arrive[j])
        dwell = float(dwell_at[j]) if after is not None else leg.dwell  # the route ends there
        station_stops.append(StationStop(
            station=leg.station, travel=float(p[j]), arrive_s=arrive, leave_s=arrive + dwell,
            straight_before=leg.length if leg.is_straight else 0.0,
            straight_after=after.length if after is not None and after.is_straight else 0.0,
            direction_before=leg.direction,
            direction_after=after.direction if after is not None else leg.direction))
    knots_p: list[float] = []
    knots_d: list[float] = []
    for i, leg in enumerate(legs):
        for kp, kd in leg.steering:
            knots_p.append(float(starts[i]) + kp)
            knots_d.append(kd)
    return Profile(t_nodes=t_nodes, p_nodes=p_nodes, leg_starts=starts[:-1],
                   directions=np.array([float(leg.direction) for leg in legs]),
                   steer_p=np.array(knots_p), steer_delta=np.array(knots_d),
                   stops=tuple(station_stops))


def sample(profile: Profile, duration: float, rate_hz: float) -> Controls:
    """Drive commands on a uniform grid at ``rate_hz`` from 0 to ``duration`` s.

    Before the profile starts and after it ends the vehicle stands still with the steering at
    the route's first or last angle. The drive speed of each step is its exact travel divided
    by the step, so the integrated path follows the route's geometry.
    """
    from lgvtool.values import MAX_SIM_DURATION_S, MAX_SIM_STEPS

    steps = duration * rate_hz
    if not (math.isfinite(steps) and steps <= MAX_SIM_STEPS and duration <= MAX_SIM_DURATION_S):
        raise ConfigError(f"the run would last {duration:g} s at {rate_hz:g} Hz; at most "
                          f"{MAX_SIM_DURATION_S:g} s and {MAX_SIM_STEPS:g} integration steps fit")
    n = max(1, round(steps))
    t = np.arange(n + 1, dtype=np.float64) / rate_hz
    p = np.interp(t, profile.t_nodes, profile.p_nodes)
    step = np.diff(p)
    mid = 0.5 * (p[:-1] + p[1:])
    leg = np.clip(np.searchsorted(profile.leg_starts, mid, side="right") - 1, 0,
                  len(profile.leg_starts) - 1)
    drive = np.empty_like(t)
    drive[:-1] = profile.directions[leg] * step * rate_hz
    drive[-1] = 0.0
    steer = np.empty_like(t)
    steer[:-1] = np.interp(mid, profile.steer_p, profile.steer_delta)
    steer[-1] = np.interp(p[-1], profile.steer_p, profile.steer_delta)
    return Controls(t=t, drive_speed=drive, steering=steer)
