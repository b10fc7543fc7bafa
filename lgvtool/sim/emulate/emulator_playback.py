"""What the virtual devices play: MCU bytes on a time line, NAV200 pose solutions, the map.

Two sources give the same :class:`Playback`:

- a simulator scenario (:func:`playback_from_scenario`): the MCU frames as the simulated link
  delivers them (lost frames left out, corrupted ones corrupted) and the NAV200's pose
  solution of every head revolution from the moment it can be reported, together with the
  means to solve any revolution again with motion compensation (speed input);
- a log (:func:`playback_from_log`): its /mcu/rx bytes in the chunks they arrived in (or, when
  a log has none, its /mcu/frame messages encoded again), and its /nav/pose messages as the
  solutions. A recorded or simulated run is played back as it was logged.

Times are s from the start of the run.
"""

from __future__ import annotations

import base64
import bisect
import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

from lgvtool.config import Config, Reflector
from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.nav200.nav200_device import PoseFix
from lgvtool.errors import MissingDataError
from lgvtool.json_types import JSONRecord, as_float, as_int

if TYPE_CHECKING:
    from lgvtool.sim.event_stream import NavScan

__all__ = ["McuChunk", "Playback", "playback_from_log", "playback_from_scenario"]


@dataclass(frozen=True, slots=True)
class McuChunk:
    """Bytes the MCU puts on the line at ``t`` s."""

    t: float
    data: bytes


@dataclass(frozen=True)
class Playback:
    """A run to play: MCU chunks and pose solutions in time order, the stored map."""

    mcu: tuple[McuChunk, ...]
    poses: tuple[PoseFix, ...]
    reflectors: tuple[Reflector, ...]
    duration: float
    """Length of the run, s."""
    source: str
    """What it was made from (for messages)."""
    resolve: Callable[[int, float, float, float], PoseFix] | None = None
    """``resolve(k, vx, vy, omega)``: the solution of revolution ``k`` (an index into
    :attr:`poses`) by a device that compensates its motion within the revolution with the head
    velocity ``vx``, ``vy`` (m/s, along the vehicle's axes) and ``omega`` (rad/s). None when the
    poses are what a device reported (a log)."""
    scans: tuple[NavScan, ...] = ()
    """The head revolution of each pose solution (:class:`lgvtool.sim.event_stream.NavScan`, same
    index as :attr:`poses`), for devices that report their reflectors (NAV350); empty for a
    log."""

    @property
    def per_revolution(self) -> bool:
        """The poses are one solution per head revolution (a scenario), so a device can average
        (PN) and compensate (Pv/Pw/PV) them; a log's poses are replies already."""
        return self.resolve is not None

    @cached_property
    def pose_times(self) -> list[float]:
        """Times of the pose solutions, s."""
        return [p.t for p in self.poses]

    def index_at(self, t: float) -> int:
        """Index of the newest solution reportable at ``t`` s, -1 before the first."""
        return bisect.bisect_right(self.pose_times, t) - 1

    def pose_at(self, t: float) -> PoseFix | None:
        """The newest solution reportable at ``t`` s, or None before the first."""
        i = self.index_at(t)
        return self.poses[i] if i >= 0 else None

    def mcu_bytes(self) -> bytes:
        """Every MCU byte of the run, in order."""
        return b"".join(c.data for c in self.mcu)


