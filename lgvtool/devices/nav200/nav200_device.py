"""The NAV200 as seen from its serial port: it answers host requests with the latest solution.

:class:`Nav200Device` is shared by the simulator's host model and the device emulators: given
the pose solutions of the head (:class:`lgvtool.sim.nav_model.Solutions`) and the stored map,
it turns a decoded request and the time it arrived into the reply bytes a NAV200 would send.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lgvtool.config import Reflector
from lgvtool.devices.nav200 import nav200_protocol as proto
from lgvtool.sim.nav_model import Solutions

POSE_CODES = frozenset({"PP", "Pv", "Pw", "PV"})
"""Requests answered with the pose."""
ACK_CODES = frozenset({"SA", "MA", "PA", "PN", "UA", "DA"})
"""Mode changes answered with an empty acknowledgement."""
ECHO_CODES = frozenset({"SU", "PL", "PM", "PO", "PC"})
"""Settings answered by echoing their data."""

VERSION = (2, 0, 0)
"""Software version the emulated device reports (SV)."""
SERIAL_NUMBER = 4711
"""Serial number the emulated device reports (SS)."""


class Nav200Device:
    """A NAV200 in positioning mode that reports the most recent completed scan solution.

    :param solutions: the head's pose solution of every revolution, with the time from which
        each can be reported.
    :param reflectors: the stored reflector map (answers SR).
    """

    def __init__(self, solutions: Solutions, reflectors: Sequence[Reflector]) -> None:
        self.solutions = solutions
        self.reflectors = tuple(reflectors)

    def latest(self, t: float) -> int:
        """Index of the newest solution available at time ``t`` (s), -1 when none is yet."""
        return int(np.searchsorted(self.solutions.available, t, side="right")) - 1

    def pose_reply(self, t: float, *, no_position: bool = False) -> tuple[bytes, int]:
        """PP reply bytes at time ``t`` and the solution index it reports (-1: none).

        Without a valid solution (none yet, too few reflectors, or ``no_position`` forced by
        a fault) the device sends quality 0xFF with zero pose.
        """
        i = self.latest(t)
        sol = self.solutions
        if i < 0 or no_position or not bool(sol.valid[i]):
            used = 0 if i < 0 else min(int(sol.used[i]), 255)
            return proto.build_no_position_reply(proto.NO_POSITION, used), i
        return proto.build_pose_reply(float(sol.x[i]), float(sol.y[i]), float(sol.heading[i]),
                                      int(sol.quality[i]), min(int(sol.used[i]), 255)), i

    def answer(self, request: proto.Request, t: float, *, no_position: bool = False) -> bytes:
        """Reply bytes to ``request`` received (completely) at time ``t``, s."""
        code = request.code
        if code in POSE_CODES:
            return self.pose_reply(t, no_position=no_position)[0]
        if code in ACK_CODES:
            return proto.build_ack_reply(request)
        if code in ECHO_CODES:
            return proto.build_echo_reply(request)
        if code == "SV":
            return proto.build_version_reply(*VERSION)
        if code == "SS":
            return proto.build_serial_reply(SERIAL_NUMBER)
        if code == "SR":
            payload = request.payload
            assert isinstance(payload, proto.ReflectorAddress)
            number = int(payload.number)
            layer = [r for r in self.reflectors if r.layer == payload.layer]
            if 0 <= number < len(layer):
                r = layer[number]
                return proto.build_reflector_reply("SR", r.layer, number, r.x, r.y)
            return proto.build_error_reply(request, proto.CLASS_USER_SOFTWARE, 3, 5)
        return proto.build_error_reply(request, proto.CLASS_USER_SOFTWARE,
                                       proto.GROUP_TELEGRAM_TRAFFIC, 2)
