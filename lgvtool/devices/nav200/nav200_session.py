"""The NAV200 host state machine of a recording: start-up sequence, pose polling, recovery.

Pure apart from the numbers it is given: the caller passes the time (monotonic s) to every
call, writes the requests that :meth:`Nav200Session.poll` returns, feeds the bytes it reads
to :meth:`Nav200Session.feed`, and collects :meth:`Nav200Session.pop_events`. So the whole
behaviour (timeouts, error replies, a device reset, silence and backoff) is testable with
bytes and made-up times, without a serial port.

Sequence (the player driver's order; docs/recording.md)::

    SA                  standby
    SV, SS              software version, serial number (device identity)
    UA, UR x n, SA      upload the stored reflector map of one layer, back to standby
    [DA, DR x n, DR end, SA, then UA, UR x n, SA]
                        only with ``write_layout``, once per session object (one recording):
                        download a layout into the layer (replacing it), then read it back
    PN n  (or PA)       enter positioning, with a sliding mean over n poses if configured
    PO rmin rmax        action radii, if configured
    PC n                use the n nearest reflectors, if configured
    PP / Pw ...         poll the pose every ``poll_period`` s (Pw: with speed input)

Recovery: a pose request answered by an error reply saying the device is not positioning
(a device reset puts it in standby), or ``silent_after`` reply timeouts in a row, restart the
sequence (identity again, and the map read again and compared with the one held:
a ``map_verified`` or ``map_changed`` diagnostic) and so lead back into positioning;
retries back off from ``retry_initial`` to ``retry_max`` s while the device
stays silent.

Bounded per device session (a device session starts each time the link is opened, or reopened
after the device fell silent): positioning is re-entered after refused pose requests at most
``resume_tries`` times in a row without a pose accepted in between, then no more (one
``positioning_given_up`` diagnostic; polling goes on, and an accepted pose re-arms it); a Pw
(speed input) refused ``speed_input_tries`` times in a row gives speed input up (one
``speed_input_given_up`` diagnostic; PP from then on). Without these bounds a NAV200 that
refuses the pose request (e.g. a firmware without Pw) was taken through the whole sequence,
the map upload included, again and again without a pause, and no pose was ever recorded.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from lgvtool.devices.head_speed import HeadSpeed
from lgvtool.devices.nav200.nav200_commands import ErrorReply, Reply, Request
from lgvtool.devices.nav200.nav200_matcher import Nav200ReplyMatcher
from lgvtool.devices.nav200.nav200_payloads import Pose, ReflectorPosition, SerialNumber, Version
from lgvtool.devices.nav200.nav200_requests import (
    DOWNLOAD_END_NUMBER,
    request_action_radii,
    request_download_end,
    request_download_mode,
    request_download_reflector,
    request_nearest_reflectors,
    request_pose,
    request_pose_with_speed,
    request_positioning_mean,
    request_positioning_mode,
    request_serial_number,
    request_standby,
    request_upload_mode,
    request_upload_next,
    request_version,
)
from lgvtool.devices.session_events import DeviceSilent, PositioningEntered
from lgvtool.json_types import JSON, JSONObject
from lgvtool.wire.decode_events import ERROR, INFO, WARNING, DecodeEvent, DecoderStats
from lgvtool.wire.units import OMEGA_UNITS_PER_RAD_S

__all__ = [
    "DeviceIdentity",
    "MapUploaded",
    "Nav200Session",
    "Nav200Settings",
    "PoseReceived",
    "SessionEvent",
]

#: F2 group "positioning" of an error reply.
GROUP_POSITIONING = 7
#: F3 details that mean "this command is not possible in the device's present mode".
_NOT_NOW_DETAILS = frozenset({1, 3, 7})
#: F3 details that end an upload normally (all transferred, none in layer, not available,
#: wrong number).
_UPLOAD_END_DETAILS = frozenset({10, 9, 4, 5})
#: Largest speed a Pv/Pw/PV field carries (int16 mm/s), m/s.
_SPEED_LIMIT = 32.767


@dataclass(frozen=True)
class Nav200Settings:
    """How the host talks to the NAV200. Times in s, lengths in m."""

    poll_period: float = 0.45
    """Pose request period, s (the paper polls every 450 ms)."""
    reply_timeout: float = 1.0
    """How long to wait for a reply before giving up on a request, s."""
    silent_after: int = 3
    """Reply timeouts in a row after which the device counts as silent."""
    layer: int = 0
    """Reflector layer to upload."""
    sliding_mean: int | None = None
    """PN n: enter positioning with a sliding mean over n poses; None: plain PA."""
    action_radii: tuple[float, float] | None = None
    """PO: minimum and maximum action radius, m; None: leave the device's setting."""
    nearest_reflectors: int | None = None
    """PC: use the N nearest reflectors; None: leave the device's setting."""
    upload_map: bool = True
    """Upload the stored reflector map at start (UA/UR)."""
    write_layout: tuple[tuple[int, float, float], ...] = ()
    """Reflectors to download into ``layer`` (number, x m, y m), replacing its stored map:
    once per session object (one recording), never again after a reconnect, with the map
    uploaded before and after. Empty: nothing is written."""
    max_upload: int = 255
    """Upper bound of UR requests in one upload."""
    speed_input: bool = False
    """Poll with Pw (vehicle-frame speed and yaw rate of the head) instead of PP."""
    omega_scale: float = OMEGA_UNITS_PER_RAD_S
    """Pw yaw-rate units per rad/s (default 32768/pi: 65536 per revolution per second)."""
    speed_max_age: float = 0.5
    """Odometry older than this is not sent as speed input (PP instead), s."""
    pose_errors_before_resume: int = 3
    """Error replies in a row to pose requests (of a kind that does not say "wrong mode")
    before re-entering positioning anyway."""
    resume_tries: int = 3
    """Re-entries of positioning after refused pose requests, in a row without a pose accepted
    in between, per device session; then positioning is not re-entered again in that device
    session (one ``positioning_given_up`` diagnostic), polling goes on. An accepted pose, or a
    new device session (the link opened again), re-arms it."""
    speed_input_tries: int = 3
    """Pw requests refused in a row, per device session, before speed input is given up for
    that device session (PP from then on; one ``speed_input_given_up`` diagnostic)."""
    retry_initial: float = 0.5
    """First retry delay after the device fell silent or a start-up step failed, s."""
    retry_max: float = 5.0
    """Largest retry delay, s."""

    def applied(self) -> JSONObject:
        """The settings that shape the device's behaviour, JSON-able (for log metadata)."""
        return {
            "layer": self.layer,
            "sliding_mean": self.sliding_mean,
            "action_radii_m": list(self.action_radii) if self.action_radii else None,
            "nearest_reflectors": self.nearest_reflectors,
            "poll_period_s": self.poll_period,
            "layout_written": len(self.write_layout),
            "speed_input": "Pw" if self.speed_input else None,
            "omega_units_per_rad_s": self.omega_scale if self.speed_input else None,
        }


