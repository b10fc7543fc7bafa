"""Motion input: MCU frames or generic odometry turned into an integrated odometry track.

The track is the vehicle's pose in an arbitrary odometry frame (it starts at the origin) at
every motion sample. Estimators never integrate messages one by one: the driver asks the track
for the body-frame motion between two observation times (:meth:`MotionTrack.deltas`), which is
the exact composition of every step in between, so accumulating odometry between observations
loses nothing for the deterministic part of the motion.

MCU frames (``lgvtool.McuFrame``) carry cumulative int32 encoder counts that wrap, a u16 sequence
number that wraps, the MCU millisecond clock (u32, wraps) and the gyro yaw rate in rad/s. Frames
lost in transit are bridged by the cumulative counts: the distance of the missing frames is in
the next count difference. Wheel travel per count is ``2 pi r / ppr``
(:meth:`lgvtool.config.Vehicle.metres_per_count`); ``v = (v_r + v_l) / 2`` and
``omega = (v_r - v_l) / l`` (domain.md eqs. 2 and 3, corrected).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Vehicle

FUSIONS = ("gyro", "encoders", "blend")
STEP_FORMS = ("arc", "paper")

_U32 = 1 << 32
_I32 = 1 << 31


@dataclass(frozen=True)
class MotionSettings:
    """How motion samples become increments.

    ``fusion``: ``gyro`` (encoder distance, gyro heading: the paper's sensors and the default),
    ``encoders`` (distance and heading from the two encoder wheels) or ``blend`` (heading change
    ``w * gyro + (1 - w) * encoders`` with ``w = gyro_weight``). Over a gap longer than
    ``max_gyro_gap_s`` (s) the gyro rate is unknown, so the heading change of that interval comes
    from the encoders whatever the fusion. ``step_form``: ``arc`` integrates each step as an arc
    of constant curvature (exact for the tricycle at fixed steering); ``paper`` is eq. 9 as
    printed, ``x += ds cos(theta + dtheta)``.
    """

    fusion: str = "gyro"
    gyro_weight: float = 0.98
    max_gyro_gap_s: float = 0.5
    step_form: str = "arc"


class Increments:
    """Motion between consecutive samples: ``t`` has one more entry than ``ds`` and ``dth``.

    ``t``: sample times, s; ``ds``: distance travelled by O, m; ``dth``: heading change, rad.
    ``missing_frames``: frames lost according to the sequence numbers (MCU input only).
    """

    __slots__ = ("ds", "dth", "missing_frames", "t")

    def __init__(self, t: NDArray[np.float64], ds: NDArray[np.float64],
                 dth: NDArray[np.float64], missing_frames: int = 0) -> None:
        self.t = t
        self.ds = ds
        self.dth = dth
        self.missing_frames = missing_frames


def unwrap_counter(values: NDArray[np.int64], modulus: int, signed: bool) -> NDArray[np.int64]:
    """Differences of a wrapping counter (``modulus`` = 2^bits), one fewer than values.

    Signed counters give differences in ``[-modulus/2, modulus/2)``; unsigned ones in
    ``[0, modulus)``.
    """
    d = np.diff(values.astype(np.int64))
    if signed:
        half = modulus // 2
        return np.asarray(np.mod(d + half, modulus) - half, dtype=np.int64)
    return np.asarray(np.mod(d, modulus), dtype=np.int64)


def clock_rate(dt_mcu: NDArray[np.float64], dt_host: NDArray[np.float64]) -> float:
    """MCU clock seconds per host clock second: the median ratio of the clock steps between
    frames, 1 when there are none to compare.

    On a vehicle it is 1 (to the clocks' drift); a run an emulator plays N times faster than real
    time (``lgvtool simulate serve --speed N``) is received N times faster than the MCU's clock
    runs, and its gyro rates (rad/s of the vehicle's time) must be integrated over MCU time.
    """
    ok = (dt_mcu > 0) & (dt_host > 1e-3)
    if not ok.any():
        return 1.0
    return float(np.median(dt_mcu[ok] / dt_host[ok]))


def increments_from_mcu(t: NDArray[np.float64], seq: NDArray[np.int64],
                        mcu_time_ms: NDArray[np.int64], enc_left: NDArray[np.int64],
                        enc_right: NDArray[np.int64], gyro_rate: NDArray[np.float64],
                        vehicle: Vehicle, settings: MotionSettings) -> Increments:
    """Increments from MCU frames in log-time order.

    ``t``: host receive time of each frame, s. Duplicated frames (same sequence number and
    counts) are dropped. The time step of the gyro integral is taken from the MCU clock when it
    agrees with the host clock (it has no host scheduling jitter), else from the host clock,
    both in MCU seconds (see :func:`clock_rate`). The gyro is integrated with the trapezoid rule
    between samples.
    """
    if settings.fusion not in FUSIONS:
        raise ValueError(f"unknown fusion {settings.fusion!r} (known: {', '.join(FUSIONS)})")
    n = len(t)
    if n == 0:
        return Increments(np.zeros(0), np.zeros(0), np.zeros(0))
    seq = np.asarray(seq, dtype=np.int64)
    enc_left = np.asarray(enc_left, dtype=np.int64)
    enc_right = np.asarray(enc_right, dtype=np.int64)
    if n > 1:
        dup = np.concatenate([[False], (np.diff(seq) == 0) & (np.diff(enc_left) == 0)
                              & (np.diff(enc_right) == 0)])
        if dup.any():
            keep = ~dup
            t, seq, enc_left, enc_right = t[keep], seq[keep], enc_left[keep], enc_right[keep]
            mcu_time_ms, gyro_rate = np.asarray(mcu_time_ms)[keep], np.asarray(gyro_rate)[keep]
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2:
        return Increments(t, np.zeros(0), np.zeros(0))
    k_left, k_right = vehicle.metres_per_count()
    dl = unwrap_counter(enc_left, _U32, signed=True) * k_left
    dr = unwrap_counter(enc_right, _U32, signed=True) * k_right
    ds = 0.5 * (dl + dr)
    dth_enc = (dr - dl) / vehicle.track
    dseq = unwrap_counter(seq, 1 << 16, signed=False)
    missing = int(np.maximum(dseq - 1, 0).sum())
    dt_host = np.diff(t)
    dt_mcu = np.asarray(unwrap_counter(np.asarray(mcu_time_ms, dtype=np.int64), _U32,
                                       signed=False) * 1e-3, dtype=np.float64)
    rate = clock_rate(dt_mcu, dt_host)
    agree = (dt_mcu > 0) & (np.abs(dt_mcu - rate * dt_host)
                            <= rate * (0.5 * np.abs(dt_host) + 0.05))
    dt = np.where(agree, dt_mcu, rate * dt_host)
    g = np.asarray(gyro_rate, dtype=np.float64)
    dth_gyro = 0.5 * (g[:-1] + g[1:]) * dt
    if settings.fusion == "encoders":
        dth = dth_enc
    else:
        dth = dth_gyro if settings.fusion == "gyro" else (
            settings.gyro_weight * dth_gyro + (1.0 - settings.gyro_weight) * dth_enc)
        gap = dt > settings.max_gyro_gap_s
        if gap.any():
            dth = np.where(gap, dth_enc, dth)
    return Increments(t, ds, dth, missing)


def increments_from_twist(t: NDArray[np.float64], v: NDArray[np.float64],
                          omega: NDArray[np.float64]) -> Increments:
    """Increments from generic odometry: each ``(v, omega)`` (m/s, rad/s) holds from its own time
    until the next message (zero-order hold)."""
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2:
        return Increments(t, np.zeros(0), np.zeros(0))
    dt = np.diff(t)
    return Increments(t, np.asarray(v, dtype=np.float64)[:-1] * dt,
                      np.asarray(omega, dtype=np.float64)[:-1] * dt)


def step_offsets(ds: NDArray[np.float64], dth: NDArray[np.float64], step_form: str
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Body-frame displacement ``(dx, dy)`` of one step of distance ``ds`` (m) and heading change
    ``dth`` (rad), in the frame of the pose before the step."""
    if step_form == "arc":
        half = 0.5 * dth
        chord = ds * np.sinc(half / math.pi)
        return chord * np.cos(half), chord * np.sin(half)
    if step_form == "paper":
        return ds * np.cos(dth), ds * np.sin(dth)
    raise ValueError(f"unknown step form {step_form!r} (known: {', '.join(STEP_FORMS)})")


class Deltas:
    """Body-frame motions between pairs of times, one entry per pair.

    ``dx, dy`` (m) and ``dth`` (rad) are in the frame of the earlier pose; ``dist`` (m) and
    ``rot`` (rad) are the path length and the total absolute rotation, which scale motion noise.
    """

    __slots__ = ("dist", "dth", "dx", "dy", "rot")

    def __init__(self, dx: NDArray[np.float64], dy: NDArray[np.float64],
                 dth: NDArray[np.float64], dist: NDArray[np.float64],
                 rot: NDArray[np.float64]) -> None:
        self.dx = dx
        self.dy = dy
        self.dth = dth
        self.dist = dist
        self.rot = rot


class MotionTrack:
    """The odometry integrated into poses at every sample time (odometry frame, m and rad).

    Between samples the motion is taken as one arc at constant speed, so poses can be asked for
    at any time; before the first sample and after the last one the vehicle stands still.
    """

    def __init__(self, inc: Increments, step_form: str = "arc") -> None:
        self.t = inc.t
        n = len(inc.ds)
        self.ds, self.dth = inc.ds, inc.dth
        self.step_form = step_form
        self.missing_frames = inc.missing_frames
        th = np.zeros(n + 1)
        np.cumsum(inc.dth, out=th[1:])
        bx, by = step_offsets(inc.ds, inc.dth, step_form)
        c, s = np.cos(th[:-1]), np.sin(th[:-1])
        x = np.zeros(n + 1)
        y = np.zeros(n + 1)
        np.cumsum(c * bx - s * by, out=x[1:])
        np.cumsum(s * bx + c * by, out=y[1:])
        self.x, self.y, self.th = x, y, th
        self.cum_dist = np.concatenate([[0.0], np.cumsum(np.abs(inc.ds))])
        self.cum_rot = np.concatenate([[0.0], np.cumsum(np.abs(inc.dth))])

    def __len__(self) -> int:
        return len(self.t)

    @property
    def start(self) -> float:
        """Time of the first motion sample, s."""
        return float(self.t[0]) if len(self.t) else 0.0

    def poses_at(self, tq: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        """Odometry-frame ``(x, y, th, cum_dist, cum_rot)`` at the times ``tq`` (s); ``th`` is
        unwrapped."""
        tq = np.asarray(tq, dtype=np.float64)
        n = len(self.t)
        if n < 2:
            z = np.zeros(tq.shape)
            return z, z.copy(), z.copy(), z.copy(), z.copy()
        i = np.clip(np.searchsorted(self.t, tq, side="right") - 1, 0, n - 2)
        span = self.t[i + 1] - self.t[i]
        with np.errstate(divide="ignore", invalid="ignore"):
            f = np.where(span > 0, (tq - self.t[i]) / span, 1.0)
        f = np.clip(f, 0.0, 1.0)
        ds, dth = f * self.ds[i], f * self.dth[i]
        bx, by = step_offsets(ds, dth, self.step_form)
        th0 = self.th[i]
        c, s = np.cos(th0), np.sin(th0)
        return (self.x[i] + c * bx - s * by, self.y[i] + s * bx + c * by, th0 + dth,
                self.cum_dist[i] + np.abs(ds), self.cum_rot[i] + np.abs(dth))

    def deltas(self, t_from: NDArray[np.float64], t_to: NDArray[np.float64]) -> Deltas:
        """Body-frame motion from each ``t_from`` to the matching ``t_to`` (s)."""
        x0, y0, th0, d0, r0 = self.poses_at(t_from)
        x1, y1, th1, d1, r1 = self.poses_at(t_to)
        c, s = np.cos(th0), np.sin(th0)
        ex, ey = x1 - x0, y1 - y0
        return Deltas(c * ex + s * ey, -s * ex + c * ey, th1 - th0, d1 - d0, r1 - r0)
