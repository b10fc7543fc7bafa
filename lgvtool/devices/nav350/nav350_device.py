"""The NAV350 device model: what the sensor answers to each telegram, given its head's output.

Shared by the simulator's NAV350 mode and the virtual NAV350 of ``simulate serve``.
Pure: the caller passes the device's run time ``t`` (s) with every call; the model keeps the
device's millisecond clock (a 32-bit counter, +1 per ms, running ``drift_ppm`` fast from
``offset_ms`` at t = 0), its access level, operating mode, layer, data formats and stored
layout. :meth:`Nav350Device.handle` answers one decoded request (replies in the request's
dialect); ``mNPOSGetData`` with wait = 1 is answered when the next revolution's result is
available, so those replies come from :meth:`Nav350Device.due`.

Behaviour where the NAV350's documentation is open (docs/protocol.md lists the inferences):
the data-format writes are read as on/off switches (landmark: cartesian, polar, optional;
scan: DIST1, RSSI1; pose: pose, optional pose), mask 0 = pose only, 1 = pose + landmarks,
2 = pose + landmarks + scan; absent blocks are sent with a zero flag; requests that need a
login answer ``sFA 1``; method calls in the wrong mode answer with errorCode 1.

Mapping (``sWN NMAPMapCfg mean neg x y phi``, ``mNEVAChangeState 2``, ``sMN mNMAPDoMapping``):
the device averages the next ``mean`` revolutions and answers after the last of them: each
reflector it measured, placed in the layout frame from the pose the host gave (it cannot know
where it stands), grouped with the measurements of the other revolutions within
:data:`MAP_GROUP_M`, kept when seen in at least half of them, and reported with its
cartesian, polar (from the stand) and optional data. Fewer than three such reflectors:
errorCode 7 and no landmarks. A vehicle that moves while mapping smears the positions, as it
would on the real device. The stored layout is read with ``mNLAYGetLayer`` and
``mNLAYGetLandmark`` (unknown id: errorCode 3).
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_telegrams import (
    MODE_LANDMARK,
    MODE_MAPPING,
    MODE_NAVIGATION,
    MODE_STANDBY,
    PASSWORD_CLIENT,
    PASSWORD_SERVICE,
    Landmark,
    LandmarkData,
    LandmarkInfo,
    PoseData,
    PoseInfo,
    ScanChannel,
    Telegram,
)

__all__ = ["ECHO_FULL", "DeviceFaults", "Nav350Device", "Observation", "Revolution",
           "RevolutionSource"]

#: Identity the device reports.
FIRMWARE = "V2.1.2-lgvtool"
DEVICE_NAME = "NAV350-3232"
SERIAL = "16460042"
#: Points of one scan (0.25 deg over a full turn).
SCAN_POINTS = 1440
_WRAP = 1 << 32
#: Time from a mode change request to its result, s.
CHANGE_DELAY = 0.05
#: Measurements of one reflector in a mapping run lie within this distance, m.
MAP_GROUP_M = 0.3
#: Fewest reflectors a mapping run must find.
MAP_MIN = 3
#: Mean echo the model reports for a clean reflector within full range, device units (the
#: NAV350's echo unit is not documented).
ECHO_FULL = 200


@dataclass(frozen=True, slots=True)
class Observation:
    """A reflector measured in a revolution: range m, bearing rad (sensor frame,
    counter-clockwise), time after the revolution start s, map id (-1 unknown), and its echo
    relative to a clean reflector within full range, 0..1 (reported as the mean echo,
    :data:`ECHO_FULL` device units at 1)."""

    range: float
    bearing: float
    time_in_scan: float
    id: int
    echo: float = 1.0


@dataclass(frozen=True, slots=True)
class Revolution:
    """One head revolution: start s, period s, when its result is available s, the head's
    pose solution (x, y m, heading rad; ``valid``; ``quality`` 0..100; reflectors used) and the
    reflectors measured in it."""

    start: float
    period: float
    available: float
    x: float
    y: float
    heading: float
    valid: bool
    quality: int
    used: int
    observations: tuple[Observation, ...]


class RevolutionSource:
    """The head's revolutions in time order, looked up by the time their result is available.

    ``resolve(k, vx, vy, omega)``, when given, solves revolution ``k`` again compensated with a
    head velocity (m/s along the vehicle axes, rad/s) and returns its new (x, y, heading,
    valid, quality, used).
    """

    def __init__(self, revolutions: Sequence[Revolution],
                 resolve: Callable[[int, float, float, float],
                                   tuple[float, float, float, bool, int, int]] | None = None
                 ) -> None:
        self.revolutions = tuple(revolutions)
        self.available = [r.available for r in self.revolutions]
        self.resolve = resolve

    def __len__(self) -> int:
        return len(self.revolutions)

    def latest(self, t: float) -> int:
        """Index of the newest revolution available at ``t`` s, -1 before the first."""
        return bisect.bisect_right(self.available, t) - 1

    def next_after(self, t: float) -> int:
        """Index of the first revolution that becomes available after ``t`` s (len: none)."""
        return bisect.bisect_right(self.available, t)


@dataclass
class DeviceFaults:
    """Faults the device injects: the next ``sfa_count`` requests answered ``sFA sfa_code``;
    pose replies with ``error_code`` until ``error_until`` s; the next ``bad_checksums``
    replies sent with a wrong checksum."""

    sfa_count: int = 0
    sfa_code: int = 13
    error_code: int = 0
    error_until: float = -math.inf
    bad_checksums: int = 0


@dataclass
class _State:
    level: int = 0
    mode: int = MODE_STANDBY
    layer: int = 0
    landmark_format: tuple[int, int, int] = (0, 1, 1)
    scan_format: tuple[int, int] = (1, 1)
    pose_format: tuple[int, int] = (1, 1)
    host_cola: int = 1
    map_cfg: tuple[int, int, int, int, int] = (50, 0, 0, 0, 0)
    """mean, negative, x mm, y mm, phi mdeg of the mapping configuration."""
    refl_size: int = 80


@dataclass
class _Pending:
    request: Telegram
    k: int
    """Revolution whose result answers it."""


@dataclass
class _Speed:
    t: float
    vx: float
    vy: float
    omega: float


@dataclass
class _Layout:
    marks: dict[int, tg.LayoutLandmark] = field(default_factory=dict)
    next_id: int = 1


class Nav350Device:
    """The device side of a NAV350 link (see the module docstring).

    :param source: the head's revolutions.
    :param layout: the stored reflector layout: global id -> landmark (mm, layers).
    :param offset_ms: clock reading at t = 0, ms.
    :param drift_ppm: the clock runs fast by this much, parts per million.
    :param area: (xmin, ymin, xmax, ymax) of the hall, m, for the DIST1 scan (walls).
    """

    def __init__(self, source: RevolutionSource, layout: dict[int, tg.LayoutLandmark], *,
                 offset_ms: int = 987_654, drift_ppm: float = 50.0,
                 area: tuple[float, float, float, float] = (-20.0, -20.0, 20.0, 20.0)) -> None:
        self.source = source
        self.offset_ms = int(offset_ms)
        self.drift_ppm = float(drift_ppm)
        self.area = area
        self._layout = _Layout(dict(layout), max(layout, default=0) + 1)
        self._state = _State()
        self._pending: list[_Pending] = []
        self._later: list[tuple[float, bytes]] = []
        self._speeds: list[_Speed] = []
        self.faults = DeviceFaults()
        #: (t, telegram) of every request handled
        self.requests: list[tuple[float, Telegram]] = []
        #: every pose-data reply sent: (t, revolution index or -1, PoseData)
        self.served: list[tuple[float, int, PoseData]] = []
        #: (t, tick, fields) of every mNPOSSetSpeed
        self.speed_inputs: list[tuple[float, int, tuple[int, ...]]] = []
        self.sfa_sent = 0

    # ------------------------------------------------------------------ clock, state
    def tick(self, t: float) -> int:
        """The device clock at run time ``t`` s: ms, 32-bit wrap-around."""
        return math.floor(self.offset_ms + t * 1000.0 * (1.0 + self.drift_ppm * 1e-6)) % _WRAP

    def time_of_tick(self, tick: float, near: float) -> float:
        """The run time (s) at which the clock reads ``tick`` (the wrap nearest ``near`` s)."""
        base = (tick - self.offset_ms) / (1000.0 * (1.0 + self.drift_ppm * 1e-6))
        period = _WRAP / (1000.0 * (1.0 + self.drift_ppm * 1e-6))
        return base + round((near - base) / period) * period

    @property
    def mode(self) -> int:
        """Operating mode (see :data:`~lgvtool.devices.nav350.nav350_telegrams.MODES`)."""
        return self._state.mode

    @property
    def layout(self) -> dict[int, tg.LayoutLandmark]:
        """The stored layout: global id -> landmark."""
        return dict(self._layout.marks)

    def reset(self) -> None:
        """Power cycle: standby, logged out, formats forgotten, pending replies dropped (the
        stored layout is kept)."""
        self._state = _State()
        self._pending.clear()
        self._later.clear()
        self._speeds.clear()

    # ------------------------------------------------------------------ telegrams
    def _out(self, telegram: Telegram, dialect: str) -> bytes:
        data = telegram.encode(dialect)
        if self.faults.bad_checksums > 0 and data[:1] == b"\x02" and data[1:2] == b"\x02":
            self.faults.bad_checksums -= 1
            data = data[:-1] + bytes([data[-1] ^ 0x5A])
        return data

    def handle(self, request: Telegram, t: float) -> list[bytes]:
        """The replies sent at once to one decoded request received at ``t`` s."""
        self.requests.append((t, request))
        if not request.is_request:
            return []
        d = request.dialect
        if self.faults.sfa_count > 0:
            self.faults.sfa_count -= 1
            return [self._sfa(self.faults.sfa_code, d)]
        if request.value is None:  # unknown name
            return [self._sfa(2 if request.kind == "sMN" else 3, d)]
        name, f = request.name, request.fields
        st = self._state
        if request.kind == "sRN":
            return [self._out(self._read(name), d)]
        if request.kind == "sWN":
            if st.level < 3 and name != "EIHstCola":
                return [self._sfa(10, d)]
            self._write(name, f)
            return [self._out(tg.reply("sWA", name), d)]
        if name == "SetAccessMode":
            level, password = int(f[0]), int(f[1])
            ok = (level == 3 and password == PASSWORD_CLIENT) or (
                level == 4 and password == PASSWORD_SERVICE)
            st.level = level if ok else 0
            return [self._out(tg.reply("sAN", name, 1 if ok else 0), d)]
        if name == "mNAVGetTimestamp":
            return [self._out(tg.reply("sAN", name, 0, self.tick(t)), d)]
        if st.level < 3:
            return [self._sfa(1, d)]
        if name == "mNEVAChangeState":
            return self._change(request, t)
        if name == "mNPOSGetData":
            return self._get_data(request, t)
        if name == "mNLMDGetData":
            if st.mode != MODE_LANDMARK:
                return [self._out(Telegram("sAN", name, PoseData(error_code=1, wait=f[0],
                                                                 mask=f[1])), d)]
            return self._get_data(request, t)
        if name == "mNPOSSetSpeed":
            ok = st.mode == MODE_NAVIGATION
            if ok:
                self.speed_inputs.append((t, int(f[3]), tuple(int(v) for v in f)))
                self._speeds.append(self._speed_of(f, t))
                del self._speeds[:-64]
            return [self._out(tg.reply("sAN", name, 0 if ok else 1), d)]
        if name == "mNPOSSetPose":
            return [self._out(tg.reply("sAN", name, 0 if st.mode == MODE_NAVIGATION else 1), d)]
        if name in ("mNLAYEraseLayout", "mNLAYAddLandmark", "mNLAYStoreLayout"):
            return [self._out(self._layout_op(request), d)]
        if name == "mNLAYGetLayer":
            layer = int(f[0])
            ids = tuple(g for g, m in sorted(self._layout.marks.items()) if layer in m.layers)
            return [self._out(Telegram("sAN", name, tg.LayerIds(0, ids)), d)]
        if name == "mNLAYGetLandmark":
            marks = self._layout.marks
            if any(int(g) not in marks for g in request.value):
                return [self._out(Telegram("sAN", name, tg.StoredLandmarks(3, ())), d)]
            return [self._out(Telegram("sAN", name, tg.StoredLandmarks(0, tuple(
                tg.StoredLandmark(int(g), marks[g].x_mm, marks[g].y_mm, marks[g].type,
                                  marks[g].subtype, marks[g].size_mm, marks[g].layers)
                for g in request.value))), d)]
        if name == "mNMAPDoMapping":
            return self._do_mapping(request, t)
        if name == "mEEwriteall":
            return [self._out(tg.reply("sAN", name, 0), d)]
        return [self._sfa(2, d)]

    def due(self, t: float) -> list[bytes]:
        """Replies whose time has come by ``t`` s (results of waiting requests, mode changes)."""
        out: list[bytes] = []
        while self._later and self._later[0][0] <= t:
            out.append(self._later.pop(0)[1])
        keep: list[_Pending] = []
        for p in self._pending:
            k = p.k
            if k < len(self.source) and self.source.revolutions[k].available <= t:
                out.append(self._out(self._pose_reply(p.request, k, t), p.request.dialect))
            elif k >= len(self.source):
                continue  # the run is over: the request is never answered
            else:
                keep.append(p)
        self._pending = keep
        return out

    def next_due(self) -> float | None:
        """Run time of the next reply :meth:`due` will give, s (None: none waiting)."""
        times = [t for t, _ in self._later[:1]]
        times += [self.source.revolutions[p.k].available for p in self._pending
                  if p.k < len(self.source)]
        return min(times) if times else None

    def _sfa(self, code: int, dialect: str) -> bytes:
        self.sfa_sent += 1
        return self._out(tg.error_reply(code), dialect)

    def _read(self, name: str) -> Telegram:
        values: dict[str, tuple[object, ...]] = {
            "FirmwareVersion": (FIRMWARE,), "SCdevicestate": (1,), "ODoprh": (12345,),
            "ODpwrc": (321,), "LocationName": ("lgvtool",), "SerialNumber": (SERIAL,),
            "DeviceIdent": (DEVICE_NAME, FIRMWARE),
            "LMDscandatacfg": (1, 1, 1, 0, 0, 0, 0, 0, 0, 1),
        }
        if name not in values:
            return tg.error_reply(3)
        return tg.reply("sRA", name, *values[name])

    def _write(self, name: str, f: tuple[object, ...]) -> None:
        st = self._state
        ints = tuple(int(v) for v in f)  # type: ignore[call-overload]
        if name == "NEVACurrLayer":
            st.layer = ints[0]
        elif name == "NLMDLandmarkDataFormat":
            st.landmark_format = (ints[0], ints[1], ints[2])
        elif name == "NAVScanDataFormat":
            st.scan_format = (ints[0], ints[1])
        elif name == "NPOSPoseDataFormat":
            st.pose_format = (ints[0], ints[1])
        elif name == "EIHstCola":
            st.host_cola = ints[0]
        elif name == "NMAPMapCfg":
            st.map_cfg = (ints[0], ints[1], ints[2], ints[3], ints[4])
        elif name == "NLMDReflSize":
            st.refl_size = ints[0]

    def _change(self, request: Telegram, t: float) -> list[bytes]:
        mode = int(request.fields[0])
        d = request.dialect
        ack = self._out(tg.reply("sMA", request.name), d)
        if mode not in tg.MODES:
            result = tg.reply("sAN", request.name, 3, self._state.mode)
        else:
            self._state.mode = mode
            self._pending.clear()
            result = tg.reply("sAN", request.name, 0, mode)
        self._later.append((t + CHANGE_DELAY, self._out(result, d)))
        return [ack]

    def _get_data(self, request: Telegram, t: float) -> list[bytes]:
        wait = int(request.fields[0])
        pose_call = request.name == "mNPOSGetData"
        if pose_call and self._state.mode != MODE_NAVIGATION:
            return [self._out(Telegram("sAN", request.name,
                                       PoseData(error_code=1, wait=wait,
                                                mask=int(request.fields[1]))),
                              request.dialect)]
        if any(p.request.name == request.name for p in self._pending):
            return [self._out(Telegram("sAN", request.name,
                                       PoseData(error_code=6, wait=wait,
                                                mask=int(request.fields[1]))),
                              request.dialect)]
        if wait:
            self._pending.append(_Pending(request, self.source.next_after(t)))
            return []
        k = self.source.latest(t)
        return [self._out(self._pose_reply(request, k, t), request.dialect)]

    def _speed_of(self, f: tuple[object, ...], t: float) -> _Speed:
        vx, vy, om = (int(v) for v in f[:3])  # type: ignore[call-overload]
        return _Speed(t, vx / 1000.0, vy / 1000.0, math.radians(om / 1000.0))

    def _layout_op(self, request: Telegram) -> Telegram:
        st, lay = self._state, self._layout
        if st.mode not in (MODE_STANDBY, MODE_MAPPING):
            return tg.Telegram("sAN", request.name, tg.AddedLandmarks(1, ())) \
                if request.name == "mNLAYAddLandmark" else tg.reply("sAN", request.name, 1)
        if request.name == "mNLAYEraseLayout":
            lay.marks.clear()
            lay.next_id = 1
            return tg.reply("sAN", request.name, 0)
        if request.name == "mNLAYStoreLayout":
            return tg.reply("sAN", request.name, 0)
        ids = []
        for m in request.value:
            lay.marks[lay.next_id] = m
            ids.append(lay.next_id)
            lay.next_id += 1
        return Telegram("sAN", request.name, tg.AddedLandmarks(0, tuple(ids)))

    def _do_mapping(self, request: Telegram, t: float) -> list[bytes]:
        d = request.dialect
        if self._state.mode != MODE_MAPPING:
            return [self._out(Telegram("sAN", request.name, tg.MappingResult(1, None)), d)]
        mean = max(1, min(127, self._state.map_cfg[0]))
        first = self.source.next_after(t)
        last = min(first + mean, len(self.source)) - 1
        if last < first:  # the run is over: never answered
            return [self._out(tg.reply("sMA", request.name), d)]
        result = self._mapped(first, last)
        at = self.source.revolutions[last].available
        self._later.append((at, self._out(Telegram("sAN", request.name, result), d)))
        self._later.sort(key=lambda item: item[0])
        return [self._out(tg.reply("sMA", request.name), d)]

    def _mapped(self, first: int, last: int) -> tg.MappingResult:
        """The reflectors of revolutions ``first..last`` placed from the configured stand (see
        the module docstring)."""
        _, _, x_mm, y_mm, phi_mdeg = self._state.map_cfg
        sx, sy, sphi = x_mm / 1000.0, y_mm / 1000.0, math.radians(phi_mdeg / 1000.0)
        c, s = math.cos(sphi), math.sin(sphi)
        groups: list[list[tuple[float, float, float, float]]] = []
        for k in range(first, last + 1):
            for o in self.source.revolutions[k].observations:
                bx, by = o.range * math.cos(o.bearing), o.range * math.sin(o.bearing)
                px, py = sx + c * bx - s * by, sy + s * bx + c * by
                near = min(groups, default=None, key=lambda g: math.hypot(
                    g[0][0] - px, g[0][1] - py))
                if near is not None and math.hypot(near[0][0] - px, near[0][1] - py) \
                        <= MAP_GROUP_M:
                    near.append((px, py, o.range, o.bearing))
                else:
                    groups.append([(px, py, o.range, o.bearing)])
        revs = last - first + 1
        kept = [g for g in groups if 2 * len(g) >= revs]
        if len(kept) < MAP_MIN:
            return tg.MappingResult(7, None)
        tick = self.tick(self.source.revolutions[last].start)
        marks = []
        for i, g in enumerate(kept):
            n = len(g)
            x = sum(p[0] for p in g) / n
            y = sum(p[1] for p in g) / n
            rng = math.hypot(x - sx, y - sy)
            bearing = math.atan2(y - sy, x - sx) - sphi
            centre = round(math.degrees(bearing) / 0.25) % SCAN_POINTS
            info = LandmarkInfo(i, 0xFFFF, 1, 1, 100, tick, self._state.refl_size,
                                min(n, 0xFFFF), ECHO_FULL, centre, centre)
            marks.append(Landmark((round(x * 1000.0), round(y * 1000.0)),
                                  (round(rng * 1000.0),
                                   round(math.degrees(bearing) * 1000.0) % 360_000), info))
        return tg.MappingResult(0, LandmarkData(1, tuple(marks)))

    # ------------------------------------------------------------------ pose data
    def _solution(self, k: int) -> tuple[float, float, float, bool, int, int]:
        rev = self.source.revolutions[k]
        base = (rev.x, rev.y, rev.heading, rev.valid, rev.quality, rev.used)
        if self.source.resolve is None or not self._speeds:
            return base
        sp = next((s for s in reversed(self._speeds) if s.t <= rev.available), None)
        if sp is None or rev.available - sp.t > 0.5:
            return base
        return self.source.resolve(k, sp.vx, sp.vy, sp.omega)

    def _pose_reply(self, request: Telegram, k: int, t: float) -> Telegram:
        st = self._state
        wait, mask = int(request.fields[0]), int(request.fields[1])
        pose_call = request.name == "mNPOSGetData"
        if k < 0:
            data = PoseData(error_code=4 if pose_call else 0, wait=wait, mask=mask)
            self.served.append((t, -1, data))
            return Telegram("sAN", request.name, data)
        rev = self.source.revolutions[k]
        error = 0
        pose = info = None
        if pose_call:
            x, y, heading, valid, quality, used = self._solution(k)
            if t < self.faults.error_until:
                error = self.faults.error_code
            elif not valid:
                error = 4
            if error == 0 and st.pose_format[0]:
                phi = round(math.degrees(heading) * 1000.0) % 360_000
                pose = (round(x * 1000.0), round(y * 1000.0), phi)
            if pose is not None and st.pose_format[1]:  # optional data only with a pose
                mid = self.tick(rev.start + 0.5 * rev.period)
                mean_dev = round((100 - max(0, min(100, quality))) * 2.5)
                info = PoseInfo(1, mid, mean_dev, 4, 0, min(used, 255))
        landmarks = None
        if (mask >= 1 or not pose_call) and error in (0, 4):
            landmarks = self._landmarks(rev)
        scans: tuple[ScanChannel, ...] = ()
        remission = None
        if mask >= 2 and error in (0, 4):
            dist, rssi = self._scan(rev)
            if st.scan_format[0]:
                scans = (dist,)
            if st.scan_format[1]:
                remission = rssi
        data = PoseData(1, error, wait, mask, pose, info, landmarks, scans, remission)
        self.served.append((t, k, data))
        return Telegram("sAN", request.name, data)

    def _landmarks(self, rev: Revolution) -> LandmarkData:
        cart_on, polar_on, opt_on = self._state.landmark_format
        marks = []
        c, s = math.cos(rev.heading), math.sin(rev.heading)
        for i, o in enumerate(rev.observations):
            cart = None
            if cart_on:
                bx, by = o.range * math.cos(o.bearing), o.range * math.sin(o.bearing)
                cart = (round((rev.x + c * bx - s * by) * 1000.0),
                        round((rev.y + s * bx + c * by) * 1000.0))
            polar = (round(o.range * 1000.0),
                     round(math.degrees(o.bearing) * 1000.0) % 360_000) if polar_on else None
            info = None
            if opt_on:
                width = max(1, round(math.degrees(0.08 / max(o.range, 0.1)) / 0.25))
                centre = round(math.degrees(o.bearing) / 0.25) % SCAN_POINTS
                info = LandmarkInfo(i, o.id if 0 <= o.id < 0xFFFF else 0xFFFF, 1, 1,
                                    max(1, 100 - round(2.0 * o.range)),
                                    self.tick(rev.start + o.time_in_scan), 80, width,
                                    max(1, min(0xFFFF, round(ECHO_FULL * o.echo))),
                                    (centre - width // 2) % SCAN_POINTS,
                                    (centre + width // 2) % SCAN_POINTS)
            marks.append(Landmark(cart, polar, info))
        return LandmarkData(1, tuple(marks))

    def _scan(self, rev: Revolution) -> tuple[ScanChannel, ScanChannel]:
        """A DIST1 scan of the hall's walls seen from the head, and its RSSI1."""
        xmin, ymin, xmax, ymax = self.area
        dist: list[int] = []
        rssi: list[int] = []
        hot = {round(math.degrees(o.bearing) / 0.25) % SCAN_POINTS for o in rev.observations}
        for i in range(SCAN_POINTS):
            a = rev.heading + math.radians(i * 0.25)
            ca, sa = math.cos(a), math.sin(a)
            r = 1e9
            if ca > 1e-9:
                r = min(r, (xmax - rev.x) / ca)
            elif ca < -1e-9:
                r = min(r, (xmin - rev.x) / ca)
            if sa > 1e-9:
                r = min(r, (ymax - rev.y) / sa)
            elif sa < -1e-9:
                r = min(r, (ymin - rev.y) / sa)
            dist.append(max(0, min(250_000, round(r * 1000.0))))
            rssi.append(250 if i in hot else 60)
        ts = self.tick(rev.start)
        return (ScanChannel("DIST1", 1.0, 0.0, 0, 250, ts, tuple(dist)),
                ScanChannel("RSSI1", 1.0, 0.0, 0, 250, ts, tuple(rssi)))
