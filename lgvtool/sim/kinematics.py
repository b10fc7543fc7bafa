"""Ground truth: the tricycle model of the forklift, integrated exactly step by step.

The vehicle frame has its origin at the target rotation centre O (middle of the encoder-wheel
axle), x forward towards the steered drive wheel, y left. With the drive wheel speed ``v_d``
(m/s) and the steering angle ``delta`` (rad) held constant over a step, O moves at
``v = v_d cos(delta)`` along its heading and turns at ``omega = v_d sin(delta) / h``, so each
step is an exact circular arc (a straight line when omega = 0). With a fixed steering angle O
therefore drives a circle of radius ``h / tan(delta)`` to machine precision.

Controls are piecewise constant on a uniform time grid (the integration rate, 200 Hz or more);
states between grid points are evaluated exactly on the arc of their step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Vehicle

FloatArray = NDArray[np.float64]


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
class Trajectory:
    """The true motion of O and of the two encoder wheels on the integration grid.

    Arrays have N + 1 points. ``v``, ``omega``, ``v_left``, ``v_right`` are the step values
    (constant over [t[k], t[k+1])). ``s_left``/``s_right`` are the cumulative signed travel of
    the left/right encoder wheel contact points, m.
    """

    t: FloatArray
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    """Unwrapped heading, rad (continuous, not wrapped into (-pi, pi])."""
    v: FloatArray
    omega: FloatArray
    drive_speed: FloatArray
    steering: FloatArray
    s_left: FloatArray
    s_right: FloatArray
    v_left: FloatArray
    v_right: FloatArray

    @property
    def duration(self) -> float:
        """Length of the trajectory, s."""
        return float(self.t[-1] - self.t[0])

    def _step(self, times: FloatArray) -> tuple[NDArray[np.intp], FloatArray]:
        times = np.asarray(times, dtype=np.float64)
        k = np.searchsorted(self.t, times, side="right") - 1
        k = np.clip(k, 0, len(self.t) - 1)
        return k, times - self.t[k]

    def pose_at(self, times: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Exact pose (x m, y m, unwrapped heading rad) of O at arbitrary ``times`` (s)."""
        k, tau = self._step(times)
        dx, dy, dth = _arc(self.v[k], self.omega[k], self.heading[k], tau)
        return self.x[k] + dx, self.y[k] + dy, self.heading[k] + dth

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
        """Steering angle (rad) in force at ``times``."""
        k, _ = self._step(times)
        return self.steering[k]

    def drive_speed_at(self, times: FloatArray) -> FloatArray:
        """Drive wheel speed (m/s) in force at ``times``."""
        k, _ = self._step(times)
        return self.drive_speed[k]


def integrate(controls: Controls, vehicle: Vehicle, x0: float, y0: float,
              heading0: float) -> Trajectory:
    """Integrate the tricycle model over ``controls`` from the pose (x0, y0 m, heading0 rad).

    Vectorised: every step is an exact arc, accumulated with cumulative sums.
    """
    t = np.asarray(controls.t, dtype=np.float64)
    vd = np.asarray(controls.drive_speed, dtype=np.float64)
    delta = np.asarray(controls.steering, dtype=np.float64)
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
    return Trajectory(t=t, x=x, y=y, heading=heading, v=v, omega=omega, drive_speed=vd,
                      steering=delta, s_left=s_left, s_right=s_right, v_left=v_left,
                      v_right=v_right)
