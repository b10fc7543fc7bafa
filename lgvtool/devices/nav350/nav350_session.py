"""The NAV350 host state machine of a recording: start-up, the navigation loop, the clock, recovery.

Pure apart from the numbers it is given: the caller passes the host time ``now`` (s, one
monotonic time base) to every call, writes the telegrams :meth:`Nav350Session.poll` returns,
feeds what it reads to :meth:`Nav350Session.feed` and collects :meth:`Nav350Session.pop_events`.

Sequence (the vendor driver's NAV350 block, docs/recording.md)::

    sMN SetAccessMode 3 F4724744         login (refused: the recording stops, one clear line)
    sWN EIHstCola 1|0                    the dialect the host speaks, as the vendor driver asks
    sRN FirmwareVersion, SerialNumber, LocationName      device identity (sFA: skipped)
    sMN mNEVAChangeState 1               standby (sMA, then sAN)
    [sMN mNLAYGetLayer L, mNLAYGetLandmark <=50 ids ...]  read the stored layout (default)
    [sMN mNLAYEraseLayout 1, mNEVAChangeState 2, mNLAYAddLandmark x <=50 ...,
     mNLAYStoreLayout, mNEVAChangeState 1, then read it back]
                                         write a layout: only when asked, once per recording
    [sWN NEVACurrLayer L, NMAPMapCfg, mNEVAChangeState 2, mNMAPDoMapping (vehicle still),
     mNEVAChangeState 1]                 map from a stand: only when asked, once per recording
    sWN NEVACurrLayer L                  the layer to navigate on
    sWN NLMDLandmarkDataFormat 0 1 1, NAVScanDataFormat 1 1, NPOSPoseDataFormat 1 1
    sMN mNEVAChangeState 4               navigation
    sMN mNPOSGetData 1 MASK              repeated: the device answers at its rate (<= 8 Hz)
      + sMN mNAVGetTimestamp every clock_period s (clock offset and drift)
      + sMN mNPOSSetSpeed after every pose, with --speed-input

Recovery: errorCode 1 (wrong mode: the device restarted) or ``restart_after`` failed pose
requests in a row restart the sequence; ``silent_after`` reply timeouts in a row report the
device silent (the caller reopens the link); failed start-up steps retry with backoff. A clock
read that fails (a reply that cannot be parsed, an error reply, no reply) is tried at most
``clock_tries`` times per device session (a link opened, or the device restarted: its clock
starts again), then the clock is estimated from the pose replies' arrival for the rest of that
session, said once. Nothing is ever written to the device's layout unless ``write_layout`` is
given, and then once per session object (one recording), never again after a reconnect.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from lgvtool.devices.head_speed import HeadSpeed
from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_clock import ClockEstimate, ClockEstimator
from lgvtool.devices.nav350.nav350_cola import BINARY
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.devices.nav350.nav350_telegrams import (
    ERROR_CODES,
    LayerIds,
    LayoutLandmark,
    MappingResult,
    PoseData,
    StoredLandmark,
    StoredLandmarks,
    Telegram,
)
from lgvtool.devices.session_events import DeviceSilent, PositioningEntered
from lgvtool.json_types import JSON, JSONObject
from lgvtool.wire.decode_events import ERROR, INFO, WARNING, DecodeEvent, DecoderStats

__all__ = [
    "ClockRead",
    "Identity",
    "LayoutRead",
    "LayoutWritten",
    "MapStand",
    "MappingDone",
    "Nav350Session",
    "Nav350Settings",
    "NavigationEntered",
    "PoseDataReceived",
    "SessionFatal",
]

#: Most landmarks per mNLAYAddLandmark and per mNLAYGetLandmark (the vendor driver's chunk).
ADD_CHUNK = 50
#: Fewest landmarks a mapping run must find (the device's own minimum for a layout).
MIN_MAPPED = 3
#: Fewest landmarks a layout must have to be uploaded.
MIN_LAYOUT = 3
_REPLY_KIND = {"sMN": "sAN", "sRN": "sRA", "sWN": "sWA", "sEN": "sEA"}
#: sFA codes that mean "this device has no such telegram" (access denied, unknown method,
#: unknown name, unknown CoLa command).
_NOT_SUPPORTED = frozenset({1, 2, 11, 12})
#: Clock reads at start, spaced this much apart (an estimate within a second), s.
_FAST_CLOCK_READS, _FAST_CLOCK_PERIOD = 5, 0.1


@dataclass(frozen=True)
class MapStand:
    """Where the vehicle stands for a mapping run: the NAV350 head's pose in the layout frame
    (``x_mm``, ``y_mm``, ``phi_mdeg``), and how many scans the device averages (``mean``,
    1..127; at 8 scans a second, 50 take about 6 s)."""

    x_mm: int
    y_mm: int
    phi_mdeg: int
    mean: int = 50


@dataclass(frozen=True)
class Nav350Settings:
    """How the host talks to the NAV350. Times in s."""

    dialect: str = BINARY
    """CoLa dialect of the requests (``binary`` or ``ascii``)."""
    access_level: int = 3
    password: int = tg.PASSWORD_CLIENT
    layer: int = 0
    """Layer to navigate on (and to read, write or map)."""
    read_layout: bool = True
    """Read the device's stored layout of ``layer`` into the log (nothing is written)."""
    write_layout: tuple[LayoutLandmark, ...] = ()
    """Landmarks to write as the device's layout of ``layer``, erasing the stored one: once
    per session object (one recording), never again after a reconnect. Empty: nothing is
    written."""
    map_at: MapStand | None = None
    """Run the device's mapping once from this stand (the vehicle still) and report the
    landmarks found; None: no mapping."""
    mask: int = 2
    """mNPOSGetData mask (2: pose, landmarks and scan, as the vendor driver asks)."""
    reply_timeout: float = 1.0
    silent_after: int = 3
    restart_after: int = 5
    """Failed pose requests in a row (sFA, errorCode other than 0 and 4) before the start-up
    sequence runs again."""
    clock_period: float = 1.0
    """How often the clock is read in the navigation loop, s."""
    clock_tries: int = 3
    """Failed clock reads per device session before the clock read is given up for it."""
    speed_input: bool = False
    """Send mNPOSSetSpeed after every pose."""
    speed_max_age: float = 0.5
    """Odometry older than this is not sent, s."""
    retry_initial: float = 0.5
    retry_max: float = 5.0

    def applied(self) -> JSONObject:
        """The settings that shape the device's behaviour, JSON-able (log metadata)."""
        return {"dialect": self.dialect, "access_level": self.access_level,
                "layer": self.layer, "layout_read": self.read_layout,
                "layout_written": len(self.write_layout),
                "map_at": None if self.map_at is None else [
                    self.map_at.x_mm, self.map_at.y_mm, self.map_at.phi_mdeg],
                "mask": self.mask, "clock_period_s": self.clock_period,
                "speed_input": "mNPOSSetSpeed" if self.speed_input else None}


