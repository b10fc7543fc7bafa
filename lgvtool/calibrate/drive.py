"""One log prepared for the calibration: trajectory nodes, motion between them, observations.

Times are s after the log's first message. The trajectory of O is one pose per motion sample
(the nodes): the MCU frames, or the generic odometry thinned to at most ``node_rate_hz``
(:data:`TWIST_NODE_RATE_HZ`).

MCU frames are placed at the instant the MCU sampled them, not at the host's read (which comes
a few ms later and jitters): the MCU's millisecond clock is mapped onto the host clock by a
straight line (its rate and offset), shifted so that the earliest reads arrive one frame's
time on the wire after the sample. The NAV-to-host time offset is therefore measured against
the MCU's sampling instants; only the host's read latency (about 1 ms) remains in it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.config import Reflector
from lgvtool.errors import MissingDataError
from lgvtool.localize.logdata import LogData, scan_batch
from lgvtool.localize.motion import unwrap_counter

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MCU_FRAME_BYTES = 30
"""Length of a version-1 MCU frame on the wire, bytes (lgvtool.devices.mcu.mcu_frame.FRAME_SIZE)."""
MCU_BAUD = 115_200
"""The MCU link's speed when the log does not say, baud (8N1: 10 bits a byte)."""
TWIST_NODE_RATE_HZ = 1.0
"""Most nodes per second of generic odometry, 1/s. Generic odometry is often the *commanded*
velocity, which a robot follows late and smoothed (its acceleration limits): over 0.1 s the
turn it makes is not the commanded one scaled, and a scale fitted interval by interval comes
out too small (regression dilution: on MRCLAM Dataset 6 the ground truth's turn against the
command is 0.83-0.88 per 0.1 s, 0.91-0.94 per 1 s and 0.93-0.97 per 5 s). Intervals of a
second, several times the robots' delay of about 0.2 s, compare what the robot does with what
it was told."""


