"""Ground truth: the tricycle model of the forklift, integrated exactly step by step.

The vehicle frame has its origin at the target rotation centre O (middle of the encoder-wheel
axle), x forward towards the steered drive wheel, y left. With the drive wheel speed ``v_d``
(m/s) and the steering angle ``delta`` (rad) held constant over a step, O moves at
``v = v_d cos(delta)`` along its heading and turns at ``omega = v_d sin(delta) / h``, so each
step is an exact circular arc (a straight line when omega = 0). With a fixed steering angle O
therefore drives a circle of radius ``h / tan(delta)`` to machine precision.

Controls are piecewise constant on a uniform time grid (the integration rate, 200 Hz or more);
states between grid points are evaluated exactly on the arc of their step.

The true vehicle departs from the commands it is given (:class:`Departures`, from the ``drive.*``
settings, :func:`departures`): its wheel stands at the commanded angle plus an offset and a
slow wobble, it slips sideways in turns (understeer), and where a path controller is on, the
commands themselves are corrected step by step towards the planned path. Each step is still
an exact arc of the *true* wheel angle, so the encoder wheels' travel follows the true motion.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Vehicle
from lgvtool.sim.settings import DriveSettings
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]

STANDARD_GRAVITY = 9.80665
"""g, m/s^2 (the unit of the understeer gradient's lateral acceleration)."""
MAX_CORRECTION = math.radians(10.0)
"""Largest steering correction of the path controller, rad."""
MAX_SHIFT_STEPS = 200
"""How far (grid steps) the path controller's reference point may run ahead of or behind the
plan's point of the same time."""


@dataclass(frozen=True)
class Controls:
    """Drive commands on a uniform time grid; element k holds over [t[k], t[k+1]).

    ``t`` has N + 1 points (s); ``drive_speed`` (m/s, signed: negative drives backwards) and
    ``steering`` (rad, counter-clockwise positive) have N + 1 values, the last one applying to
    the final instant only.
    """

    t: FloatArray
    drive_speed: FloatArray
    steering: FloatArray

    @property
    def dt(self) -> float:
        """Step of the grid, s."""
        return float(self.t[1] - self.t[0])


def _arc(v: FloatArray, omega: FloatArray, heading: FloatArray,
         tau: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Displacement (dx, dy, dtheta) after ``tau`` s on the arc of speed ``v`` (m/s) and yaw
    rate ``omega`` (rad/s) starting at ``heading`` (rad): chord length times direction."""
    dth = omega * tau
    chord = v * tau * np.sinc(dth / (2.0 * np.pi))  # np.sinc(x) = sin(pi x)/(pi x)
    mid = heading + 0.5 * dth
    return chord * np.cos(mid), chord * np.sin(mid), dth


@dataclass(frozen=True)
class TrueDrive:
    """The true motion of the vehicle on the integration grid: the path of O and what the
    drive, the steering and the two encoder wheels did.

    ``path`` holds the N + 1 grid poses of O (:class:`lgvtool.trajectory.Trajectory`: ``t``
    in s of the run, counted from ``path.t0_ns``, ns since the Unix epoch; x, y in m; heading
    in rad, continuous, not wrapped into (-pi, pi]). The other arrays have N + 1 points too.
    ``v`` (m/s), ``omega`` (rad/s), ``v_left``, ``v_right`` (m/s) are the step values
    (constant over [t[k], t[k+1])). ``s_left``/``s_right`` are the cumulative signed travel
    of the left/right encoder wheel contact points, m.
    """

    path: Trajectory
    v: FloatArray
    omega: FloatArray
    drive_speed: FloatArray
    steering: FloatArray
    """The true, effective steering angle: the direction in which the drive wheel's contact
    point moves relative to the vehicle (the wheel's angle less its slip angle), rad."""
    s_left: FloatArray
    s_right: FloatArray
    v_left: FloatArray
    v_right: FloatArray
    steering_command: FloatArray
    """The steering angle the drive unit is commanded, and its sensor reports, rad (the plan's,
    plus the path controller's corrections)."""

    @property
    def duration(self) -> float:
        """Length of the drive, s."""
        return self.path.duration

    @property
    def end(self) -> float:
        """Time of the last grid point, s of the run."""
        return float(self.path.t[-1])

    def _step(self, times: FloatArray) -> tuple[NDArray[np.intp], FloatArray]:
        t = self.path.t
        times = np.asarray(times, dtype=np.float64)
        k = np.searchsorted(t, times, side="right") - 1
        k = np.clip(k, 0, len(t) - 1)
        return k, times - t[k]

    def pose_at(self, times: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Exact pose (x m, y m, unwrapped heading rad) of O at arbitrary ``times`` (s)."""
        k, tau = self._step(times)
        p = self.path
        dx, dy, dth = _arc(self.v[k], self.omega[k], p.heading[k], tau)
        return p.x[k] + dx, p.y[k] + dy, p.heading[k] + dth

    def sampled(self, times: FloatArray) -> Trajectory:
        """The exact poses of O at ``times`` (s of the run, not decreasing; heading
        continuous), on the arcs of their steps: the simulator's ground truth."""
        t = np.asarray(times, dtype=np.float64)
        x, y, heading = self.pose_at(t)
        return Trajectory(t, x, y, heading, self.path.t0_ns)

    def point_at(self, times: FloatArray, px: float, py: float
                 ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Pose of the vehicle-frame point (px, py) m at ``times``: (x, y, heading)."""
        x, y, th = self.pose_at(times)
        c, s = np.cos(th), np.sin(th)
        return x + px * c - py * s, y + px * s + py * c, th

    def wheel_travel_at(self, times: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Cumulative signed travel (m) of the left and right encoder wheels at ``times``."""
        k, tau = self._step(times)
        return self.s_left[k] + self.v_left[k] * tau, self.s_right[k] + self.v_right[k] * tau

    def steering_at(self, times: FloatArray) -> FloatArray:
        """True effective steering angle (rad) in force at ``times``."""
        k, _ = self._step(times)
        return self.steering[k]

    def steering_command_at(self, times: FloatArray) -> FloatArray:
        """Commanded (and reported) steering angle (rad) in force at ``times``."""
        k, _ = self._step(times)
        return self.steering_command[k]

    def drive_speed_at(self, times: FloatArray) -> FloatArray:
        """Drive wheel speed (m/s) in force at ``times``."""
        k, _ = self._step(times)
        return self.drive_speed[k]


@dataclass(frozen=True)
class Departures:
    """How the true drive departs from its commands, resolved on the integration grid."""

    steering_error: FloatArray | None = None
    """True wheel angle minus the commanded one at each grid point (offset + wobble), rad;
    None: none."""
    understeer: float = 0.0
    """Slip angle of the drive wheel per lateral acceleration, rad per m/s^2: the wheel's
    contact point moves at its angle less this times the lateral acceleration (plus, in
    reverse, where the drive wheel trails)."""
    path_control: float = 0.0
    """Distance of travel over which the path controller brings the vehicle back to the planned
    path, m (critically damped); 0: no controller, the commands are the plan's."""

    @property
    def kinematic(self) -> bool:
        """True when the vehicle drives exactly what it is commanded."""
        return self.understeer == 0.0 and (self.steering_error is None
                                           or not np.any(self.steering_error))


def wobble(n: int, dt: float, sigma: float, tau: float,
           rng: np.random.Generator) -> FloatArray:
    """``n`` samples, ``dt`` s apart, of a stationary Ornstein-Uhlenbeck process of standard
    deviation ``sigma`` and correlation time ``tau`` s (exact discretisation). Always draws
    ``n`` normals, whatever ``sigma``."""
    xi = rng.standard_normal(n)
    a = math.exp(-dt / tau)
    b = math.sqrt(1.0 - a * a)
    out = np.empty(n)
    x = 0.0
    for k, e in enumerate(xi.tolist()):
        x = e if k == 0 else a * x + b * e
        out[k] = x
    return sigma * out


def departures(drive: DriveSettings, t: FloatArray, rng: np.random.Generator) -> Departures:
    """The departures of the ``drive.*`` settings on the grid ``t`` (s, uniform), the wobble
    drawn from ``rng``."""
    n = len(t)
    dt = float(t[1] - t[0]) if n > 1 else 1.0
    error = wobble(n, dt, math.radians(drive.wobble_deg), drive.wobble_time_s, rng)
    error += math.radians(drive.steering_offset_deg)
    return Departures(steering_error=error,
                      understeer=math.radians(drive.understeer_deg_per_g) / STANDARD_GRAVITY,
                      path_control=drive.path_control_m)


def true_steering(drive_speed: FloatArray, wheel: FloatArray, h: float,
                  understeer: float) -> FloatArray:
    """Effective steering angle (rad) of a wheel at angle ``wheel`` (rad) driven at
    ``drive_speed`` (m/s): less its slip angle ``understeer`` x the lateral acceleration
    v_d^2 sin cos / h (understeer gradient; the sign of the speed flips it in reverse)."""
    if understeer == 0.0:
        return wheel
    lateral = drive_speed * drive_speed * np.sin(wheel) * np.cos(wheel) / h
    return wheel - np.sign(drive_speed) * understeer * lateral


def integrate(controls: Controls, vehicle: Vehicle, x0: float, y0: float,
              heading0: float, departure: Departures | None = None, t0_ns: int = 0
              ) -> TrueDrive:
    """Integrate the tricycle model over ``controls`` from the pose (x0, y0 m, heading0 rad),
    the true wheel angle departing from the commands by ``departure`` (None: none); the
    controls' time 0 is ``t0_ns`` (ns since the Unix epoch: the run's start).

    Vectorised: every step is an exact arc, accumulated with cumulative sums. With a path
    controller the commands are first corrected step by step (:func:`_path_controlled`).
    """
    t = np.asarray(controls.t, dtype=np.float64)
    vd = np.asarray(controls.drive_speed, dtype=np.float64)
    command = np.asarray(controls.steering, dtype=np.float64)
    if departure is None or departure.kinematic:
        return _integrate(t, vd, command, command, vehicle, x0, y0, heading0, t0_ns)
    error = (np.zeros_like(t) if departure.steering_error is None
             else np.asarray(departure.steering_error, dtype=np.float64))
    if departure.path_control > 0.0:
        plan = _integrate(t, vd, command, command, vehicle, x0, y0, heading0, t0_ns)
        command = _path_controlled(plan, error, departure, vehicle.h)
    delta = true_steering(vd, command + error, vehicle.h, departure.understeer)
    return _integrate(t, vd, delta, command, vehicle, x0, y0, heading0, t0_ns)


def _path_controlled(plan: TrueDrive, error: FloatArray, dep: Departures,
                     h: float) -> FloatArray:
    """The commanded steering of a vehicle whose path controller steers it back to ``plan``.

    Every grid step the controller finds the plan's point abreast of the true O (the plan's
    pose of a nearby time, moved along the path until the along-track error vanishes), takes
    the cross-track error e_y and the heading error e_th there and adds to the plan's steering
    ``-h cos^2(delta) (2/L sign(v) e_th + e_y / L^2)`` (a critically damped response over a
    distance L of travel, whatever the speed), held while the vehicle stands. The true motion
    of each step is an exact arc of the resulting wheel angle plus ``error`` less its slip.
    """
    path = plan.path
    t = path.t
    n = len(t) - 1
    dt = float(t[1] - t[0]) if n > 0 else 1.0
    length = dep.path_control
    k_heading, k_lateral = 2.0 / length, 1.0 / (length * length)
    xs, ys, ths = path.x.tolist(), path.y.tolist(), path.heading.tolist()
    cs, sn = np.cos(path.heading).tolist(), np.sin(path.heading).tolist()
    step = (plan.v * dt).tolist()
    vd = plan.drive_speed.tolist()
    planned = plan.steering.tolist()
    cosp = np.cos(plan.steering).tolist()
    err = error.tolist()
    slip = dep.understeer
    out = np.empty(n + 1)
    x, y, th = xs[0], ys[0], ths[0]
    corr = 0.0
    shift = 0.0
    lo, hi = 0, n - 1
    for k in range(n):
        v_d = vd[k]
        if v_d != 0.0:
            # the plan's point abreast of O: one Newton step along the path per grid step
            f = min(max(k + shift, k - MAX_SHIFT_STEPS, lo), k + MAX_SHIFT_STEPS, hi + 0.999999)
            i = int(f)
            u = f - i
            gx, gy, gth = xs[i + 1] - xs[i], ys[i + 1] - ys[i], ths[i + 1] - ths[i]
            pth = ths[i] + u * gth
            c = cs[i] + u * (cs[i + 1] - cs[i])  # cos and sin of pth to ~1e-7
            s = sn[i] + u * (sn[i + 1] - sn[i])
            dx, dy = x - xs[i] - u * gx, y - ys[i] - u * gy
            st = step[i]
            if st > 1e-9 or st < -1e-9:
                df = (c * dx + s * dy) / st
                shift = f + df - k
                pth += df * gth
            e_y = c * dy - s * dx
            e_th = th - pth
            cos_d = cosp[k]
            if v_d > 0:
                corr = -h * cos_d * cos_d * (k_heading * e_th + k_lateral * e_y)
            else:
                corr = -h * cos_d * cos_d * (k_lateral * e_y - k_heading * e_th)
            corr = min(max(corr, -MAX_CORRECTION), MAX_CORRECTION)
        command = planned[k] + corr
        out[k] = command
        if v_d == 0.0:
            continue
        wheel = command + err[k]
        if slip:
            sw = math.sin(wheel)
            wheel -= (slip if v_d > 0 else -slip) * v_d * v_d * sw * math.cos(wheel) / h
        half = 0.5 * v_d * math.sin(wheel) / h * dt
        chord = v_d * math.cos(wheel) * dt * (1.0 - half * half / 6.0)  # sin(a)/a, |a| < 0.01
        mid = th + half
        x += chord * math.cos(mid)
        y += chord * math.sin(mid)
        th += half + half
    out[n] = planned[n] + corr
    return out


def _integrate(t: FloatArray, vd: FloatArray, delta: FloatArray, command: FloatArray,
               vehicle: Vehicle, x0: float, y0: float, heading0: float, t0_ns: int
               ) -> TrueDrive:
    """The exact arcs of the true steering ``delta`` (``command``: what the drive unit was
    told, kept for the MCU)."""
    dt = np.diff(t)
    v = vd * np.cos(delta)
    omega = vd * np.sin(delta) / vehicle.h
    heading = np.empty_like(t)
    heading[0] = heading0
    np.cumsum(omega[:-1] * dt, out=heading[1:])
    heading[1:] += heading0
    dx, dy, _ = _arc(v[:-1], omega[:-1], heading[:-1], dt)
    x = np.empty_like(t)
    y = np.empty_like(t)
    x[0], y[0] = x0, y0
    np.cumsum(dx, out=x[1:])
    np.cumsum(dy, out=y[1:])
    x[1:] += x0
    y[1:] += y0
    half = 0.5 * vehicle.track
    v_left = v - omega * half
    v_right = v + omega * half
    s_left = np.zeros_like(t)
    s_right = np.zeros_like(t)
    np.cumsum(v_left[:-1] * dt, out=s_left[1:])
    np.cumsum(v_right[:-1] * dt, out=s_right[1:])
    return TrueDrive(path=Trajectory(t, x, y, heading, t0_ns), v=v, omega=omega,
                     drive_speed=vd, steering=delta, s_left=s_left, s_right=s_right,
                     v_left=v_left, v_right=v_right, steering_command=command)
