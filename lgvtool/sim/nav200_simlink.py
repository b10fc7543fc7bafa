"""The host polling the NAV200 over RS-232, with the faults of that link.

Every ``poll_period_s`` (plus scheduling jitter) the host writes a PP request. The request takes
5 characters of 11 bits (19200 baud, 8E1) on the wire; the device composes its reply
``reply_delay_s`` after the last request byte, from its newest completed solution (the shared
model :class:`lgvtool.devices.nav200.nav200_device.Nav200Device`, in positioning mode, reporting
the head's solutions through a :class:`SolutionSource`), and the 17-byte reply reaches the host
in one or two reads (:mod:`lgvtool.sim.serial_timing`). Faults: a request lost before the
device, a reply lost, a reply with one bit flipped in its data (the BCC fails), a reply forced
to "no valid position".
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Reflector
from lgvtool.devices.nav200.nav200_commands import ERROR_REPLY_LEN
from lgvtool.devices.nav200.nav200_device import Nav200Device, PoseFix
from lgvtool.devices.nav200.nav200_replies import NO_POSITION, build_error_reply
from lgvtool.devices.nav200.nav200_requests import request_pose
from lgvtool.sim import faults as faultlib
from lgvtool.sim.faults import FaultEvent
from lgvtool.sim.kinematics import FloatArray
from lgvtool.sim.nav_model import Solutions
from lgvtool.sim.serial_timing import BITS_8E1, Chunk, deliver, wire_time
from lgvtool.sim.settings import FaultSettings, NavSettings

REPLY_SIZE = 17
"""Bytes of a PP reply."""
POLL_ERROR = (4, 7, 7)
"""F1-F3 of the error reply a failed poll gets (``faults.nav_error_rate``): spurious
measurement, positioning, input not possible (an assumption: not documented)."""


@dataclass(frozen=True)
class SolutionSource:
    """The head's pose solution of every revolution, reportable from the time it is
    available, as a :class:`~lgvtool.devices.nav200.nav200_device.Nav200Source`."""

    solutions: Solutions
    reflectors: Sequence[Reflector]
    resolve: Callable[[int, float, float, float], PoseFix] | None = None
    per_revolution: bool = False

    @cached_property
    def poses(self) -> tuple[PoseFix, ...]:
        """The solutions as pose fixes, in time order."""
        s = self.solutions
        return tuple(PoseFix(float(s.available[i]), float(s.x[i]), float(s.y[i]),
                             float(s.heading[i]), int(s.quality[i]), int(s.used[i]),
                             bool(s.valid[i])) for i in range(len(s.available)))

    def index_at(self, t: float) -> int:
        """Index of the newest solution available at ``t`` s, -1 when none is yet."""
        return int(np.searchsorted(self.solutions.available, t, side="right")) - 1

    def pose_at(self, t: float) -> PoseFix | None:
        """The newest solution available at ``t`` s, None before the first."""
        i = self.index_at(t)
        return self.poses[i] if i >= 0 else None


def simulated_device(solutions: Solutions, reflectors: Sequence[Reflector]) -> Nav200Device:
    """The NAV200 the simulated host polls: positioning from the start, reporting the newest
    available solution of ``solutions``, with the stored map ``reflectors``."""
    return Nav200Device(SolutionSource(solutions, tuple(reflectors)), mode="positioning")


@dataclass(frozen=True)
class NavTraffic:
    """Everything on the NAV200 link: host writes (tx), host reads (rx), and what happened."""

    poll_times: FloatArray
    """Time each PP request was written, s."""
    solution: NDArray[np.int64]
    """Index of the solution each reply reports (-1: none, or no reply)."""
    tx: tuple[Chunk, ...]
    rx: tuple[Chunk, ...]
    faults: tuple[FaultEvent, ...]


def simulate(device: Nav200Device, nav: NavSettings, fault: FaultSettings, duration: float,
             noise: bool, rng_link: np.random.Generator,
             rng_faults: np.random.Generator) -> NavTraffic:
    """Poll ``device`` from ``nav.poll_start_s`` until the end of the run."""
    request = request_pose()
    request_bytes = request.encode()
    t_request = float(wire_time(len(request_bytes), nav.baud, BITS_8E1))
    t_reply = float(wire_time(REPLY_SIZE, nav.baud, BITS_8E1))
    span = t_request + nav.reply_delay_s + t_reply + nav.host_latency_s + nav.host_jitter_s
    n = max(0, math.floor((duration - span - nav.poll_jitter_s - nav.poll_start_s)
                          / nav.poll_period_s) + 1)
    u_poll = rng_link.random(n)
    polls = (nav.poll_start_s + nav.poll_period_s * np.arange(n)
             + nav.poll_jitter_s * u_poll * (1.0 if noise else 0.0))
    # drawn only when asked for: a log without error replies keeps its other faults' draws
    error = (faultlib.choose(fault.nav_error_rate, n, rng_faults) if fault.nav_error_rate > 0
             else np.zeros(n, dtype=bool))
    lost_request = faultlib.choose(fault.nav_request_drop_rate, n, rng_faults)
    lost_reply = faultlib.choose(fault.nav_reply_drop_rate, n, rng_faults)
    corrupt = faultlib.choose(fault.nav_corrupt_rate, n, rng_faults)
    no_position = faultlib.choose(fault.nav_invalid_rate, n, rng_faults)
    compose = polls + t_request + nav.reply_delay_s
    delivery = deliver(compose, np.where(error, ERROR_REPLY_LEN, REPLY_SIZE), nav.baud, BITS_8E1,
                       nav.host_latency_s, nav.host_jitter_s * (1.0 if noise else 0.0),
                       nav.split_probability, rng_link)
    tx: list[Chunk] = []
    rx: list[Chunk] = []
    events: list[FaultEvent] = []
    solution = np.full(n, -1, dtype=np.int64)
    for i in range(n):
        t = float(polls[i])
        tx.append(Chunk(t, request_bytes))
        if lost_request[i]:
            events.append(FaultEvent(t, "simulator", "nav_request_dropped",
                                     "PP request lost on the way to the NAV200"))
            continue
        forced = bool(no_position[i])
        data, index = device.pose_reply(float(compose[i]), no_position=forced)
        if error[i]:
            data, forced = build_error_reply(request, *POLL_ERROR), True
            events.append(FaultEvent(float(compose[i]), "simulator", "nav_error_reply",
                                     "NAV200 answers the PP poll with an error reply",
                                     dict(zip(("error_class", "group", "detail"), POLL_ERROR,
                                              strict=True))))
        elif forced:
            events.append(FaultEvent(float(compose[i]), "simulator", "nav_no_position",
                                     "NAV200 replies 'no valid position' (quality 0xFF)",
                                     {"quality": NO_POSITION}))
        if lost_reply[i]:
            events.append(FaultEvent(float(compose[i]), "simulator", "nav_reply_dropped",
                                     "PP reply lost on the way to the host"))
            continue
        if corrupt[i]:
            data, byte, bit = faultlib.flip_bit(data, 4, len(data) - 1, rng_faults)
            events.append(FaultEvent(float(compose[i]), "simulator", "nav_reply_corrupted",
                                     f"PP reply byte {byte} bit {bit} flipped",
                                     {"byte_index": byte, "bit": bit}))
        solution[i] = -1 if forced else index
        rx.extend(delivery.chunks(i, data))
    return NavTraffic(poll_times=polls, solution=solution, tx=tuple(tx), rx=tuple(rx),
                      faults=tuple(events))