def playback_from_scenario(name: str, *, seed: int = 0, duration: float | None = None,
                           config: Config | None = None,
                           overrides: Mapping[str, object] | None = None) -> Playback:
    """Simulate scenario ``name`` (``lgvtool simulate`` settings) and play its device side."""
    import numpy as np

    from lgvtool.sim import nav_model
    from lgvtool.sim.event_stream import mcu_sends, nav_scans, nav_solutions
    from lgvtool.sim.simulation import simulate

    sim = simulate(name, seed=seed, config=config, overrides=overrides, duration=duration)
    mcu = tuple(McuChunk(s.t, s.delivered) for s in mcu_sends(sim) if s.delivered)
    poses = tuple(PoseFix(p.t, p.x, p.y, p.heading, p.quality, p.reflectors_used, p.valid)
                  for p in nav_solutions(sim))

    def resolve(k: int, vx: float, vy: float, omega: float) -> PoseFix:
        scans = nav_model.compensate(sim.scans, np.array([k]), vx, vy, omega)
        s = nav_model.solve(scans, sim.truth, sim.vehicle, sim.settings.nav,
                            sim.landmarks)
        return PoseFix(poses[k].t, float(s.x[0]), float(s.y[0]), float(s.heading[0]),
                       int(s.quality[0]), int(s.used[0]), bool(s.valid[0]))

    return Playback(mcu=mcu, poses=poses, reflectors=tuple(sim.config.reflectors),
                    duration=float(sim.duration), source=f"scenario {name} (seed {seed})",
                    resolve=resolve, scans=tuple(nav_scans(sim)))


def _frame_from_message(d: JSONRecord) -> bytes:
    return McuFrame(
        seq=as_int(d["seq"]), mcu_time_ms=as_int(d["mcu_time_ms"]),
        enc_left=as_int(d["enc_left"]), enc_right=as_int(d["enc_right"]),
        gyro_raw=as_int(d["gyro_raw"]), gyro_scale_udeg_s=round(as_float(d["gyro_scale"]) * 1e6),
        steering_cdeg=round(math.degrees(as_float(d["steering_angle"])) * 100.0),
        drive_speed_mm_s=round(as_float(d["drive_speed"]) * 1000.0),
        status=as_int(d["status"]), version=as_int(d.get("version", 1)),
    ).encode()


def playback_from_log(path: str | Path) -> Playback:
    """Play a log: /mcu/rx (or /mcu/frame), /nav/pose, and its reflector map.

    :raises LogFormatError: a topic's messages do not match the log contract."""
    from lgvtool.errors import LogFormatError

    try:
        return _playback_from_log(path)
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise LogFormatError(f"{path}: messages do not match the log contract "
                             f"({type(exc).__name__}: {exc})") from None


def _playback_from_log(path: str | Path) -> Playback:
    from lgvtool.log import LogReader, LogWarning, topics

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(path)
    for said in reader.warnings:  # a salvaged log is served, and said so, as every reader does
        warnings.warn(said, LogWarning, stacklevel=2)
    names = set(reader.topic_names())
    mcu_topic = topics.MCU_RX if topics.MCU_RX in names else (
        topics.MCU_FRAME if topics.MCU_FRAME in names else None)
    wanted = [t for t in (mcu_topic, topics.NAV_POSE) if t is not None and t in names]
    if not wanted:
        raise MissingDataError(f"{path}: no /mcu/rx, /mcu/frame or /nav/pose to play")
    raw_mcu: list[tuple[int, bytes]] = []
    raw_poses: list[tuple[int, dict[str, Any]]] = []
    for m in reader.messages(wanted):
        if m.topic == topics.MCU_RX:
            raw_mcu.append((m.log_time_ns, base64.b64decode(m.data["data"])))
        elif m.topic == topics.MCU_FRAME:
            raw_mcu.append((m.log_time_ns, _frame_from_message(m.data)))
        else:
            raw_poses.append((m.log_time_ns, m.data))
    t0 = min(t for t, _ in raw_mcu + raw_poses)
    end = max(t for t, _ in raw_mcu + raw_poses)
    mcu = tuple(McuChunk((t - t0) / 1e9, data) for t, data in raw_mcu if data)
    poses = tuple(
        PoseFix((t - t0) / 1e9, float(d["x"]), float(d["y"]), float(d["heading"]),
                int(d["quality"]), int(d["reflectors_used"]), bool(d["valid"]))
        for t, d in raw_poses)
    return Playback(mcu=mcu, poses=poses, reflectors=tuple(reader.reflector_map()),
                    duration=(end - t0) / 1e9, source=f"log {Path(path).name}")