@dataclass(frozen=True)
class PoseDataReceived:
    """A pose-data reply: written at ``sent``, read at ``received`` (host s)."""

    data: PoseData
    sent: float
    received: float


@dataclass(frozen=True)
class Identity:
    """The identity reads that were answered: name -> value."""

    values: dict[str, str]


@dataclass(frozen=True)
class LayoutRead:
    """The device's stored layout of ``layer`` as read (``when``: ``before`` a write or the
    only read, ``after`` a write)."""

    layer: int
    landmarks: tuple[StoredLandmark, ...]
    when: str = "before"


@dataclass(frozen=True)
class LayoutWritten:
    """A layout was written into ``layer`` (asked for by name): the global ids the device
    gave, in the order of the landmarks written."""

    layer: int
    ids: tuple[int, ...]


@dataclass(frozen=True)
class MappingDone:
    """The mapping run from ``stand``: the device's errorCode and the landmarks it found
    (``x_mm``, ``y_mm`` in the layout frame, as the device computed them from the stand)."""

    stand: MapStand
    error_code: int
    landmarks: tuple[tuple[int, int], ...]


#: The device confirmed navigation (the NAV350's positioning); ``settings`` lists what was
#: applied.
NavigationEntered = PositioningEntered


@dataclass(frozen=True)
class ClockRead:
    """A clock read: ``tick`` ms between ``sent`` and ``received`` (host s); the estimate
    after it (None until enough reads)."""

    tick: int
    sent: float | None
    received: float
    estimate: ClockEstimate | None


