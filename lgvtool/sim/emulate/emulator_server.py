"""The emulator loop: a virtual NAV200 and a virtual MCU on their ports, in real time or faster.

The run's clock starts when every port has a client (or at once), and runs ``speed`` times
faster than the wall clock. Faults are scheduled on the run's clock (s):

=========================  ===========================================================
``drop:DEVICE:AT:FOR``     the port disappears at AT for FOR s (the client's link fails)
``silent:DEVICE:AT:FOR``   the device stays connected but sends nothing for FOR s
``garbage:DEVICE:AT:N``    N random bytes on the line at AT
``reset:nav200:AT``        the NAV200 restarts: back in standby, settings forgotten
``sfa:nav350:AT[:CODE]``   the NAV350 answers the next request with ``sFA CODE``
``error:nav350:AT:FOR[:C]`` NAV350 pose replies carry errorCode C (default 7) for FOR s
``badsum:nav350:AT:N``     the next N NAV350 replies have a wrong checksum
=========================  ===========================================================

DEVICE is ``nav200``, ``nav350``, ``mcu`` or ``all``. Everything the devices sent and received is kept in a
transcript (in memory, and as JSON lines in a file if asked), so a recording can be compared
with it byte for byte.
"""

from __future__ import annotations

import functools
import json
import random
import select
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import IO, TypeGuard

from lgvtool.devices.device_registry import registration
from lgvtool.errors import InputError
from lgvtool.json_types import JSONObject
from lgvtool.sim.emulate.emulator_playback import Playback
from lgvtool.sim.emulate.emulator_registry import Emulator, FamilyEmulation, Pacer, emulations
from lgvtool.sim.emulate.endpoints import PTY_SETTLE, Endpoint, PtyEndpoint, TcpEndpoint
from lgvtool.values import MAX_GARBAGE_BYTES, MAX_SIM_DURATION_S, coerce, parse_scalar

__all__ = ["DEVICES", "EmulatorServer", "Fault", "TranscriptEntry", "parse_fault"]

#: The order in which a fault on ``all`` hits the families (it fixes which garbage bytes each
#: gets); a family not named here follows, in :func:`emulations` order.
DEVICES = ("nav200", "mcu", "nav350")
#: The syntax of each fault kind: its ARG required (True), absent (False) or optional (None).
_KINDS = {"drop": True, "silent": True, "garbage": True, "reset": False, "sfa": None,
          "error": True, "badsum": True}
#: The faults the server applies itself, to any device; the others are the devices' own
#: (their emulators' ``FAULT_KINDS``, the emulations' ``fault_kinds()``).
_GENERIC = ("drop", "silent", "garbage")
#: What follows ``KIND:DEVICE:`` in the usage line, for the devices' own faults.
_SYNTAX = {"reset": "AT", "sfa": "AT[:CODE]", "error": "AT:SECONDS[:CODE]",
           "badsum": "AT:COUNT"}
#: Longest sleep of the loop, s.
_TICK = 0.005
#: With a client on only one port for this long, the run's clock starts anyway, s.
START_GRACE = 2.0


@dataclass(frozen=True)
class Fault:
    """A scheduled fault: ``kind`` on ``device`` at ``at`` s of the run; ``arg`` is a duration
    in s (drop, silent) or a byte count (garbage)."""

    kind: str
    device: str
    at: float
    arg: float = 0.0
    code: int = 0
    """The NAV350 error code of an ``error`` fault (0: the default)."""

    def devices(self) -> tuple[str, ...]:
        """The devices it hits."""
        return _all_devices() if self.device == "all" else (self.device,)


def _all_devices() -> tuple[str, ...]:
    """Every family's device, in the order a fault on ``all`` hits them (:data:`DEVICES`)."""
    names = [e.DEVICE for e in emulations()]
    return (*[d for d in DEVICES if d in names], *[d for d in names if d not in DEVICES])


def _takers(kind: str) -> list[FamilyEmulation]:
    """The emulations whose emulators take the device fault ``kind``, in :func:`emulations`
    order."""
    return [e for e in emulations() if kind in e.fault_kinds()]


def _paces(emulator: Emulator | None) -> TypeGuard[Pacer]:
    """``emulator`` paces the run (a :class:`Pacer`: it has ``next_time()``, and
    ``finished``)."""
    return hasattr(emulator, "next_time")


def _title(emulated: FamilyEmulation) -> str:
    """The emulated device in messages (its family's ``TITLE``: "the NAV200")."""
    return registration(emulated.DEVICE).TITLE


