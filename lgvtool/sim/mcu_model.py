"""The MCU: encoders on the two auxiliary wheels, the gyro, the drive unit, its clock.

Every ``period_s`` by its own (drifting) clock, give or take a little loop jitter, the MCU
latches the cumulative counts of both encoders, takes the mean gyro rate over the frame
interval, reads the drive unit's steering angle and wheel speed, and sends a version-1 frame
(:mod:`lgvtool.devices.mcu.mcu_frame`).

- Encoders: the count follows the wheel's true rolling distance divided by its *true* radius
  (nominal x (1 + wheel_radius_error) x (1 + the load's compression, ``drive.load_fraction`` x
  ``drive.radius_change_at_rated_load``)), plus a slip random walk, quantised at
  ``encoder_ppr`` counts per revolution with a random initial phase (int32, wrapping).
- Steering angle and drive speed: what the drive unit was commanded (its sensors' readings),
  plus noise; the wheel's true angle differs (:mod:`lgvtool.sim.kinematics`).
- Gyro: mean true yaw rate x (1 + scale error) + bias (constant + random walk) + white noise,
  quantised to int16 counts of ``gyro_scale_udeg_s`` (saturation sets GYRO_SATURATED).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Vehicle
from lgvtool.devices.mcu.mcu_frame import McuFrame, McuStatus
from lgvtool.sim.kinematics import FloatArray, TrueDrive
from lgvtool.sim.settings import DriveSettings, McuSettings


@dataclass(frozen=True)
class McuOutput:
    """Every frame the MCU sends: true send time, the frame, its bytes."""

    t: FloatArray
    """Time (simulation s) at which the MCU sampled and started sending each frame."""
    frames: tuple[McuFrame, ...]
    data: tuple[bytes, ...]
    travel_left: FloatArray
    """True rolling distance of the left wheel at each frame, m."""
    travel_right: FloatArray
    """True rolling distance of the right wheel at each frame, m."""

    def __len__(self) -> int:
        return len(self.t)


def _counts(travel: FloatArray, radius: float, ppr: int, phase: float) -> NDArray[np.int64]:
    revolutions = travel / (2.0 * math.pi * radius)
    return (np.floor(phase + revolutions * ppr) - math.floor(phase)).astype(np.int64)


def load_radius_scale(drive: DriveSettings) -> float:
    """Factor on both encoder wheels' effective rolling radius from the load they carry."""
    return 1.0 + drive.load_fraction * drive.radius_change_at_rated_load


def simulate(traj: TrueDrive, vehicle: Vehicle, mcu: McuSettings, noise: bool,
             rng: np.random.Generator, drive: DriveSettings | None = None) -> McuOutput:
    """Every MCU frame over ``traj``. ``noise`` False removes slip, gyro noise and bias walk,
    steering and speed noise and loop jitter (calibration errors stay). ``drive``: the load
    on the encoder wheels (None: none)."""
    rate = 1.0 + mcu.clock_drift_ppm * 1e-6  # MCU seconds per true second
    period_true = mcu.period_s / rate
    phase = float(rng.random()) * period_true
    end = traj.end - 0.02
    n = max(0, math.floor((end - phase) / period_true) + 1)
    k = np.arange(n, dtype=np.float64)
    draws = rng.standard_normal((7, n))
    u_enc = rng.random(2)
    scale = 1.0 if noise else 0.0
    jitter = np.clip(draws[0], -3.0, 3.0) * mcu.send_jitter_s * scale
    t = phase + k * period_true + jitter
    t = np.maximum.accumulate(np.clip(t, 0.0, end))
    mcu_ms = np.floor((mcu.clock_offset_ms * 1e-3 + rate * t) * 1000.0).astype(np.int64)

    travel_l, travel_r = traj.wheel_travel_at(t)
    step_l = np.abs(np.diff(travel_l, prepend=0.0))
    step_r = np.abs(np.diff(travel_r, prepend=0.0))
    slip_l = np.cumsum(draws[1] * np.sqrt(step_l)) * mcu.slip_sigma * scale
    slip_r = np.cumsum(draws[2] * np.sqrt(step_r)) * mcu.slip_sigma * scale
    load = 1.0 if drive is None else load_radius_scale(drive)
    radius_l = vehicle.wheel_radius_left * (1.0 + mcu.wheel_radius_error_left) * load
    radius_r = vehicle.wheel_radius_right * (1.0 + mcu.wheel_radius_error_right) * load
    enc_l = _counts(travel_l + slip_l, radius_l, vehicle.encoder_ppr, float(u_enc[0]))
    enc_r = _counts(travel_r + slip_r, radius_r, vehicle.encoder_ppr, float(u_enc[1]))

    _, _, heading = traj.pose_at(t)
    _, _, heading_before = traj.pose_at(np.maximum(t - period_true, 0.0))
    interval = np.maximum(t - np.maximum(t - period_true, 0.0), 1e-9)
    mean_rate = (heading - heading_before) / interval
    dt = np.diff(t, prepend=t[0] - period_true) if n else t
    walk = np.cumsum(draws[3] * np.sqrt(np.maximum(dt, 0.0)))
    bias = math.radians(mcu.gyro_bias_dps) + math.radians(mcu.gyro_bias_walk_dps) * walk * scale
    gyro = (mean_rate * (1.0 + mcu.gyro_scale_error) + bias
            + math.radians(mcu.gyro_noise_dps) * draws[4] * scale)
    steering = traj.steering_command_at(t) + math.radians(mcu.steering_noise_deg) * draws[5] * scale
    speed = traj.drive_speed_at(t) + mcu.speed_noise * draws[6] * scale

    frames = []
    data = []
    status = int(McuStatus.DRIVE_ENABLED)
    for i in range(n):
        frame = McuFrame.from_si(
            seq=i, mcu_time_ms=int(mcu_ms[i]), enc_left=int(enc_l[i]), enc_right=int(enc_r[i]),
            gyro_rate_rad_s=float(gyro[i]), steering_rad=float(steering[i]),
            drive_speed_m_s=float(speed[i]), status=status,
            gyro_scale_udeg_s=mcu.gyro_scale_udeg_s,
        )
        frames.append(frame)
        data.append(frame.encode())
    return McuOutput(t=t, frames=tuple(frames), data=tuple(data), travel_left=travel_l,
                     travel_right=travel_r)
