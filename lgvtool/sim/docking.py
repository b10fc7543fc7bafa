"""The docking controller: where the vehicle really comes to rest at a station.

A route's stops at stations (:class:`lgvtool.sim.routes.StationStop`) are planned at the
station's nominal pose. A real vehicle's docking controller stops it there only to within its
repeatability: each visit ends a little long or short, to one side and turned, by an error of
its own (its docking sensor's and brakes' error, drawn per visit:
``drive.dock_sigma_along_m``, ``drive.dock_sigma_across_m``, ``drive.dock_sigma_heading_deg``).

The error is not a jump: the controller steers and brakes the vehicle into the offset pose over
the final ``drive.dock_approach_m`` of travel (at most the straight travel before the stop),
and back onto the route over as much travel after it drives off. :func:`dock` writes that
manoeuvre into the drive commands, so that the kinematics integrate it (and the path controller
follows it) like any other part of the route: the encoder wheels, the gyro and the NAV see the
motion the vehicle really makes.

The manoeuvre, in the vehicle's frame at the nominal stop (x forward, along the straight
approach, y to the left), as functions of u, the fraction of the window's nominal drive-wheel travel p
covered (0 to 1), with the smooth step A(u) = 3u^2 - 2u^3 and the bump B(u) = u^2 (1 - u)^2
(both flat at 0 and 1, so the steering starts and ends at the route's):

- along: x = x_route(p) + a(u), a = e_along A(u) on the approach, e_along (1 - A(u)) after;
- heading: phi = e_heading A(u) + kappa B(u) (approach), e_heading (1 - A(u)) + kappa B(u)
  (after), kappa solved (Newton) so that y = integral of tan(phi) dx ends at e_across (at 0);
- the drive wheel travels q with dq/dp = sqrt(((1 + d a') / cos phi)^2 + (h phi')^2) (d the
  leg's direction, +1 forward, -1 reverse; ' = d/dp), which makes dx/dp = d + a' and
  dphi/dq = d sin(delta) / h with sin(delta) = d h phi' / (dq/dp): the tricycle's own motion.

The steering angle of each command step is the route's plus delta at the step's middle, its
drive speed the warped travel of the step over its duration; the stop itself keeps its times.
Every quantity is in SI units: m, s, rad.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lgvtool.errors import ConfigError
from lgvtool.sim.kinematics import Controls, FloatArray
from lgvtool.sim.routes import StationStop
from lgvtool.sim.settings import DriveSettings

GRID = 4001
"""Points of the quadrature grid of one window (Simpson's rule; an odd count)."""
MAX_DOCK_STEERING = math.radians(45.0)
"""Largest steering angle the docking manoeuvre may add, rad: beyond it the station's straight
is too short for the error drawn (``drive.dock_approach_m`` or the route's legs)."""


@dataclass(frozen=True)
class DockError:
    """The docking controller's error on one visit: where O comes to rest minus the station's
    nominal stop, in the vehicle's frame at the nominal stop (x forward, y to the left)."""

    along: float
    """Forward (along the approach of a forward stop), m."""
    across: float
    """To the left, m."""
    heading: float
    """Heading minus the nominal heading, counter-clockwise, rad."""


@dataclass(frozen=True)
class StationVisit:
    """One stop of the run at a station, and the docking controller's error there."""

    station: str
    """The station's name."""
    arrive_s: float
    """Time at which the vehicle comes to rest, s of the run."""
    leave_s: float
    """Time at which it drives off, s of the run."""
    error: DockError
    """Where the controller stopped it, relative to the nominal stop."""


def draw_errors(drive: DriveSettings, count: int, rng: np.random.Generator
                ) -> tuple[DockError, ...]:
    """The errors of ``count`` visits: independent normals of the ``drive.dock_sigma_*``
    standard deviations (m, m, deg -> rad). Always draws 3 x ``count`` normals, whatever the
    settings (0: an exact stop), so that switching docking off changes no other draw."""
    z = rng.standard_normal((count, 3))
    scale = np.array([drive.dock_sigma_along_m, drive.dock_sigma_across_m,
                      math.radians(drive.dock_sigma_heading_deg)])
    e = z * scale
    return tuple(DockError(float(a), float(c), float(h)) for a, c, h in e.tolist())


def _smoothstep(u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """A(u) = 3u^2 - 2u^3 and dA/du."""
    return u * u * (3.0 - 2.0 * u), 6.0 * u * (1.0 - u)


def _bump(u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """B(u) = u^2 (1 - u)^2 and dB/du."""
    w = u * (1.0 - u)
    return w * w, 2.0 * w * (1.0 - 2.0 * u)


@dataclass(frozen=True)
class _Window:
    """One stretch of travel over which the vehicle moves into (or out of) its docking offset.

    ``start`` (m of nominal travel) and ``length`` (m) bound it; ``direction`` is its leg's
    (+1, -1); ``entering``: the offset builds up (the approach), else it dies away.
    """

    start: float
    length: float
    direction: int
    entering: bool
    error: DockError
    kappa: float
    """The bump's weight in the heading, rad (solved so that the lateral offset comes out)."""

    def shape(self, u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """At fractions ``u`` of the window: a (m) and da/dp, phi (rad) and dphi/dp (1/m)."""
        e = self.error
        s, ds = _smoothstep(u)
        b, db = _bump(u)
        if self.entering:
            a, da, phi, dphi = e.along * s, e.along * ds, e.heading * s, e.heading * ds
        else:
            a, da, phi, dphi = e.along * (1 - s), -e.along * ds, e.heading * (1 - s), -e.heading * ds
        phi = phi + self.kappa * b
        dphi = dphi + self.kappa * db
        return a, da / self.length, phi, dphi / self.length

    def rate(self, u: FloatArray, h: float) -> tuple[FloatArray, FloatArray]:
        """dq/dp (drive wheel travel per nominal travel) and the added steering angle (rad) at
        fractions ``u``, for the wheelbase ``h`` (m)."""
        _, da, phi, dphi = self.shape(u)
        along = (1.0 + self.direction * da) / np.cos(phi)
        r = np.sqrt(along * along + (h * dphi) ** 2)
        sin_delta = self.direction * h * dphi / r
        if np.any(along <= 0.0) or np.any(np.abs(sin_delta) > math.sin(MAX_DOCK_STEERING)):
            raise ConfigError(
                f"a docking error of {self.error.along * 1e3:.0f} mm along, "
                f"{self.error.across * 1e3:.0f} mm across and "
                f"{math.degrees(self.error.heading):.2f} deg does not fit in {self.length:g} m "
                "of straight travel; lower drive.dock_sigma_* or give the stations longer "
                "straights (drive.dock_approach_m, the scenario's lengths)")
        return r, np.arcsin(sin_delta)

    def lateral(self, u: FloatArray) -> float:
        """The change of y over the whole window, m (Simpson's rule on ``u``, uniform, odd)."""
        _, da, phi, _ = self.shape(u)
        f = np.tan(phi) * (self.direction + da)
        return _simpson(f, self.length / (len(u) - 1))


def _simpson(f: FloatArray, step: float) -> float:
    """Simpson's rule over uniformly spaced samples (an odd count)."""
    return float(step / 3.0 * (f[0] + f[-1] + 4.0 * f[1:-1:2].sum() + 2.0 * f[2:-1:2].sum()))


def _solved(window: _Window, target: float) -> _Window:
    """``window`` with its ``kappa`` such that its lateral change is ``target`` m (Newton on
    the bump's weight; the change is nearly linear in it)."""
    u = np.linspace(0.0, 1.0, GRID)
    b, _ = _bump(u)
    w = window
    for _ in range(20):
        _, da, phi, _ = w.shape(u)
        got = w.lateral(u)
        slope = _simpson(b * (w.direction + da) / np.cos(phi) ** 2, w.length / (GRID - 1))
        step = (target - got) / slope
        w = _Window(w.start, w.length, w.direction, w.entering, w.error, w.kappa + step)
        if abs(step * slope) < 1e-13:
            break
    return w


def _windows(stops: Sequence[StationStop], errors: Sequence[DockError],
            approach: float) -> list[_Window]:
    """The windows of every stop (its approach and its departure), in travel order, the
    approach at most ``approach`` m (``drive.dock_approach_m``) and the straight travel there.

    :raises ConfigError: a stop with no straight travel before it, or windows that overlap.
    """
    out: list[_Window] = []
    for stop, e in zip(stops, errors, strict=True):
        before = min(approach, stop.straight_before)
        if before <= 0.0:
            raise ConfigError(f"the stop at station {stop.station!r} has no straight approach "
                              "for the docking controller")
        w_in = _Window(stop.travel - before, before, stop.direction_before, True, e, 0.0)
        out.append(_solved(w_in, e.across))
        after = min(approach, stop.straight_after)
        if after > 0.0:
            w_out = _Window(stop.travel, after, stop.direction_after, False, e, 0.0)
            out.append(_solved(w_out, -e.across))
    for a, b in itertools.pairwise(out):
        if b.start < a.start + a.length - 1e-9:
            raise ConfigError("two stations' docking approaches overlap; lower "
                              "drive.dock_approach_m")
    return out


def dock(controls: Controls, stops: Sequence[StationStop], errors: Sequence[DockError],
         approach: float, h: float) -> Controls:
    """The drive commands ``controls`` with the docking manoeuvre of every stop (see the
    module's docstring): the vehicle comes to rest at each ``stops[i]`` offset by
    ``errors[i]`` and returns to the route after it; ``approach``: the longest window, m;
    ``h``: the wheelbase O to drive wheel, m. Stops without an error (all zero) leave the
    commands as they are.

    The travel at each grid point is the cumulative drive wheel travel of the commands (m);
    every window lies on a straight of the route (steering 0). Outside the windows the
    commands stay as they are.
    """
    live = [(s, e) for s, e in zip(stops, errors, strict=True)
            if (e.along, e.across, e.heading) != (0.0, 0.0, 0.0)]
    if not live:
        return controls
    t = controls.t
    dt = np.diff(t)
    speed = np.asarray(controls.drive_speed, dtype=np.float64)
    p = np.concatenate([[0.0], np.cumsum(np.abs(speed[:-1]) * dt)])
    mid = 0.5 * (p[:-1] + p[1:])
    gained = np.zeros_like(p)  # drive wheel travel gained (or lost) by the warp so far, m
    passed = np.zeros_like(p)  # travel gained by the windows wholly behind each point, m
    steering = np.asarray(controls.steering, dtype=np.float64).copy()
    u_grid = np.linspace(0.0, 1.0, GRID)
    for w in _windows([s for s, _ in live], [e for _, e in live], approach):
        r, _ = w.rate(u_grid, h)
        # drive wheel travel gained over the window so far: the integral of (dq/dp - 1) dp
        gain = np.concatenate([[0.0], np.cumsum(0.5 * (r[1:] + r[:-1]) - 1.0)]) * (
            w.length / (GRID - 1))
        i0, i1 = np.searchsorted(p, [w.start, w.start + w.length], side="right")
        gained[i0:i1] += np.interp((p[i0:i1] - w.start) / w.length, u_grid, gain)
        if i1 < len(p):
            passed[i1] += gain[-1]
        k0, k1 = np.searchsorted(mid, [w.start, w.start + w.length], side="right")
        _, delta = w.rate((mid[k0:k1] - w.start) / w.length, h)
        steering[k0:k1] += delta
    gained += np.cumsum(passed)
    drive = speed.copy()  # outside the windows the commands stay as they are, bit for bit
    drive[:-1] += np.sign(speed[:-1]) * np.diff(gained) / dt
    return Controls(t=t, drive_speed=drive, steering=steering)