@dataclass
class Drive:
    """One log, ready for the least squares (arrays per node, interval or observation)."""

    name: str
    motion: str
    """``mcu`` (encoders and gyro) or ``twist`` (generic odometry v, omega)."""
    t: FloatArray
    """Node times, s."""
    counts_left: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Encoder counts of each interval (MCU), left wheel."""
    counts_right: FloatArray = field(default_factory=lambda: np.zeros(0))
    gyro: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Integral of the reported gyro rate over each interval, rad (MCU)."""
    gyro_dt: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Length of each interval by the MCU's clock, s (MCU)."""
    gyro_ok: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    """Interval without lost frames, so that its gyro integral is complete."""
    dist: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Integral of the reported speed over each interval, m (generic odometry)."""
    turn: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Integral of the reported yaw rate over each interval, rad (generic odometry)."""
    obs_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Stamp of each reflector measurement (scan start + time in the scan), s."""
    obs_range: FloatArray = field(default_factory=lambda: np.zeros(0))
    obs_bearing: FloatArray = field(default_factory=lambda: np.zeros(0))
    obs_id: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    obs_lx: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Map position of the associated reflector, m (NaN: not associated)."""
    obs_ly: FloatArray = field(default_factory=lambda: np.zeros(0))
    pose_t: FloatArray = field(default_factory=lambda: np.zeros(0))
    """Receive time of each valid NAV pose, s."""
    pose_x: FloatArray = field(default_factory=lambda: np.zeros(0))
    pose_y: FloatArray = field(default_factory=lambda: np.zeros(0))
    pose_heading: FloatArray = field(default_factory=lambda: np.zeros(0))
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Time from the first to the last node, s."""
        return float(self.t[-1] - self.t[0]) if len(self.t) else 0.0


def mcu_sample_times(t_recv: FloatArray, mcu_ms: IntArray, baud: float) -> tuple[FloatArray, str]:
    """When the MCU sampled each frame, on the host clock (s): the MCU clock mapped by a
    straight line through the earliest reads, minus the frame's time on the wire.

    Falls back to the read times when the MCU clock does not follow the host clock (spread of
    the reads about the line over 50 ms). Returns the times and which clock was used.
    """
    if len(t_recv) < 10:
        return t_recv, "host"
    steps = unwrap_counter(np.asarray(mcu_ms, dtype=np.int64), 1 << 32, signed=False)
    m = np.concatenate([[0.0], np.cumsum(steps) * 1e-3])
    a, b = np.polyfit(m, t_recv, 1)
    late = t_recv - (a * m + b)
    lo, hi = np.percentile(late, [1.0, 99.0])
    if not (hi - lo < 0.05 and 0.9 < a < 1.1):
        return t_recv, "host"
    keep = late <= lo + 0.5 * (hi - lo)
    a, b = np.polyfit(m[keep], t_recv[keep], 1)
    late = t_recv - (a * m + b)
    wire = MCU_FRAME_BYTES * 10.0 / baud
    # the earliest reads are those of a frame sampled at the start of its ms count; on
    # average a frame was sampled half a ms after its count began
    return np.asarray(a * (m + 0.5e-3) + b + float(np.percentile(late, 0.5)) - wire), "mcu"


def _mcu_intervals(drive: Drive, mcu: Mapping[str, ArrayLike], baud: float) -> None:
    seq = np.asarray(mcu["seq"], dtype=np.int64)
    el = np.asarray(mcu["enc_left"], dtype=np.int64)
    er = np.asarray(mcu["enc_right"], dtype=np.int64)
    keep = np.ones(len(seq), dtype=bool)
    if len(seq) > 1:
        keep[1:] = ~((np.diff(seq) == 0) & (np.diff(el) == 0) & (np.diff(er) == 0))
    t_recv = np.asarray(mcu["t"], dtype=np.float64)[keep]
    ms = np.asarray(mcu["mcu_time_ms"], dtype=np.int64)[keep]
    seq, el, er = seq[keep], el[keep], er[keep]
    rate = np.asarray(mcu["gyro_rate"], dtype=np.float64)[keep]
    t, clock = mcu_sample_times(t_recv, ms, baud)
    order = np.argsort(t, kind="stable")
    t, seq, el, er, rate, ms = t[order], seq[order], el[order], er[order], rate[order], ms[order]
    drive.t = t
    drive.counts_left = unwrap_counter(el, 1 << 32, signed=True).astype(np.float64)
    drive.counts_right = unwrap_counter(er, 1 << 32, signed=True).astype(np.float64)
    dseq = unwrap_counter(seq, 1 << 16, signed=False)
    dt_mcu = unwrap_counter(ms, 1 << 32, signed=False) * 1e-3
    dt: FloatArray = np.asarray(dt_mcu if clock == "mcu" else np.diff(t), dtype=np.float64)
    # a frame's rate is the mean over the time since the MCU's previous sample
    drive.gyro = rate[1:] * dt
    drive.gyro_dt = dt
    drive.gyro_ok = (dseq == 1) & (dt > 0)
    drive.info.update(clock=clock, frames=len(t), lost_frames=int(np.maximum(dseq - 1, 0).sum()))


def _twist_intervals(drive: Drive, twist: dict[str, FloatArray], node_rate_hz: float) -> None:
    t = np.asarray(twist["t"], dtype=np.float64)
    v = np.asarray(twist["v"], dtype=np.float64)
    w = np.asarray(twist["omega"], dtype=np.float64)
    dt = np.diff(t)
    ds, dth = v[:-1] * dt, w[:-1] * dt
    # thin the nodes: a node whenever 1/node_rate_hz has passed since the last one
    step = 1.0 / node_rate_hz
    slot = np.floor((t - t[0]) / step).astype(np.int64)
    nodes = np.concatenate([[0], np.nonzero(np.diff(slot) > 0)[0] + 1])
    if nodes[-1] != len(t) - 1:
        nodes = np.concatenate([nodes, [len(t) - 1]])
    cs = np.concatenate([[0.0], np.cumsum(ds)])
    ct = np.concatenate([[0.0], np.cumsum(dth)])
    drive.t = t[nodes]
    drive.dist = np.diff(cs[nodes])
    drive.turn = np.diff(ct[nodes])
    drive.info.update(clock="host", odometry_rows=len(t))


def _observations(drive: Drive, data: LogData, use_scans: bool, use_poses: bool) -> None:
    if use_scans and data.has_scans:
        b = scan_batch(data.scans)
        owner = np.repeat(np.arange(len(b.t)), b.counts)
        drive.obs_t = b.t[owner] + b.times
        drive.obs_range = b.ranges
        drive.obs_bearing = b.bearings
        drive.obs_id = b.ids
        drive.info["scans"] = len(b.t)
    if use_poses and data.has_poses and data.nav is not None:
        ok = np.asarray(data.nav["valid"], dtype=bool)
        drive.pose_t = np.asarray(data.nav["t"], dtype=np.float64)[ok]
        drive.pose_x = np.asarray(data.nav["x"], dtype=np.float64)[ok]
        drive.pose_y = np.asarray(data.nav["y"], dtype=np.float64)[ok]
        drive.pose_heading = np.asarray(data.nav["heading"], dtype=np.float64)[ok]
        drive.info["poses"] = len(drive.pose_t)


def associate_known(drive: Drive, reflectors: tuple[Reflector, ...]) -> None:
    """Map position of every measurement whose id is in the map (NaN for the others)."""
    lx = np.full(len(drive.obs_id), math.nan)
    ly = np.full(len(drive.obs_id), math.nan)
    if reflectors and len(drive.obs_id):
        ids = np.array([r.id for r in reflectors], dtype=np.int64)
        xs = np.array([r.x for r in reflectors])
        ys = np.array([r.y for r in reflectors])
        order = np.argsort(ids)
        at = np.clip(np.searchsorted(ids[order], drive.obs_id), 0, len(ids) - 1)
        hit = ids[order][at] == drive.obs_id
        lx[hit] = xs[order][at][hit]
        ly[hit] = ys[order][at][hit]
    drive.obs_lx, drive.obs_ly = lx, ly


def prepare(name: str, data: LogData, reflectors: tuple[Reflector, ...], *,
            observations: str = "auto", mcu_baud: float = MCU_BAUD,
            node_rate_hz: float = TWIST_NODE_RATE_HZ) -> Drive:
    """A :class:`Drive` from a log's data. ``observations``: ``auto`` (scans and the poses
    beside them), ``scans`` or ``poses``.

    :raises MissingDataError: no motion data, or no observation of the chosen kind.
    """
    if data.mcu is not None and len(data.mcu["t"]) >= 2:
        drive = Drive(name, "mcu", np.zeros(0))
        _mcu_intervals(drive, data.mcu, mcu_baud)
    elif data.twist is not None and len(data.twist["t"]) >= 2:
        drive = Drive(name, "twist", np.zeros(0))
        _twist_intervals(drive, data.twist, node_rate_hz)
    else:
        raise MissingDataError(f"{name}: no motion data (/mcu/frame or /odom/twist)")
    use_scans = observations in ("auto", "scans")
    use_poses = observations in ("auto", "poses")
    _observations(drive, data, use_scans, use_poses)
    associate_known(drive, reflectors)
    if not len(drive.obs_t) and not len(drive.pose_t):
        what = {"scans": "reflector scans (/nav/reflectors with a map)",
                "poses": "valid NAV poses (/nav/pose)"}.get(
            observations, "reflector scans (/nav/reflectors with a map) or valid NAV poses")
        raise MissingDataError(f"{name}: no observations: the log has no {what}")
    return drive


def log_mcu_baud(metadata: Mapping[str, Mapping[str, object]]) -> float:
    """The MCU link's speed as the log's metadata gives it, else :data:`MCU_BAUD`."""
    sim = metadata.get("simulator", {})
    settings = sim.get("settings") if isinstance(sim, dict) else None
    if isinstance(settings, dict):
        baud = settings.get("mcu", {}).get("baud")
        if isinstance(baud, int | float) and baud > 0:
            return float(baud)
    return float(MCU_BAUD)