@dataclass(frozen=True)
class SessionFatal:
    """The recording cannot go on with this device (e.g. the login was refused)."""

    message: str


SessionEvent = PoseDataReceived | Identity | LayoutRead | LayoutWritten | MappingDone \
    | NavigationEntered | ClockRead | DeviceSilent | SessionFatal | DecodeEvent


@dataclass
class _Pending:
    step: str
    request: Telegram
    sent_at: float
    timeout: float
    acked: bool = False


class Nav350Session:
    """The host side of one NAV350 link; see the module docstring."""

    def __init__(self, settings: Nav350Settings | None = None) -> None:
        self.settings = settings or Nav350Settings()
        self.decoder = Nav350StreamDecoder()
        self.clock = ClockEstimator()
        self._events: list[SessionEvent] = []
        self._plan: deque[str] = deque()
        self._pending: _Pending | None = None
        self._retry_at = -math.inf
        self._failures = 0
        self._timeouts = 0
        self._pose_failures = 0
        self._next_clock = -math.inf
        self._clock_by_telegram = True
        self._clock_failures = 0
        self._speed = HeadSpeed()
        self._speed_due = False
        self._identity: dict[str, str] = {}
        self._chunks: list[tuple[LayoutLandmark, ...]] = []
        self._added: list[int] = []
        self._layer_ids: tuple[int, ...] = ()
        self._stored: list[StoredLandmark] = []
        #: the layout write and the mapping run are done once per session object
        self.layout_written = False
        self.mapped = False
        self._moving: bool | None = None
        self._waiting_still = False
        self.active = False
        self.navigating = False
        self.silent = False
        #: pose-data replies received, pose requests sent
        self.poses = 0
        self.pose_requests = 0

    # ------------------------------------------------------------------ state
    @property
    def stats(self) -> DecoderStats:
        """Counters of the reply stream (and the request/reply matching)."""
        return self.decoder.stats

    @property
    def state(self) -> str:
        """'idle', 'silent', 'starting' or 'navigating'."""
        if not self.active:
            return "idle"
        if self.silent:
            return "silent"
        return "navigating" if self.navigating else "starting"

    def link_up(self, now: float) -> None:
        """The link is (again) open: a new device session; run the start-up sequence."""
        self.active = True
        self.silent = False
        self._pending = None
        self._timeouts = 0
        self._new_clock_session()
        self._restart()

    def vehicle_moving(self, moving: bool | None) -> None:
        """Whether the vehicle moves now (from the odometry; None: not known). A mapping run
        waits while it moves."""
        self._moving = moving

    def link_down(self, now: float) -> None:
        """The link failed: a telegram cut off by it is counted, the request in flight
        forgotten."""
        self.active = False
        self.navigating = False
        self._pending = None
        self._plan.clear()
        self.decoder.flush()

    def set_speed(self, vx: float, vy: float, omega: float, now: float) -> None:
        """Latest head velocity in the NAV350's frame: vx, vy m/s, omega rad/s, at ``now``."""
        self._speed = HeadSpeed(vx, vy, omega, now)

    # ------------------------------------------------------------------ scheduling
    def next_deadline(self, now: float) -> float:
        """When :meth:`poll` next has work (s)."""
        if not self.active:
            return now + 1.0
        if self._pending is not None:
            return self._pending.sent_at + self._pending.timeout
        if now < self._retry_at:
            return self._retry_at
        return now

    def poll(self, now: float) -> Telegram | None:
        """The telegram to write now, if any (also handles reply timeouts)."""
        if not self.active:
            return None
        p = self._pending
        if p is not None:
            if now - p.sent_at < p.timeout:
                return None
            self._on_timeout(p, now)
        if now < self._retry_at:
            return None
        if self._plan:
            step = self._plan[0]
            if step == "do_mapping" and not self._still_for_mapping():
                return None
            return self._send(step, self._request_for(step), now)
        if not self.navigating:
            return None
        s = self.settings
        if self._speed_due:
            self._speed_due = False
            sp = self._speed
            est = self.clock.estimate
            if s.speed_input and est is not None and now - sp.at <= s.speed_max_age:
                tick = round(est.device_time(sp.at) * 1000.0) & 0xFFFFFFFF
                return self._send("speed", tg.set_speed(_clamp(sp.vx, 32.767),
                                                        _clamp(sp.vy, 32.767),
                                                        _clamp(sp.omega, 2 * math.pi), tick),
                                  now)
        if self._clock_by_telegram and now >= self._next_clock:
            fast = self.clock.reads < _FAST_CLOCK_READS
            self._next_clock = now + (_FAST_CLOCK_PERIOD if fast else s.clock_period)
            return self._send("clock", tg.request("sMN", "mNAVGetTimestamp"), now)
        self.pose_requests += 1
        return self._send("pose", tg.get_pose_data(1, s.mask), now)

    def feed(self, data: bytes, now: float) -> None:
        """Bytes read from the device at ``now``. A corrupt telegram while a request waits is
        taken for its reply: the request is sent again at once instead of timing out."""
        st = self.decoder.stats
        corrupt = st.bad_checksum + st.bad_length
        for telegram in self.decoder.feed(data):
            self._on_telegram(telegram, now)
        p = self._pending
        if p is None or st.bad_checksum + st.bad_length == corrupt:
            return
        if p.step in ("pose", "speed"):
            self._pending = None
            self._diag("reply_corrupt", f"the reply to {p.request.kind} {p.request.name} "
                       "was corrupt: asking again", level=WARNING, step=p.step)
        elif p.step == "clock":
            self._pending = None
            self._clock_failed("its reply could not be read")
        elif p.step == "do_mapping":
            self._pending = None
            self._plan.popleft()
            self._mapping_failed(-1, "the mapping reply could not be read")

    def pop_events(self) -> list[SessionEvent]:
        """Decoder events, then the session's own, oldest first."""
        out: list[SessionEvent] = list(self.decoder.pop_events())
        out.extend(self._events)
        self._events = []
        return out

    # ------------------------------------------------------------------ internals
    def _diag(self, kind: str, message: str, level: int = WARNING, **details: JSON) -> None:
        self._events.append(DecodeEvent("nav350", kind, message, level, 1, details))

    def _new_clock_session(self) -> None:
        """A new device session (its clock starts again): the clock read is tried anew."""
        self._clock_by_telegram = True
        self._clock_failures = 0

    def _restart(self) -> None:
        self.navigating = False
        s = self.settings
        plan = ["login", "cola", "id:FirmwareVersion", "id:SerialNumber", "id:LocationName",
                "standby"]
        if s.read_layout or (s.write_layout and not self.layout_written):
            plan += ["layer_ids"]
        if s.write_layout and not self.layout_written:
            if len(s.write_layout) < MIN_LAYOUT:
                self._diag("layout_not_written", f"the layout to write has "
                           f"{len(s.write_layout)} landmarks; the NAV350 needs at least "
                           f"{MIN_LAYOUT}: nothing is written", level=ERROR,
                           landmarks=len(s.write_layout))
                self.layout_written = True
            else:
                self._chunks = [s.write_layout[i:i + ADD_CHUNK]
                                for i in range(0, len(s.write_layout), ADD_CHUNK)]
                self._added = []
                plan += ["erase", "mapping"] + [f"add:{i}" for i in range(len(self._chunks))]
                plan += ["store", "standby", "layer_ids_after"]
        if s.map_at is not None and not self.mapped:
            plan += ["layer", "map_cfg", "mapping", "do_mapping", "standby"]
        plan += ["layer", "fmt:0", "fmt:1", "fmt:2", "navigate"]
        self._plan = deque(plan)

    def _still_for_mapping(self) -> bool:
        """True when the mapping request may go: the vehicle is not known to move (a
        diagnostic says once that the run waits while it moves)."""
        if self._moving:
            if not self._waiting_still:
                self._waiting_still = True
                self._diag("mapping_waits", "the vehicle moves: the mapping run waits until "
                           "it stands still", level=WARNING)
            return False
        if self._waiting_still:
            self._waiting_still = False
            self._diag("mapping_resumes", "the vehicle stands still: mapping", level=INFO)
        elif self._moving is None:
            self._diag("mapping_unchecked", "no odometry: the mapping run cannot check that "
                       "the vehicle stands still (record --mcu checks it)", level=WARNING)
        return True

    def _request_for(self, step: str) -> Telegram:
        s = self.settings
        if step == "login":
            return tg.set_access_mode(s.access_level, s.password)
        if step == "cola":
            return tg.request("sWN", "EIHstCola", 1 if s.dialect == BINARY else 0)
        if step in ("layer_ids", "layer_ids_after"):
            return tg.get_layer(s.layer)
        if step.startswith("get:") or step.startswith("got:"):
            chunk = int(step[4:])
            return tg.get_landmarks(self._layer_ids[chunk * ADD_CHUNK:(chunk + 1) * ADD_CHUNK])
        if step == "map_cfg":
            m = s.map_at
            assert m is not None
            return tg.map_config(m.mean, 0, m.x_mm, m.y_mm, m.phi_mdeg)
        if step == "do_mapping":
            return tg.do_mapping()
        if step.startswith("id:"):
            return tg.request("sRN", step[3:])
        if step == "standby":
            return tg.change_state(tg.MODE_STANDBY)
        if step == "mapping":
            return tg.change_state(tg.MODE_MAPPING)
        if step == "navigate":
            return tg.change_state(tg.MODE_NAVIGATION)
        if step == "erase":
            return tg.request("sMN", "mNLAYEraseLayout", 1)
        if step.startswith("add:"):
            return tg.add_landmarks(self._chunks[int(step[4:])])
        if step == "store":
            return tg.request("sMN", "mNLAYStoreLayout")
        if step == "layer":
            return tg.current_layer(s.layer)
        if step.startswith("fmt:"):
            return tg.data_formats()[int(step[4:])]
        raise ValueError(f"unknown session step {step!r}")

    def _send(self, step: str, request: Telegram, now: float) -> Telegram:
        request = Telegram(request.kind, request.name, request.value, self.settings.dialect)
        timeout = self.settings.reply_timeout
        if step == "do_mapping" and self.settings.map_at is not None:
            # the device averages ``mean`` scans at up to 8 a second before it answers
            timeout = max(timeout, 1.5 * self.settings.map_at.mean / 8.0 + 2.0)
        self._pending = _Pending(step, request, now, timeout)
        return request

    def _backoff(self, now: float) -> None:
        self._failures += 1
        s = self.settings
        self._retry_at = now + min(s.retry_max, s.retry_initial * 2 ** (self._failures - 1))

    def _on_timeout(self, p: _Pending, now: float) -> None:
        self._pending = None
        self._timeouts += 1
        if p.step == "pose":
            self._pose_failures += 1
        if p.step == "clock":
            self._clock_failed("no reply", report=False)
        self._diag("reply_timeout", f"no reply to {p.request.kind} {p.request.name} within "
                   f"{self.settings.reply_timeout:g} s", level=WARNING, step=p.step,
                   timeouts_in_a_row=self._timeouts)
        if self._timeouts >= self.settings.silent_after and not self.silent:
            self.silent = True
            self._events.append(DeviceSilent(self._timeouts))
            return
        if p.step.startswith("id:") or p.step == "cola":
            self._plan.popleft()
        elif p.step == "do_mapping":
            self._plan.popleft()
            self._mapping_failed(-1, "no mapping reply")
        elif not self.navigating:
            self._restart()
            self._backoff(now)

    def _on_telegram(self, t: Telegram, now: float) -> None:
        p = self._pending
        if p is None or not self._answers(t, p):
            if t.name == "mNPOSGetData" and isinstance(t.value, PoseData):
                self._events.append(PoseDataReceived(t.value, now, now))  # late, still data
            self.decoder.stats.unexpected_reply += 1
            self._diag("unexpected_reply", f"NAV350 {t.describe()} answers no pending request",
                       level=WARNING, telegram_kind=t.kind, name=t.name)
            return
        if t.kind == "sMA":
            p.acked = True
            return
        self._pending = None
        self._timeouts = 0
        self.silent = False
        if t.is_error:
            self._on_sfa(p, t, now)
            return
        self._on_reply(p, t, now)

    @staticmethod
    def _answers(t: Telegram, p: _Pending) -> bool:
        if t.is_error:
            return True
        if t.kind == "sMA":
            return p.request.kind == "sMN" and t.name == p.request.name
        return t.kind == _REPLY_KIND.get(p.request.kind) and t.name == p.request.name

    def _on_sfa(self, p: _Pending, t: Telegram, now: float) -> None:
        code = int(t.fields[0]) if t.fields else -1
        step = p.step
        what = f"{p.request.kind} {p.request.name}"
        if step == "pose":
            self._pose_failure(now, f"{what} answered {t.describe()}")
            return
        if step == "clock" and code not in _NOT_SUPPORTED:
            self._clock_failed(f"{what} answered {t.describe()}", sopas_error=code)
            return
        if step == "clock":
            self._clock_by_telegram = False
            self._diag("clock_read_refused", f"{what} answered {t.describe()}: the clock is "
                       "estimated from the pose replies' arrival (offset includes the "
                       "device latency)", level=WARNING, sopas_error=code)
            return
        if step == "speed":
            self._diag("speed_refused", f"{what} answered {t.describe()}", sopas_error=code)
            return
        if step.startswith("id:"):
            self._plan.popleft()
            self._diag("identity_unreadable", f"{what} answered {t.describe()}",
                       sopas_error=code)
            self._identity_done()
            return
        if step in ("layer", "fmt:0", "fmt:1", "fmt:2", "cola"):
            self._plan.popleft()
            self._diag("setting_refused", f"{what} answered {t.describe()}", sopas_error=code)
            return
        if step in ("layer_ids", "layer_ids_after") or step.startswith(("get:", "got:")):
            self._layout_unreadable(f"{what} answered {t.describe()}", sopas_error=code)
            return
        if step in ("map_cfg", "do_mapping"):
            self._plan.popleft()
            if step == "map_cfg":  # no mapping without its stand
                self._drop_mapping()
            self._mapping_failed(-1, f"{what} answered {t.describe()}")
            return
        self._diag("start_failed", f"{what} answered {t.describe()}; starting over",
                   level=ERROR, sopas_error=code, step=step)
        self._restart()
        self._backoff(now)

    def _identity_done(self) -> None:
        if not any(s.startswith("id:") for s in self._plan):
            self._events.append(Identity(dict(self._identity)))

    def _on_reply(self, p: _Pending, t: Telegram, now: float) -> None:
        step = p.step
        if step == "pose":
            self._on_pose(p, t, now)
            return
        if step == "clock":
            err, tick = (int(v) for v in t.fields)
            if err != 0:
                self._clock_failed(f"mNAVGetTimestamp errorCode {err} "
                                   f"({ERROR_CODES.get(err, 'unknown')})", error_code=err)
                return
            self._clock_failures = 0
            est = self.clock.add(tick, p.sent_at, now)
            self._events.append(ClockRead(tick, p.sent_at, now, est))
            return
        if step == "speed":
            if t.fields and int(t.fields[0]) != 0:
                code = int(t.fields[0])
                self._diag("speed_refused", f"mNPOSSetSpeed errorCode {code} "
                           f"({ERROR_CODES.get(code, 'unknown')})", error_code=code)
            return
        self._plan.popleft()
        if step == "login":
            if int(t.fields[0]) != 1:
                self._plan.clear()
                self.active = False
                self._events.append(SessionFatal(
                    f"the NAV350 refused the login (access level {self.settings.access_level});"
                    " check the device's password"))
            return
        if step.startswith("id:"):
            self._identity[step[3:]] = " ".join(str(v) for v in t.fields)
            self._identity_done()
            return
        if step in ("standby", "mapping", "navigate"):
            want = {"standby": tg.MODE_STANDBY, "mapping": tg.MODE_MAPPING,
                    "navigate": tg.MODE_NAVIGATION}[step]
            err, state = (int(v) for v in t.fields)
            if err != 0 or state != want:
                self._diag("mode_refused", f"the NAV350 did not enter {tg.MODES[want]} "
                           f"(errorCode {err}, state {state}); starting over", level=ERROR,
                           error_code=err, state=state, wanted=want)
                self._restart()
                self._backoff(now)
                return
            if step == "navigate":
                self._entered(now)
            return
        if step in ("layer_ids", "layer_ids_after") or step.startswith(("get:", "got:")):
            code = t.value.error_code
            if code != 0:
                self._layout_unreadable(f"{p.request.name} errorCode {code} "
                                        f"({ERROR_CODES.get(code, 'unknown')})",
                                        error_code=code, popped=True)
            elif isinstance(t.value, LayerIds):
                self._on_layer_ids(step, t.value)
            else:
                self._on_landmarks(step, t.value)
            return
        if step == "do_mapping":
            self._on_mapping(t.value)
            return
        if step.startswith("add:"):
            added = t.value
            if added.error_code != 0:
                self._diag("layout_failed", f"mNLAYAddLandmark errorCode {added.error_code} "
                           f"({ERROR_CODES.get(added.error_code, 'unknown')}): the layout is "
                           "not stored and not written again in this recording", level=ERROR,
                           error_code=added.error_code)
                self.layout_written = True
                while self._plan and (self._plan[0].startswith("add:")
                                      or self._plan[0] == "store"):
                    self._plan.popleft()
            else:
                self._added.extend(added.ids)
            return
        if step == "store":
            self.layout_written = True
            self._events.append(LayoutWritten(self.settings.layer, tuple(self._added)))
            return
        # cola, erase, layer, formats, map_cfg: acknowledged

    # ------------------------------------------------------------------ layout and mapping
    def _on_layer_ids(self, step: str, value: LayerIds) -> None:
        self._layer_ids = tuple(value.ids)
        self._stored = []
        prefix = "got:" if step == "layer_ids_after" else "get:"
        chunks = [f"{prefix}{i}" for i in range((len(value.ids) + ADD_CHUNK - 1) // ADD_CHUNK)]
        self._plan.extendleft(reversed(chunks))
        if not chunks:
            self._layout_read(prefix)

    def _on_landmarks(self, step: str, value: StoredLandmarks) -> None:
        self._stored.extend(value.landmarks)
        if not self._plan or not self._plan[0].startswith(step[:4]):
            self._layout_read(step[:4])

    def _layout_read(self, prefix: str) -> None:
        when = "after" if prefix == "got:" else "before"
        self._events.append(LayoutRead(self.settings.layer, tuple(self._stored), when))

    def _layout_unreadable(self, message: str, *, popped: bool = False, **details: JSON) -> None:
        """The stored layout cannot be read: said once, the rest of the read skipped (a
        requested write still goes ahead: it was asked for by name)."""
        if not popped:
            self._plan.popleft()
        while self._plan and self._plan[0].startswith(("get:", "got:")):
            self._plan.popleft()
        self._diag("layout_unreadable", f"the NAV350's stored layout cannot be read: {message}",
                   level=WARNING, **details)

    def _on_mapping(self, value: MappingResult) -> None:
        stand = self.settings.map_at
        assert stand is not None
        marks = tuple(lm.cartesian for lm in (value.landmarks.landmarks if value.landmarks
                                              else ()) if lm.cartesian is not None)
        if value.error_code != 0 or len(marks) < MIN_MAPPED:
            why = (f"errorCode {value.error_code} ({ERROR_CODES.get(value.error_code, 'unknown')})"
                   if value.error_code != 0 else
                   f"{len(marks)} landmarks found, at least {MIN_MAPPED} needed")
            self._mapping_failed(value.error_code, why, landmarks=marks)
            return
        self.mapped = True
        self._events.append(MappingDone(stand, 0, marks))

    def _mapping_failed(self, code: int, why: str,
                        landmarks: tuple[tuple[int, int], ...] = ()) -> None:
        """The mapping run failed: said once, not repeated (navigation goes on)."""
        stand = self.settings.map_at
        assert stand is not None
        self.mapped = True
        self._diag("mapping_failed", f"the NAV350's mapping run failed: {why}", level=ERROR,
                   error_code=code, landmarks=len(landmarks))
        self._events.append(MappingDone(stand, code if code != 0 else -1, landmarks))

    def _drop_mapping(self) -> None:
        while self._plan and self._plan[0] in ("mapping", "do_mapping"):
            self._plan.popleft()

    def _clock_failed(self, why: str, *, report: bool = True, **details: JSON) -> None:
        """A clock read failed; after ``clock_tries`` in this device session the clock read
        is given up for it (said once) and the clock follows the pose replies' arrival."""
        self._clock_failures += 1
        if report:
            self._diag("clock_read_failed", f"NAV350 clock read failed: {why}", level=WARNING,
                       failures=self._clock_failures, **details)
        if self._clock_failures >= self.settings.clock_tries and self._clock_by_telegram:
            self._clock_by_telegram = False
            self._diag("clock_given_up", f"the NAV350's clock read failed "
                       f"{self._clock_failures} times: for this device session the clock is "
                       "estimated from the pose replies' arrival (offset includes the device "
                       "latency)", level=WARNING, failures=self._clock_failures)

    def _entered(self, now: float) -> None:
        self.navigating = True
        self._failures = 0
        self._pose_failures = 0
        self._retry_at = -math.inf
        self._next_clock = now
        self._events.append(NavigationEntered(self.settings.applied()))

    def _on_pose(self, p: _Pending, t: Telegram, now: float) -> None:
        data: PoseData = t.value
        self.poses += 1
        code = data.error_code
        if code == 1:
            self._diag("device_error_code", "mNPOSGetData errorCode 1 (wrong operating mode): "
                       "starting over", level=ERROR, error_code=1)
            self._new_clock_session()  # the device restarted: its clock starts again
            self._restart()
            return
        self._events.append(PoseDataReceived(data, p.sent_at, now))
        if not self._clock_by_telegram and data.info is not None:
            est = self.clock.add(data.info.timestamp_ms, None, now)
            self._events.append(ClockRead(data.info.timestamp_ms, None, now, est))
        self._speed_due = True
        if code == 0:
            self._pose_failures = 0
            return
        self._diag("device_error_code", f"mNPOSGetData errorCode {code} "
                   f"({ERROR_CODES.get(code, 'unknown')})",
                   level=WARNING if code == 4 else ERROR, error_code=code)
        if code != 4:
            self._pose_failure(now, None)

    def _pose_failure(self, now: float, message: str | None) -> None:
        self._pose_failures += 1
        if message is not None:
            self._diag("pose_failed", message, level=WARNING,
                       failures_in_a_row=self._pose_failures)
        if self._pose_failures >= self.settings.restart_after:
            self._pose_failures = 0
            self._diag("navigation_restart", "pose requests keep failing: starting over",
                       level=ERROR)
            self._restart()


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))

