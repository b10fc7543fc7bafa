"""The NAV350 host state machine of a recording: start-up, the navigation loop, the clock, recovery.

Pure apart from the numbers it is given: the caller passes the host time ``now`` (s, one
monotonic time base) to every call, writes the telegrams :meth:`Nav350Session.poll` returns,
feeds what it reads to :meth:`Nav350Session.feed` and collects :meth:`Nav350Session.pop_events`.

Sequence (the vendor driver's NAV350 block, docs/recording.md)::

    sMN SetAccessMode 3 F4724744         login (refused: the recording stops, one clear line)
    sRN FirmwareVersion, SerialNumber, LocationName      device identity (sFA: skipped)
    sMN mNEVAChangeState 1               standby (sMA, then sAN)
    [sMN mNLAYEraseLayout 1, mNEVAChangeState 2, mNLAYAddLandmark x <=50 ...,
     mNLAYStoreLayout, mNEVAChangeState 1]                upload the configured layout
    sWN NEVACurrLayer L                  the layer to navigate on
    sWN NLMDLandmarkDataFormat 0 1 1, NAVScanDataFormat 1 1, NPOSPoseDataFormat 1 1
    sMN mNEVAChangeState 4               navigation
    sMN mNPOSGetData 1 MASK              repeated: the device answers at its rate (<= 8 Hz)
      + sMN mNAVGetTimestamp every clock_period s (clock offset and drift)
      + sMN mNPOSSetSpeed after every pose, with --speed-input

Recovery: errorCode 1 (wrong mode: the device restarted) or ``restart_after`` failed pose
requests in a row restart the sequence; ``silent_after`` reply timeouts in a row report the
device silent (the caller reopens the link); failed start-up steps retry with backoff.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

from lgvtool.devices.head_speed import HeadSpeed
from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_clock import ClockEstimate, ClockEstimator
from lgvtool.devices.nav350.nav350_cola import BINARY
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.devices.nav350.nav350_telegrams import ERROR_CODES, LayoutLandmark, PoseData, Telegram
from lgvtool.devices.session_events import DeviceSilent, PositioningEntered
from lgvtool.wire.decode_events import ERROR, WARNING, DecodeEvent, DecoderStats

__all__ = [
    "ClockRead",
    "Identity",
    "LayoutUploaded",
    "Nav350Session",
    "Nav350Settings",
    "NavigationEntered",
    "PoseDataReceived",
    "SessionFatal",
]

#: Most landmarks per mNLAYAddLandmark (the vendor driver's chunk).
ADD_CHUNK = 50
#: Fewest landmarks a layout must have to be uploaded.
MIN_LAYOUT = 3
_REPLY_KIND = {"sMN": "sAN", "sRN": "sRA", "sWN": "sWA", "sEN": "sEA"}
#: sFA codes that mean "this device has no such telegram" (access denied, unknown method,
#: unknown name, unknown CoLa command).
_NOT_SUPPORTED = frozenset({1, 2, 11, 12})
#: Clock reads at start, spaced this much apart (an estimate within a second), s.
_FAST_CLOCK_READS, _FAST_CLOCK_PERIOD = 5, 0.1


@dataclass(frozen=True)
class Nav350Settings:
    """How the host talks to the NAV350. Times in s."""

    dialect: str = BINARY
    """CoLa dialect of the requests (``binary`` or ``ascii``)."""
    access_level: int = 3
    password: int = tg.PASSWORD_CLIENT
    layer: int = 0
    """Layer to navigate on (and to upload the layout into)."""
    layout: tuple[LayoutLandmark, ...] = ()
    """Landmarks to upload (empty: keep the device's stored layout)."""
    mask: int = 2
    """mNPOSGetData mask (2: pose, landmarks and scan, as the vendor driver asks)."""
    reply_timeout: float = 1.0
    silent_after: int = 3
    restart_after: int = 5
    """Failed pose requests in a row (sFA, errorCode other than 0 and 4) before the start-up
    sequence runs again."""
    clock_period: float = 1.0
    """How often the clock is read in the navigation loop, s."""
    speed_input: bool = False
    """Send mNPOSSetSpeed after every pose."""
    speed_max_age: float = 0.5
    """Odometry older than this is not sent, s."""
    retry_initial: float = 0.5
    retry_max: float = 5.0

    def applied(self) -> dict[str, Any]:
        """The settings that shape the device's behaviour, JSON-able (log metadata)."""
        return {"dialect": self.dialect, "access_level": self.access_level,
                "layer": self.layer, "layout_uploaded": len(self.layout),
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
class LayoutUploaded:
    """The layout was uploaded into ``layer``: the global ids the device gave."""

    layer: int
    ids: tuple[int, ...]


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


SessionEvent = PoseDataReceived | Identity | LayoutUploaded | NavigationEntered | ClockRead \
    | DeviceSilent | SessionFatal | DecodeEvent


@dataclass
class _Pending:
    step: str
    request: Telegram
    sent_at: float
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
        self._speed = HeadSpeed()
        self._speed_due = False
        self._identity: dict[str, str] = {}
        self._chunks: list[tuple[LayoutLandmark, ...]] = []
        self._added: list[int] = []
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
        """The link is (again) open: run the start-up sequence."""
        self.active = True
        self.silent = False
        self._pending = None
        self._timeouts = 0
        self._restart()

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
            return self._pending.sent_at + self.settings.reply_timeout
        if now < self._retry_at:
            return self._retry_at
        return now

    def poll(self, now: float) -> Telegram | None:
        """The telegram to write now, if any (also handles reply timeouts)."""
        if not self.active:
            return None
        p = self._pending
        if p is not None:
            if now - p.sent_at < self.settings.reply_timeout:
                return None
            self._on_timeout(p, now)
        if now < self._retry_at:
            return None
        if self._plan:
            step = self._plan[0]
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
        if p is not None and st.bad_checksum + st.bad_length > corrupt and p.step in (
                "pose", "clock", "speed"):
            self._pending = None
            self._diag("reply_corrupt", f"the reply to {p.request.kind} {p.request.name} "
                       "was corrupt: asking again", level=WARNING, step=p.step)

    def pop_events(self) -> list[SessionEvent]:
        """Decoder events, then the session's own, oldest first."""
        out: list[SessionEvent] = list(self.decoder.pop_events())
        out.extend(self._events)
        self._events = []
        return out

    # ------------------------------------------------------------------ internals
    def _diag(self, kind: str, message: str, level: int = WARNING, **details: Any) -> None:
        self._events.append(DecodeEvent("nav350", kind, message, level, 1, details))

    def _restart(self) -> None:
        self.navigating = False
        s = self.settings
        plan = ["login", "id:FirmwareVersion", "id:SerialNumber", "id:LocationName", "standby"]
        if s.layout:
            if len(s.layout) < MIN_LAYOUT:
                self._diag("layout_not_uploaded", f"the layout has {len(s.layout)} landmarks; "
                           f"the NAV350 needs at least {MIN_LAYOUT}: its stored one is used",
                           landmarks=len(s.layout))
            else:
                self._chunks = [s.layout[i:i + ADD_CHUNK]
                                for i in range(0, len(s.layout), ADD_CHUNK)]
                self._added = []
                plan += ["erase", "mapping"] + [f"add:{i}" for i in range(len(self._chunks))]
                plan += ["store", "standby"]
        plan += ["layer", "fmt:0", "fmt:1", "fmt:2", "navigate"]
        self._plan = deque(plan)

    def _request_for(self, step: str) -> Telegram:
        s = self.settings
        if step == "login":
            return tg.set_access_mode(s.access_level, s.password)
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
        self._pending = _Pending(step, request, now)
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
        self._diag("reply_timeout", f"no reply to {p.request.kind} {p.request.name} within "
                   f"{self.settings.reply_timeout:g} s", level=WARNING, step=p.step,
                   timeouts_in_a_row=self._timeouts)
        if self._timeouts >= self.settings.silent_after and not self.silent:
            self.silent = True
            self._events.append(DeviceSilent(self._timeouts))
            return
        if p.step.startswith("id:"):
            self._plan.popleft()
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
            self._diag("clock_read_failed", f"{what} answered {t.describe()}",
                       sopas_error=code)
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
        if step in ("layer", "fmt:0", "fmt:1", "fmt:2"):
            self._plan.popleft()
            self._diag("setting_refused", f"{what} answered {t.describe()}", sopas_error=code)
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
            tick = int(t.fields[1])
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
        if step.startswith("add:"):
            added = t.value
            if added.error_code != 0:
                self._diag("layout_failed", f"mNLAYAddLandmark errorCode {added.error_code}",
                           error_code=added.error_code)
                while self._plan and self._plan[0].startswith("add:"):
                    self._plan.popleft()
            else:
                self._added.extend(added.ids)
            return
        if step == "store":
            self._events.append(LayoutUploaded(self.settings.layer, tuple(self._added)))
            return
        # erase, layer, formats: acknowledged

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