def _joined(words: list[str], last: str) -> str:
    """``a, b and c`` (``last``: the final conjunction)."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} {last} {words[-1]}"


def parse_fault(text: str) -> Fault:
    """Parse ``KIND:DEVICE:AT[:ARG]`` (see the module docstring); InputError if malformed."""
    parts = text.strip().split(":")
    own = [f"{k}:{'|'.join(e.DEVICE for e in _takers(k))}:{_SYNTAX[k]}"
           for k in _KINDS if k not in _GENERIC]
    names = [e.DEVICE for e in emulations()]
    usage = (f"fault {text!r}: expected drop|silent:DEVICE:AT:SECONDS, garbage:DEVICE:AT:BYTES, "
             f"{_joined(own, 'or')} (DEVICE: {', '.join(names)}, all)")
    if len(parts) < 3 or parts[0] not in _KINDS:
        raise InputError(usage)
    kind, device = parts[0], parts[1]
    if device not in (*names, "all"):
        raise InputError(usage)
    takers = [] if kind in _GENERIC else _takers(kind)
    needs_arg = _KINDS[kind]
    allowed = {3, 4} if needs_arg is None else ({4, 5} if kind == "error" else
                                                {4} if needs_arg else {3})
    if len(parts) not in allowed:
        raise InputError(usage)
    if len(takers) == 1 and device != takers[0].DEVICE:
        raise InputError(usage)  # a fault of one family names it
    try:
        at = coerce(f"fault {text!r}: AT", parse_scalar(parts[2], float), float, minimum=0.0,
                    maximum=MAX_SIM_DURATION_S)
        top = MAX_GARBAGE_BYTES if kind == "garbage" else MAX_SIM_DURATION_S
        arg = coerce(f"fault {text!r}: {'BYTES' if kind == 'garbage' else 'SECONDS'}",
                     parse_scalar(parts[3], float), float, minimum=0.0, maximum=top,
                     min_open=bool(needs_arg)) if len(parts) > 3 else 0.0
        code = int(parts[4]) if len(parts) > 4 else 0
    except ValueError:
        raise InputError(usage) from None
    if not 0 <= code <= 7:
        raise InputError(f"fault {text!r}: CODE must be 0..7")
    if len(takers) > 1 and device not in (*(e.DEVICE for e in takers), "all"):
        who = _joined([_title(e) for e in takers], "and")
        raise InputError(f"fault {text!r}: only {who} can "
                         f"{'be reset' if kind == 'reset' else f'take {kind} faults'}")
    return Fault(kind, device, at, arg, code)


@dataclass(frozen=True)
class TranscriptEntry:
    """Bytes a device sent or received: host time ns, run time s, device, direction."""

    t_ns: int
    t: float
    device: str
    direction: str
    data: bytes


class EmulatorServer:
    """Serve a :class:`Playback` as a virtual NAV200 and a virtual MCU.

    :param ports: by the parameter of each family's port option (``SERVE_OPTION.param`` of its
        emulation, :mod:`~lgvtool.sim.emulate.emulator_registry`: ``nav``: the NAV200,
        ``nav350``, ``mcu``), where its device listens: ``"pty"``, ``"tcp://HOST:PORT"`` (port
        0: any free port) or None (not served); an unnamed family gets its option's default
        (the NAV200 and the MCU ``"pty"``, the NAV350 None).
    :param link_dir: where the pseudo-terminal links go (default: a new temporary folder).
    :param speed: run-clock seconds per wall-clock second.
    :param faults: scheduled faults.
    :param wait: start the run's clock once every port has a client (or one has had a client
        for :data:`START_GRACE` s); else at once.
    :param loop: play the run over and over.
    :param transcript: also write the transcript as JSON lines to this file.
    :param seed: seed of the garbage bytes.
    """

    def __init__(self, playback: Playback, *, link_dir: str | Path | None = None,
                 speed: float = 1.0, faults: tuple[Fault, ...] | list[Fault] = (),
                 wait: bool = True, loop: bool = False, transcript: str | Path | None = None,
                 seed: int = 0, **ports: str | None) -> None:
        if not speed > 0:
            raise InputError(f"speed must be positive, got {speed}")
        regs = emulations()
        unknown = set(ports) - {e.SERVE_OPTION.param for e in regs}
        if unknown:
            raise TypeError(f"EmulatorServer: no device family serves {', '.join(sorted(unknown))}")
        specs = {e.DEVICE: ports.get(e.SERVE_OPTION.param, e.SERVE_OPTION.served_at)
                 for e in regs}
        if all(spec is None for spec in specs.values()):
            *first, last = [_title(e) for e in regs]
            raise InputError(f"serve: at least one of {', '.join(first)} and {last} must be "
                             f"served")
        self.playback = playback
        self.speed = float(speed)
        self.wait = wait
        self.faults = sorted(faults, key=lambda f: f.at)
        # the devices, made by their families' emulations
        self.emulators: dict[str, Emulator | None] = {}
        for e in regs:
            specs[e.DEVICE], self.emulators[e.DEVICE] = e.serve_emulator(
                playback, specs[e.DEVICE], loop=loop)
        #: the emulators that pace the run (their ``finished`` and ``next_time()``)
        self._pacers: list[Pacer] = [e for e in self.emulators.values() if _paces(e)]
        self._rng = random.Random(seed)
        self._own_dir: Path | None = None
        self._file: IO[str] | None = None
        self.endpoints: dict[str, Endpoint] = {}
        titles = {e.DEVICE: _title(e) for e in regs}
        named = [(titles[name], listen) for name, listen in specs.items()
                 if listen is not None and listen != "pty" and not listen.endswith(":0")]
        for i, (who, where) in enumerate(named):
            for other, where2 in named[i + 1:]:
                if where == where2:
                    raise InputError(f"serve: {who} and {other} cannot both listen on {where}")
        if link_dir is None and "pty" in specs.values():
            self._own_dir = Path(tempfile.mkdtemp(prefix="lgvtool-serve-"))
        self.link_dir = Path(link_dir) if link_dir is not None else self._own_dir
        try:
            for name, spec in specs.items():
                if spec is not None:
                    self.endpoints[name] = self._endpoint(name, spec)
            if transcript is not None:
                try:
                    self._file = open(transcript, "w", encoding="utf-8")  # noqa: SIM115 - closed in close()
                except OSError as exc:
                    raise InputError(f"serve: cannot write the transcript {transcript}: "
                                     f"{exc.strerror}") from None
        except BaseException:
            self.close()
            raise
        self.transcript: list[TranscriptEntry] = []
        self._silent_until: dict[str, float] = {}
        self._restore_at: dict[str, float] = {}
        self._next_fault = 0
        self._start: float | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        #: set once the whole run has been played (never when looping)
        self.finished = threading.Event()
        #: faults applied so far: (run time s, fault)
        self.applied: list[tuple[float, Fault]] = []

    def _endpoint(self, name: str, spec: str) -> Endpoint:
        if spec == "pty":
            assert self.link_dir is not None
            try:
                # the NAV200 only answers requests, so it may answer at once
                return PtyEndpoint(name, self.link_dir,
                                   settle=0.0 if name == "nav200" else PTY_SETTLE)
            except OSError as exc:
                raise InputError(f"{name}: cannot create a pseudo-terminal link in "
                                 f"{self.link_dir}: {exc.strerror or exc}") from None
        if spec.startswith("tcp://"):
            host, _, port = spec[len("tcp://"):].rpartition(":")
            if not host or not port.isdigit() or not 0 <= int(port) <= 65535:
                raise InputError(f"{name}: expected tcp://HOST:PORT with a port 0-65535, "
                                 f"got {spec!r}")
            try:
                return TcpEndpoint(name, host.strip("[]"), int(port))
            except OSError as exc:
                reason = exc.strerror or str(exc)
                raise InputError(f"{name}: cannot listen on {spec}: {reason}") from None
        raise InputError(f"{name}: expected 'pty' or tcp://HOST:PORT, got {spec!r}")

    # ------------------------------------------------------------------ public
    @property
    def urls(self) -> dict[str, str]:
        """The URL of each served device, for ``lgvtool record --nav URL --mcu URL``."""
        return {name: ep.url for name, ep in self.endpoints.items()}

    def run_time(self, now: float | None = None) -> float | None:
        """The run's clock, s (None before it started)."""
        if self._start is None:
            return None
        return ((time.monotonic() if now is None else now) - self._start) * self.speed

    def sent(self, device: str) -> bytes:
        """Every byte ``device`` wrote to its client(s), in order."""
        with self._lock:
            return b"".join(e.data for e in self.transcript
                            if e.device == device and e.direction == "sent")

    def received(self, device: str) -> bytes:
        """Every byte ``device`` received from its client(s), in order."""
        with self._lock:
            return b"".join(e.data for e in self.transcript
                            if e.device == device and e.direction == "received")

    def start(self) -> EmulatorServer:
        """Run the loop in a background thread; returns self."""
        self._thread = threading.Thread(target=self.run, name="emulator", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """End the loop (and join its thread) and release the ports."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
        self.close()

    def close(self) -> None:
        """Release ports, links and the transcript file."""
        for ep in self.endpoints.values():
            ep.close()
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._own_dir is not None:
            for p in self._own_dir.glob("*"):
                p.unlink(missing_ok=True)
            self._own_dir.rmdir()
            self._own_dir = None

    def __enter__(self) -> EmulatorServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ loop
    def run(self, *, until: float | None = None) -> None:
        """Serve until :meth:`stop` (or ``until`` s of wall time after the run has ended)."""
        ended_at: float | None = None
        while not self._stop.is_set():
            now = time.monotonic()
            self._step(now)
            if self.finished.is_set() and until is not None:
                ended_at = ended_at if ended_at is not None else now
                if now - ended_at >= until:
                    break
            self._wait(now)

    def request_stop(self) -> None:
        """Ask the loop to end (safe from a signal handler)."""
        self._stop.set()

    def _step(self, now: float) -> None:
        for ep in self.endpoints.values():
            ep.service(now)
        if self._start is None and self._may_start(now):
            self._start = now
        t = self.run_time(now)
        if t is not None:
            self._apply_faults(t, now)
        for name, emulator in self.emulators.items():
            if emulator is not None:
                emulator.serve(self.endpoints.get(name), now, t, self._logger(name, t),
                               functools.partial(self._silent, name, t))
        if t is not None and all(e.finished for e in self._pacers) \
                and t >= self.playback.duration:
            self.finished.set()

    def _may_start(self, now: float) -> bool:
        """Start the clock at once, or when every port has a client, or when one has had a
        client for START_GRACE s (a recorder that serves only one of the devices)."""
        if not self.wait:
            return True
        eps = self.endpoints.values()
        if all(ep.ready(now) for ep in eps):
            return True
        return any(ep.connected_at is not None and now - ep.connected_at >= START_GRACE
                   for ep in eps)

    def _wait(self, now: float) -> None:
        timeout = _TICK
        times = [x for e in self._pacers if (x := e.next_time()) is not None]
        nxt = min(times) if times else None
        if nxt is not None and self._start is not None:
            timeout = max(0.0, min(timeout, self._start + nxt / self.speed - now))
        fds = [fd for ep in self.endpoints.values() if (fd := ep.fileno()) is not None]
        if fds:
            select.select(fds, [], [], timeout)
        else:
            self._stop.wait(timeout)

    def _log(self, device: str, direction: str, data: bytes, t: float | None) -> None:
        entry = TranscriptEntry(time.time_ns(), -1.0 if t is None else t, device, direction,
                                data)
        with self._lock:
            self.transcript.append(entry)
        if self._file is not None:
            self._file.write(json.dumps({"t_ns": entry.t_ns, "t": round(entry.t, 6),
                                         "device": device, "direction": direction,
                                         "hex": data.hex()}) + "\n")
            self._file.flush()

    def _silent(self, device: str, t: float | None) -> bool:
        return t is not None and t < self._silent_until.get(device, -1.0)

    def _logger(self, device: str, t: float | None) -> Callable[[str, bytes], None]:
        """``log(direction, data)`` of ``device``'s traffic at run time ``t`` s."""
        def log(direction: str, data: bytes) -> None:
            self._log(device, direction, data, t)
        return log

    def _apply_faults(self, t: float, now: float) -> None:
        for device, at in list(self._restore_at.items()):
            if t >= at:
                del self._restore_at[device]
                self.endpoints[device].restore()
        while self._next_fault < len(self.faults) and self.faults[self._next_fault].at <= t:
            fault = self.faults[self._next_fault]
            self._next_fault += 1
            self.applied.append((t, fault))
            for device in fault.devices():
                ep = self.endpoints.get(device)
                if ep is None:
                    continue
                self._apply(fault, device, ep, t, now)

    def _apply(self, fault: Fault, device: str, ep: Endpoint, t: float, now: float) -> None:
        if fault.kind == "drop":
            ep.drop()
            self._restore_at[device] = fault.at + fault.arg
        elif fault.kind == "silent":
            self._silent_until[device] = fault.at + fault.arg
        elif fault.kind == "garbage":
            junk = bytes(self._rng.randrange(256) for _ in range(int(fault.arg)))
            if ep.write(junk, now):
                self._log(device, "sent", junk, t)
        else:
            emulator = self.emulators.get(device)
            if emulator is not None and fault.kind in emulator.FAULT_KINDS:
                emulator.apply_fault(fault.kind, t, fault.arg, fault.code)

    def status(self) -> JSONObject:
        """Counts for people: run time (s), bytes each way, connections, faults applied."""
        out: JSONObject = {"run_time_s": self.run_time(), "faults": len(self.applied)}
        for name, ep in self.endpoints.items():
            out[name] = {"sent_bytes": len(self.sent(name)),
                         "received_bytes": len(self.received(name)),
                         "connections": ep.connections}
        return out
