"""The NAV200 device model: the one that the simulator polls and the emulator serves.

:class:`Nav200Device` answers decoded host requests with the modes of the real device. It
starts in standby, as a NAV200 does after power-up. Mode changes (SA, PA, PN, UA, DA, MA) are
accepted in any mode; every other command only in its own mode, otherwise the reply is an
error telegram ('E', F1 = 1 user software, F2 = the group of the present mode, F3 = 3 wrong
command). The stored reflector map answers SR and the upload loop (UA, then UR until an end
marker with number 0xFF; one more UR gets 'E' with F3 = 10, all reflectors transferred), and
can be changed with SC, SI, SD and the download (DA, DR). Pose requests (PP, Pv, Pw, PV) are
answered with the newest solution of its :class:`Nav200Source`; the speed inputs are kept in
:attr:`Nav200Device.speed_inputs`. Identity: software version :data:`VERSION`, serial number
:data:`SERIAL_NUMBER`.

When the source gives one solution per head revolution and can solve them again (a scenario
played by the emulator) the device also does what the NAV200's positioning settings ask:

- speed input: a revolution that ends within :data:`SPEED_MAX_AGE` of a Pv/Pw/PV request is
  solved again, compensated with the speeds of the latest such request (Pv: no yaw rate; PV:
  world-frame speeds, turned into the vehicle frame with the device's heading), so that a host
  that sends good speeds gets the skew of turning removed, and one that sends wrong ones (the
  omega units are an open point of the protocol) gets it changed;
- sliding mean (PN n): the reply is the mean of the last n revolutions' solutions (positions
  averaged, heading as a circular mean); no valid position while the newest has none. PA
  enters positioning without one (n = 1; the NAV200's own default is undocumented).

A log's poses, and the simulator's solutions, are reported as they are.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from lgvtool.angles import circular_mean
from lgvtool.config import Reflector
from lgvtool.devices.nav200.nav200_commands import Reply, Request
from lgvtool.devices.nav200.nav200_payloads import (
    ActionRadii,
    Count,
    Layer,
    Payload,
    ReflectorAddress,
    ReflectorPosition,
    ReflectorRadius,
    Speed,
    SpeedOmega,
)
from lgvtool.devices.nav200.nav200_replies import (
    CLASS_USER_SOFTWARE,
    DETAIL_WRONG_COMMAND,
    NO_POSITION,
    build_ack_reply,
    build_download_reply,
    build_echo_reply,
    build_error_reply,
    build_mapping_reply,
    build_no_position_reply,
    build_pose_reply,
    build_radius_reply,
    build_serial_reply,
    build_upload_reply,
    build_version_reply,
    build_version_text_reply,
)
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S

__all__ = ["MODE_GROUP", "SERIAL_NUMBER", "SPEED_MAX_AGE", "VERSION", "Nav200Device",
           "Nav200Source", "PoseFix"]

#: Software version the device model reports (SV).
VERSION = (2, 4, 1)
#: Serial number the device model reports (SS).
SERIAL_NUMBER = 20417
#: F2 error group of each mode.
MODE_GROUP = {"standby": 2, "download": 4, "upload": 5, "mapping": 6, "positioning": 7}
#: Mode each command letter belongs to (mode changes are handled apart).
_MODE_OF = {"S": "standby", "R": "standby", "M": "mapping", "P": "positioning",
            "U": "upload", "D": "download"}
_MODE_CHANGE = {"SA": "standby", "PA": "positioning", "PN": "positioning", "UA": "upload",
                "DA": "download", "MA": "mapping"}
_POSE = frozenset({"PP", "Pv", "Pw", "PV"})
_ECHO = frozenset({"SU", "PL", "PM", "PC"})
#: F3 details.
_NOT_AVAILABLE, _WRONG_NUMBER, _ALL_TRANSFERRED, _WRONG_RADII = 4, 5, 10, 13
#: Reflector number of the upload end marker.
END_NUMBER = 0xFF
#: A speed input older than this at the end of a revolution is not used to compensate it, s.
SPEED_MAX_AGE = 0.5
#: Speed inputs and compensated solutions kept (minutes of polling; a PN mean spans 32 s at most).
_KEEP = 1024


@dataclass(frozen=True, slots=True)
class PoseFix:
    """A NAV200 pose solution of the head, reportable from ``t`` s on: x, y in m, heading in
    rad, quality and reflectors used as the device reports them, ``valid`` False for
    "no valid position"."""

    t: float
    x: float
    y: float
    heading: float
    quality: int
    reflectors_used: int
    valid: bool


class Nav200Source(Protocol):
    """What the device reports: pose solutions in time order and the stored map
    (the emulator's playback is one, the simulator's solution source another)."""

    @property
    def poses(self) -> Sequence[PoseFix]:
        """The pose solutions, in time order."""

    @property
    def reflectors(self) -> Sequence[Reflector]:
        """The stored reflector map."""

    @property
    def resolve(self) -> Callable[[int, float, float, float], PoseFix] | None:
        """``resolve(k, vx, vy, omega)``: revolution ``k`` solved again with motion
        compensation (vehicle-frame head velocity m/s, m/s, rad/s); None: the poses are
        replies already and are reported as they are."""

    @property
    def per_revolution(self) -> bool:
        """The poses are one solution per head revolution (so they can be averaged)."""

    def index_at(self, t: float) -> int:
        """Index of the newest solution reportable at ``t`` s, -1 before the first."""

    def pose_at(self, t: float) -> PoseFix | None:
        """The newest solution reportable at ``t`` s, None before the first."""


@dataclass
class _State:
    mode: str = "standby"
    upload_cursor: int = 0
    upload_done: bool = False
    sliding_mean: int = 1
    action_radii_mm: tuple[int, int] = (1000, 30000)
    nearest: int = 0
    layer: int = 0
    radius: dict[int, int] = field(default_factory=dict)
    download: list[ReflectorPosition] = field(default_factory=list)


class Nav200Device:
    """The NAV200's side of the host protocol: decoded requests in, reply telegrams out.

    :param source: the pose solutions and the map the device reports.
    :param omega_scale: wire units of a Pw/PV yaw rate per rad/s (default 32768/pi, 65536 per
        revolution per second, as lgvtool's recorder sends it).
    :param mode: the mode it starts in (a NAV200 powers up in standby; the simulator's polled
        device is positioning already).
    """

    def __init__(self, source: Nav200Source,
                 omega_scale: float = OMEGA_UNITS_PER_RAD_S, *,
                 mode: str = "standby") -> None:
        self.source = source
        self.omega_scale = omega_scale
        #: (t, vx, vy, omega) of every speed input, in the vehicle frame: m/s, m/s, rad/s
        self._speeds: deque[tuple[float, float, float, float]] = deque(maxlen=_KEEP)
        self._compensated: dict[tuple[int, float, float, float], PoseFix] = {}
        self._state = _State(mode=mode)
        self.store: dict[tuple[int, int], tuple[int, int]] = {}
        for r in source.reflectors:
            if 0 <= r.id < END_NUMBER and 0 <= r.layer <= 255:
                self.store[(r.layer, r.id)] = (round(r.x * 1000), round(r.y * 1000))
        #: (t, code) of every request decoded
        self.requests: list[tuple[float, str]] = []
        #: (t, code, payload) of every pose request that carried speed input
        self.speed_inputs: list[tuple[float, str, Payload]] = []
        #: error replies sent
        self.errors_sent = 0
        self._handlers: dict[str, Callable[[Request], bytes]] = {
            "SV": self._version, "ST": self._version_text, "SS": self._serial,
            "SR": self._read_reflector, "SC": self._change_reflector,
            "SI": self._insert_reflector, "SD": self._delete_reflector,
            "RG": self._get_radius, "RS": self._set_radius, "MS": self._map, "MM": self._map,
            "MN": self._map, "MR": self._mapped_reflector, "PO": self._action_radii,
            "UR": self._upload_next, "DR": self._download,
        }

    @property
    def mode(self) -> str:
        """The present mode: standby, positioning, upload, download or mapping."""
        return self._state.mode

    def reset(self) -> None:
        """Power cycle: back to standby with the settings forgotten (the map is kept)."""
        self._state = _State(radius=self._state.radius)
        self._speeds.clear()

    def latest(self, t: float) -> int:
        """Index of the newest solution reportable at ``t`` s, -1 when none is yet."""
        return self.source.index_at(t)

    def pose_reply(self, t: float, *, no_position: bool = False) -> tuple[bytes, int]:
        """The pose reply at ``t`` s and the index of the solution it reports (-1: none yet).
        ``no_position``: a fault forces "no valid position" (quality 0xFF, zero pose)."""
        fix = self.current_fix(t)
        i = self.latest(t)
        if no_position and fix is not None:
            fix = PoseFix(fix.t, 0.0, 0.0, 0.0, NO_POSITION, fix.reflectors_used, False)
        return self._pose_bytes(fix), i

    # ------------------------------------------------------------------ replies
    def _error(self, request: Request, detail: int, group: int | None = None) -> bytes:
        self.errors_sent += 1
        return build_error_reply(request, CLASS_USER_SOFTWARE,
                                       MODE_GROUP[self._state.mode] if group is None else group,
                                       detail)

    def answer(self, request: Request, t: float) -> bytes:
        """The reply to one decoded request received at ``t`` s."""
        code = request.code
        self.requests.append((t, code))
        st = self._state
        if code in _MODE_CHANGE:
            st.mode = _MODE_CHANGE[code]
            if code == "PN":
                assert isinstance(request.payload, Count)
                st.sliding_mean = request.payload.n
            elif code == "PA":
                st.sliding_mean = 1
            if code == "UA":
                st.upload_cursor, st.upload_done = 0, False
            if code == "DA":
                st.download = []
            return build_ack_reply(request)
        if _MODE_OF.get(code[0]) != st.mode:
            return self._error(request, DETAIL_WRONG_COMMAND)
        if code in _POSE:
            if code != "PP":
                self.speed_inputs.append((t, code, request.payload))
                self._speeds.append((t, *self._vehicle_speed(code, request.payload, t)))
            return self._pose(t)
        if code in _ECHO:
            return build_echo_reply(request)
        handler = self._handlers.get(code)
        if handler is None:
            return self._error(request, 2)  # not implemented
        return handler(request)

    def _vehicle_speed(self, code: str, payload: Payload, t: float
                       ) -> tuple[float, float, float]:
        """A speed input as (vx, vy, omega) along the vehicle's axes: m/s, m/s, rad/s."""
        if isinstance(payload, Speed):
            return payload.vx, payload.vy, 0.0
        assert isinstance(payload, SpeedOmega)
        vx, vy, omega = payload.vx, payload.vy, payload.omega(self.omega_scale)
        if code == "PV":  # world frame: into the vehicle frame with the device's own heading
            fix = self.source.pose_at(t)
            th = 0.0 if fix is None else fix.heading
            c, s = math.cos(th), math.sin(th)
            vx, vy = c * vx + s * vy, -s * vx + c * vy
        return vx, vy, omega

    def _solution(self, k: int) -> PoseFix:
        """Revolution ``k`` as the device solves it: compensated with the latest speed input
        received before it was solved, if that is recent enough."""
        pb = self.source
        fix = pb.poses[k]
        if pb.resolve is None:
            return fix
        speed = next((sp for sp in reversed(self._speeds) if sp[0] <= fix.t), None)
        if speed is None or fix.t - speed[0] > SPEED_MAX_AGE:
            return fix
        key = (k, *speed[1:])
        if key not in self._compensated:
            if len(self._compensated) >= _KEEP:
                self._compensated.clear()
            self._compensated[key] = pb.resolve(k, *speed[1:])
        return self._compensated[key]

    def current_fix(self, t: float) -> PoseFix | None:
        """The solution the device reports at ``t`` s: the newest revolution's, compensated
        and averaged as its settings ask (see the module docstring); None before the first."""
        pb = self.source
        i = pb.index_at(t)
        if i < 0:
            return None
        if not pb.per_revolution:
            return pb.poses[i]
        newest = self._solution(i)
        n = max(1, self._state.sliding_mean)
        if n == 1 or not newest.valid:
            return newest
        fixes = [f for f in (self._solution(j) for j in range(max(0, i - n + 1), i + 1))
                 if f.valid]
        heading = circular_mean(np.array([f.heading for f in fixes]))
        return PoseFix(newest.t, sum(f.x for f in fixes) / len(fixes),
                       sum(f.y for f in fixes) / len(fixes), heading,
                       round(sum(f.quality for f in fixes) / len(fixes)),
                       newest.reflectors_used, True)

    def _pose(self, t: float) -> bytes:
        return self._pose_bytes(self.current_fix(t))

    @staticmethod
    def _pose_bytes(fix: PoseFix | None) -> bytes:
        if fix is None or not fix.valid:
            used = 0 if fix is None else min(fix.reflectors_used, 255)
            return build_no_position_reply(NO_POSITION, used)
        return build_pose_reply(fix.x, fix.y, fix.heading, min(fix.quality, 0xFD),
                                      min(fix.reflectors_used, 255))

    def _layer_numbers(self, layer: int) -> list[int]:
        return sorted(n for (lay, n) in self.store if lay == layer)

    def _rp_reply(self, code: str, layer: int, number: int) -> bytes:
        x, y = self.store[(layer, number)]
        return Reply(code, ReflectorPosition(layer, number, x, y)).encode()

    def _version(self, request: Request) -> bytes:
        return build_version_reply(*VERSION)

    def _version_text(self, request: Request) -> bytes:
        return build_version_text_reply("NAV200 V{}.{}.{} (virtual)".format(*VERSION))

    def _serial(self, request: Request) -> bytes:
        return build_serial_reply(SERIAL_NUMBER)

    def _read_reflector(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorAddress)
        if (p.layer, p.number) not in self.store:
            return self._error(request, _NOT_AVAILABLE, group=3)
        return self._rp_reply("SR", p.layer, p.number)

    def _change_reflector(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorPosition)
        if (p.layer, p.number) not in self.store:
            return self._error(request, _NOT_AVAILABLE, group=3)
        self.store[(p.layer, p.number)] = (p.x_mm, p.y_mm)
        return build_echo_reply(request)

    def _insert_reflector(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorPosition)
        if p.number >= END_NUMBER:
            return self._error(request, _WRONG_NUMBER, group=3)
        self.store[(p.layer, p.number)] = (p.x_mm, p.y_mm)
        return build_echo_reply(request)

    def _delete_reflector(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorAddress)
        if (p.layer, p.number) not in self.store:
            return self._error(request, _NOT_AVAILABLE, group=3)
        reply = self._rp_reply("SD", p.layer, p.number)
        del self.store[(p.layer, p.number)]
        return reply

    def _get_radius(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, Layer)
        return build_radius_reply(p.layer, self._state.radius.get(p.layer, 45))

    def _set_radius(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorRadius)
        self._state.radius[p.layer] = p.radius
        return build_radius_reply(p.layer, p.radius)

    def _map(self, request: Request) -> bytes:
        layer = getattr(request.payload, "layer", 0)
        return build_mapping_reply(layer, min(len(self._layer_numbers(layer)), 255))

    def _mapped_reflector(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorAddress)
        numbers = self._layer_numbers(p.layer)
        if p.number >= len(numbers):
            return self._error(request, _WRONG_NUMBER)
        x, y = self.store[(p.layer, numbers[p.number])]
        return Reply("MR", ReflectorPosition(p.layer, p.number, x, y)).encode()

    def _action_radii(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ActionRadii)
        if not 0 <= p.r_min_mm < p.r_max_mm:
            return self._error(request, _WRONG_RADII)
        self._state.action_radii_mm = (p.r_min_mm, p.r_max_mm)
        return build_echo_reply(request)

    def _upload_next(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, Layer)
        st = self._state
        numbers = self._layer_numbers(p.layer)
        if st.upload_done:
            return self._error(request, _ALL_TRANSFERRED)
        if st.upload_cursor >= len(numbers):
            st.upload_done = True
            return build_upload_reply(p.layer, END_NUMBER, 0.0, 0.0)
        number = numbers[st.upload_cursor]
        st.upload_cursor += 1
        return self._rp_reply("UR", p.layer, number)

    def _download(self, request: Request) -> bytes:
        p = request.payload
        assert isinstance(p, ReflectorPosition)
        st = self._state
        if p.number == END_NUMBER:
            for layer in {r.layer for r in st.download}:
                for key in [k for k in self.store if k[0] == layer]:
                    del self.store[key]
            for r in st.download:
                self.store[(r.layer, r.number)] = (r.x_mm, r.y_mm)
            st.download = []
        else:
            st.download.append(p)
        return build_download_reply(p.layer, p.number)

    def reflectors(self) -> tuple[Reflector, ...]:
        """The stored map as reflectors (m)."""
        return tuple(Reflector(id=n, x=x / 1000.0, y=y / 1000.0, layer=lay)
                     for (lay, n), (x, y) in sorted(self.store.items()))