@dataclass(frozen=True)
class PoseReceived:
    """A pose reply. ``round_trip`` from request written to reply decoded, s."""

    pose: Pose
    request_code: str
    round_trip: float


@dataclass(frozen=True)
class DeviceIdentity:
    """Version (``a.b.c``, None if unreadable) and serial number (None if unreadable)."""

    version: str | None
    serial: int | None


@dataclass(frozen=True)
class MapUploaded:
    """The stored reflectors of ``layer``, as uploaded (raw mm, see ReflectorPosition)."""

    layer: int
    reflectors: tuple[ReflectorPosition, ...]


SessionEvent = PoseReceived | DeviceIdentity | MapUploaded | PositioningEntered | DeviceSilent \
    | DecodeEvent


@dataclass
class _Pending:
    step: str
    request: Request
    sent_at: float


@dataclass
class _Upload:
    seen: set[int] = field(default_factory=set)
    items: list[ReflectorPosition] = field(default_factory=list)


class Nav200Session:
    """The host side of one NAV200 link. See the module docstring for the sequence.

    Call :meth:`start` (or :meth:`link_up`) once the link is open, then repeatedly
    :meth:`poll` (send what it returns) and :meth:`feed` (bytes read), and
    :meth:`pop_events`. :meth:`next_deadline` tells when :meth:`poll` has work to do.
    """

    def __init__(self, settings: Nav200Settings | None = None) -> None:
        self.settings = settings or Nav200Settings()
        self._host = Nav200ReplyMatcher()
        self._events: list[SessionEvent] = []
        self._plan: deque[str] = deque()
        #: the requested layout write is done once per session object
        self.layout_written = False
        self._pending: _Pending | None = None
        self._retry_at = -math.inf
        self._failures = 0
        self._timeouts = 0
        self._pose_errors = 0
        self._silent_since: float | None = None
        self._last_reply: float | None = None
        self._suppressed = 0
        self._next_poll = -math.inf
        self._speed = HeadSpeed()
        self._upload = _Upload()
        self._use_pa = self.settings.sliding_mean is None
        self._entered_with = ""
        self._verify_map = False
        # per device session (see link_up): re-entries of positioning without a pose since,
        # refused Pw requests in a row, and what was given up
        self._resumes = 0
        self._resume_given_up = False
        self._pw_refusals = 0
        self._pw_given_up = False
        #: True between the device confirming positioning and losing it
        self.positioning = False
        #: True while the link is up and the session is working
        self.active = False
        #: (version, serial) as last read
        self.version: str | None = None
        self.serial: int | None = None
        #: the uploaded map, once an upload finished
        self.map: tuple[ReflectorPosition, ...] | None = None
        #: poses received, pose requests sent
        self.poses = 0
        self.pose_requests = 0

    # ------------------------------------------------------------------ state
    @property
    def stats(self) -> DecoderStats:
        """Counters of the reply stream and the request/reply matching."""
        return self._host.stats

    @property
    def state(self) -> str:
        """'idle' (no link), 'silent', 'starting' (sequence), 'positioning'."""
        if not self.active:
            return "idle"
        if self._silent_since is not None:
            return "silent"
        return "positioning" if self.positioning else "starting"

    @property
    def silent(self) -> bool:
        """True while the device counts as silent."""
        return self._silent_since is not None

    # ------------------------------------------------------------------ link events
    def start(self, now: float) -> None:
        """Begin the full start-up sequence now (link freshly open)."""
        self.link_up(now)

    def link_up(self, now: float) -> None:
        """The link is (again) open: a new device session; run the sequence, honouring a
        pending retry delay. What an earlier device session gave up is tried again."""
        self.active = True
        self._resumes, self._resume_given_up = 0, False
        self._pw_refusals, self._pw_given_up = 0, False
        if self._host.pending is not None:
            self._host.cancel()
        self._pending = None
        self._restart_plan()

    def link_down(self, now: float) -> None:
        """The link failed: forget the request in flight; positioning is unknown."""
        self.active = False
        self.positioning = False
        self._timeouts = 0
        if self._pending is not None:
            self._host.cancel()
            self._pending = None
        self._plan.clear()
        self._host.pop_events()

    def set_speed(self, vx: float, vy: float, omega: float, now: float) -> None:
        """Latest vehicle-frame velocity of the head: vx, vy in m/s, omega in rad/s."""
        self._speed = HeadSpeed(vx, vy, omega, now)

    # ------------------------------------------------------------------ scheduling
    def next_deadline(self, now: float) -> float:
        """The time (s) by which :meth:`poll` should be called again."""
        if not self.active:
            return now + 1.0
        if self._pending is not None:
            return self._pending.sent_at + self.settings.reply_timeout
        if now < self._retry_at:
            return self._retry_at
        if self._plan:
            return now
        if self.positioning:
            return max(now, self._next_poll)
        return now + 1.0

    def poll(self, now: float) -> Request | None:
        """The request to write now, if any (also handles reply timeouts)."""
        if not self.active:
            return None
        if self._pending is not None:
            if now - self._pending.sent_at < self.settings.reply_timeout:
                return None
            self._on_timeout(now)
        if now < self._retry_at:
            return None
        if self._plan:
            step = self._plan[0]
            return self._send(step, self._request_for(step), now)
        if self.positioning and now >= self._next_poll:
            nxt = self._next_poll + self.settings.poll_period
            self._next_poll = nxt if nxt > now else now + self.settings.poll_period
            self.pose_requests += 1
            return self._send("pose", self._pose_request(now), now)
        return None

    def feed(self, data: bytes, now: float) -> None:
        """Bytes read from the device at ``now``."""
        for exchange in self._host.feed(data):
            if exchange.request is None or self._pending is None:
                continue
            pending, self._pending = self._pending, None
            self._on_reply(pending, exchange.reply, now)

    def pop_events(self) -> list[SessionEvent]:
        """Events since the last call, oldest first: decoder/matching diagnostics, then the
        session's own (poses, identity, map, positioning, silence)."""
        out: list[SessionEvent] = []
        for event in self._host.pop_events():
            if self._silent_since is not None and event.kind == "unanswered":
                self._suppressed += 1
                continue
            out.append(event)
        out.extend(self._events)
        self._events = []
        return out

    # ------------------------------------------------------------------ internals
    def _diag(self, kind: str, message: str, level: int = WARNING, **details: JSON) -> None:
        self._events.append(DecodeEvent("nav200", kind, message, level, 1, details))

    def _restart_plan(self) -> None:
        # after a reset or a reconnect the device may hold another map: read it again
        self._verify_map = self.map is not None
        self.positioning = False
        plan = ["standby", "version", "serial"]
        plan += self._enter_steps()
        self._plan = deque(plan)

    def _enter_steps(self) -> list[str]:
        steps = ["enter"]
        if self.settings.action_radii is not None:
            steps.append("radii")
        if self.settings.nearest_reflectors is not None:
            steps.append("nearest")
        return steps

    def _request_for(self, step: str) -> Request:
        s = self.settings
        if step in ("standby", "standby_after_upload", "standby_after_download"):
            return request_standby()
        if step == "download_mode":
            return request_download_mode()
        if step.startswith("download:"):
            number, x, y = s.write_layout[int(step[9:])]
            return request_download_reflector(s.layer, number, x, y)
        if step == "download_end":
            return request_download_end(s.layer)
        if step == "version":
            return request_version()
        if step == "serial":
            return request_serial_number()
        if step == "upload_mode":
            self._upload = _Upload()
            return request_upload_mode()
        if step == "upload_next":
            return request_upload_next(s.layer)
        if step == "enter":
            if self._use_pa or s.sliding_mean is None:
                return request_positioning_mode()
            return request_positioning_mean(s.sliding_mean)
        if step == "radii":
            assert s.action_radii is not None
            return request_action_radii(*s.action_radii)
        if step == "nearest":
            assert s.nearest_reflectors is not None
            return request_nearest_reflectors(s.nearest_reflectors)
        raise ValueError(f"unknown session step {step!r}")

    def _pose_request(self, now: float) -> Request:
        s, sp = self.settings, self._speed
        if not s.speed_input or self._pw_given_up or now - sp.at > s.speed_max_age:
            return request_pose()
        limit = 32767 / s.omega_scale
        return request_pose_with_speed(
            _clamp(sp.vx, _SPEED_LIMIT), _clamp(sp.vy, _SPEED_LIMIT), _clamp(sp.omega, limit),
            omega_scale=s.omega_scale,
        )

    def _send(self, step: str, request: Request, now: float) -> Request:
        self._host.send(request)
        self._pending = _Pending(step, request, now)
        return request

    def _backoff(self, now: float) -> None:
        self._failures += 1
        delay = min(self.settings.retry_max,
                    self.settings.retry_initial * 2 ** (self._failures - 1))
        self._retry_at = now + delay

    def _on_timeout(self, now: float) -> None:
        pending = self._pending
        assert pending is not None
        self._pending = None
        self._host.cancel()
        self._timeouts += 1
        if self._silent_since is not None:
            self._restart_plan()
            self._backoff(now)
            return
        if self._timeouts >= self.settings.silent_after:
            self._silent_since = self._last_reply if self._last_reply is not None else now
            self._suppressed = 0
            self._diag("device_silent",
                       f"NAV200 silent: {self._timeouts} requests unanswered in a row",
                       level=ERROR, timeouts=self._timeouts,
                       reply_timeout_s=self.settings.reply_timeout)
            self._events.append(DeviceSilent(self._timeouts))
            self._restart_plan()
            self._backoff(now)
        # below the threshold: a start-up step is simply sent again (it is still first in
        # the plan); a pose request is superseded by the next poll

    def _on_reply(self, pending: _Pending, reply: Reply | ErrorReply, now: float) -> None:
        if self._silent_since is not None:
            gap = now - self._silent_since
            self._diag("device_back", f"NAV200 answers again after {gap:.1f} s",
                       level=INFO, gap_s=round(gap, 3),
                       unanswered_requests=self._suppressed)
            self._silent_since = None
        self._last_reply = now
        self._timeouts = 0
        if isinstance(reply, ErrorReply):
            self._on_error(pending, reply, now)
            return
        if pending.step == "pose":
            self._pose_errors = 0
            self._failures = 0
            self._resumes, self._resume_given_up = 0, False
            if pending.request.code == "Pw":
                self._pw_refusals = 0
            assert isinstance(reply.payload, Pose)
            self.poses += 1
            self._events.append(PoseReceived(reply.payload, pending.request.code,
                                             now - pending.sent_at))
            return
        self._plan.popleft()
        self._on_step_done(pending.step, reply, now)

    def _on_step_done(self, step: str, reply: Reply, now: float) -> None:
        if step == "version" and isinstance(reply.payload, Version):
            self.version = str(reply.payload)
        elif step == "serial":
            serial = reply.payload.serial if isinstance(reply.payload, SerialNumber) else None
            self._identified(serial)
        elif step == "upload_next":
            self._uploaded_one(reply)
        elif step == "download_mode":
            stored = 0 if self.map is None else len(self.map)
            self._diag("layout_erasing", f"erasing the NAV200's map of layer "
                       f"{self.settings.layer} ({stored} reflectors, uploaded before) to write "
                       f"{len(self.settings.write_layout)}", level=WARNING,
                       layer=self.settings.layer, stored=stored,
                       writing=len(self.settings.write_layout))
        elif step == "download_end":
            self.layout_written = True
            self._diag("layout_written", f"{len(self.settings.write_layout)} reflectors written "
                       f"into the NAV200's layer {self.settings.layer}", level=WARNING,
                       layer=self.settings.layer, reflectors=len(self.settings.write_layout))
        elif step == "enter":
            self._entered_with = "PA" if self._use_pa else "PN"
        if not self._plan:
            self._entered(now)

    def _identified(self, serial: int | None) -> None:
        changed = self.serial is not None and serial is not None and serial != self.serial
        if changed:
            self._diag("device_changed", f"NAV200 serial number changed from {self.serial} "
                       f"to {serial}", level=WARNING, previous_serial=self.serial, serial=serial)
        if serial is not None:
            self.serial = serial
        self._events.append(DeviceIdentity(self.version, serial))
        write = bool(self.settings.write_layout) and not self.layout_written
        steps: list[str] = []
        if self.settings.upload_map and (self.map is None or changed or self._verify_map
                                         or write):
            steps += _UPLOAD_STEPS  # with a write: the map before it
        if write:
            steps += ["download_mode",
                      *[f"download:{i}" for i in range(len(self.settings.write_layout))],
                      "download_end", "standby_after_download", *_UPLOAD_STEPS]
        self._plan = deque(steps + list(self._plan))
        self._verify_map = False

    def _uploaded_one(self, reply: Reply) -> None:
        rp = reply.payload
        up = self._upload
        done = True
        if isinstance(rp, ReflectorPosition) and rp.number != DOWNLOAD_END_NUMBER \
                and rp.number not in up.seen:
            up.seen.add(rp.number)
            up.items.append(rp)
            done = len(up.items) >= self.settings.max_upload
        if done:
            self._finish_upload()
        else:
            self._plan.appendleft("upload_next")

    def _finish_upload(self) -> None:
        previous = self.map
        self.map = tuple(self._upload.items)
        if previous is not None:
            if _positions(previous) == _positions(self.map):
                self._diag("map_verified", f"NAV200 still holds the reflector map "
                           f"({len(self.map)} reflectors)", level=INFO,
                           reflectors=len(self.map))
            else:
                self._diag("map_changed", f"NAV200 reflector map changed: {len(previous)} "
                           f"reflectors before, {len(self.map)} now", level=WARNING,
                           before=len(previous), reflectors=len(self.map))
        self._events.append(MapUploaded(self.settings.layer, self.map))

    def _entered(self, now: float) -> None:
        self.positioning = True
        self._failures = 0
        self._pose_errors = 0
        self._retry_at = -math.inf
        self._next_poll = now
        given_up = {"speed_input_given_up": True} if self._pw_given_up else {}
        self._events.append(PositioningEntered(self.settings.applied()
                                               | {"entered_with": self._entered_with}
                                               | given_up))

    def _on_error(self, pending: _Pending, reply: ErrorReply, now: float) -> None:
        step = pending.step
        if step == "pose":
            self._pose_errors += 1
            if pending.request.code == "Pw" and self._pw_refused(reply):
                self._pose_errors = 0  # the next poll asks with PP
                return
            not_now = reply.detail in _NOT_NOW_DETAILS or reply.group != GROUP_POSITIONING
            if not_now or self._pose_errors >= self.settings.pose_errors_before_resume:
                self._pose_errors = 0
                self._resume(pending, reply)
            return
        if step == "upload_next":
            self._plan.popleft()
            if reply.detail not in _UPLOAD_END_DETAILS:
                self._diag("upload_failed", f"NAV200 map upload stopped: {reply.describe()}",
                           level=WARNING, uploaded=len(self._upload.items))
            self._finish_upload()
            if not self._plan:
                self._entered(now)
            return
        if step == "upload_mode":
            self._diag("upload_failed", f"NAV200 refused upload mode: {reply.describe()}",
                       level=WARNING)
            for s in ("upload_mode", "upload_next", "standby_after_upload"):
                if s in self._plan:
                    self._plan.remove(s)
            self.map = self.map if self.map is not None else ()
            return
        if step == "download_mode" or step.startswith("download"):
            # nothing more is sent of this layout (the device keeps its map unless the end
            # marker went through), never again in this recording; the map is read back
            self.layout_written = True
            self._diag("layout_failed", f"NAV200 {pending.request.code} refused: "
                       f"{reply.describe()}; the layout is not written", level=ERROR,
                       request=pending.request.code)
            while self._plan and self._plan[0].startswith("download"):
                self._plan.popleft()
            return
        if step == "enter" and not self._use_pa:
            self._diag("setting_refused", f"NAV200 refused PN (sliding mean): "
                       f"{reply.describe()}; entering positioning with PA", level=WARNING)
            self._use_pa = True
            return
        if step in ("version", "serial", "radii", "nearest"):
            self._plan.popleft()
            kind = "setting_refused" if step in ("radii", "nearest") else "identity_unreadable"
            self._diag(kind, f"NAV200 {pending.request.code}: {reply.describe()}",
                       level=WARNING, request=pending.request.code)
            if step == "serial":
                self._identified(None)
            if not self._plan:
                self._entered(now)
            return
        # standby or enter (PA) refused: the sequence cannot go on; start over after a pause
        self._diag("start_failed", f"NAV200 {pending.request.code} refused: "
                   f"{reply.describe()}; retrying", level=ERROR, request=pending.request.code)
        self._restart_plan()
        self._backoff(now)

    def _pw_refused(self, reply: ErrorReply) -> bool:
        """A Pw was refused; True when that gives speed input up for this device session."""
        self._pw_refusals += 1
        if self._pw_given_up or self._pw_refusals < self.settings.speed_input_tries:
            return False
        self._pw_given_up = True
        self._diag("speed_input_given_up", f"NAV200 refused Pw {self._pw_refusals} times in a "
                   f"row ({reply.describe()}): poses are polled with PP, without speed input, "
                   "for the rest of this device session", level=WARNING,
                   refusals=self._pw_refusals, error_class=reply.error_class,
                   group=reply.group, detail=reply.detail)
        return True

    def _resume(self, pending: _Pending, reply: ErrorReply) -> None:
        """Pose requests were refused: enter positioning again, unless that was done
        ``resume_tries`` times in a row without a pose (then it is given up, said once)."""
        if self._resume_given_up:
            return
        details: JSONObject = {"request": pending.request.code, "error_class": reply.error_class,
                   "group": reply.group, "detail": reply.detail}
        if self._resumes >= self.settings.resume_tries:
            self._resume_given_up = True
            self._diag("positioning_given_up", f"NAV200 rejected the pose request "
                       f"({reply.describe()}) after entering positioning {self._resumes} times "
                       "in a row without a pose: not entering positioning again in this "
                       "device session; polling goes on", level=ERROR, tries=self._resumes,
                       **details)
            return
        self._resumes += 1
        self._diag("positioning_lost", "NAV200 rejected the pose request "
                   f"({reply.describe()}): entering positioning again", level=WARNING,
                   tries=self._resumes, **details)
        self._restart_plan()


#: the steps of one map upload (UA, UR until the end, SA)
_UPLOAD_STEPS = ["upload_mode", "upload_next", "standby_after_upload"]


def _positions(reflectors: tuple[ReflectorPosition, ...]) -> list[tuple[int, int, int, int]]:
    """Layer, number and raw position of each reflector, sorted: what a map comparison
    compares."""
    return sorted((r.layer, r.number, r.x_mm, r.y_mm) for r in reflectors)


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))
