"""Reconnecting with back-off: a link that opens and drops at once, a refused connect, a silent
device's link, and the back-off starting again after a healthy link; and the NAV200 session's
bounded retries of a refused pose request (docs/recording.md, "Reconnecting and back-off").

Real recordings against local TCP servers on 127.0.0.1 that count the connections they accept.
Bounds are generous (a loaded 2-core machine) but far below the old behaviour: tens of
thousands of connections in 10 s to a peer that accepts and closes every connection.
"""

from __future__ import annotations

import select
import socket
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from devices_helpers import circle_playback, diagnostics, messages

from lgvtool.devices import device_links
from lgvtool.devices.link_worker import LinkTiming
from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.nav200.nav200_replies import build_error_reply
from lgvtool.devices.nav200.nav200_session import Nav200Session, Nav200Settings, PoseReceived
from lgvtool.devices.recorder import RecordedDevice, Recorder, RecorderSettings
from lgvtool.log import topics
from lgvtool.sim.emulate.nav200.nav200_emulator import VirtualNav200
from lgvtool.wire.decode_events import DecodeEvent

#: how long each recording against an accept-and-close server runs, s
SECONDS = 3.0
#: the most connections the default back-off (0.2 s doubling to 2 s) allows in SECONDS: at
#: 0, 0.2, 0.6, 1.4, 3.0 s, i.e. 5 (the target: 20 in 10 s)
MOST_CONNECTIONS = 8

Handler = Callable[[int, socket.socket, "Server"], None]


def close_at_once(n: int, conn: socket.socket, server: Server) -> None:
    """Close the connection as soon as it is accepted."""
    conn.close()


def hold_silent(n: int, conn: socket.socket, server: Server) -> None:
    """Keep the connection open and say nothing until the client closes it."""
    with conn:
        while not server.stopping.is_set():
            ready, _, _ = select.select([conn], [], [], 0.05)
            if ready and not conn.recv(4096):
                return


def feed_mcu_frames(seconds: float) -> Handler:
    """Send MCU frames every 20 ms for ``seconds``, then close."""

    def handler(n: int, conn: socket.socket, server: Server) -> None:
        with conn:
            end = time.monotonic() + seconds
            seq = 0
            while time.monotonic() < end and not server.stopping.is_set():
                frame = McuFrame(seq=seq, mcu_time_ms=20 * seq, enc_left=seq, enc_right=seq,
                                 gyro_raw=0)
                try:
                    conn.sendall(frame.encode())
                except OSError:
                    return
                seq += 1
                time.sleep(0.02)

    return handler


class Server:
    """A TCP server on 127.0.0.1 (port 0) serving one connection at a time: the ``n``-th
    connection (from 1) is given to ``plan(n)``'s handler. Counts what it accepts."""

    def __init__(self, plan: Callable[[int], Handler] = lambda n: close_at_once) -> None:
        self.plan = plan
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(64)
        self.port = self.sock.getsockname()[1]
        self.url = f"tcp://127.0.0.1:{self.port}"
        self.stopping = threading.Event()
        #: monotonic times of every accept, and of every close by a handler
        self.accepted: list[float] = []
        self.closed: list[float] = []
        self._thread = threading.Thread(target=self._serve, name="backoff-server", daemon=True)

    @property
    def connections(self) -> int:
        return len(self.accepted)

    def _serve(self) -> None:
        while not self.stopping.is_set():
            ready, _, _ = select.select([self.sock], [], [], 0.05)
            if not ready:
                continue
            conn, _ = self.sock.accept()
            self.accepted.append(time.monotonic())
            self.plan(len(self.accepted))(len(self.accepted), conn, self)
            self.closed.append(time.monotonic())

    def __enter__(self) -> Server:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        time.sleep(0.2)  # connections the client made as it stopped are accepted and counted
        self.stopping.set()
        self._thread.join(5.0)
        self.sock.close()


def _record(out: Path, family: str, url: str, timing: LinkTiming, seconds: float) -> Any:
    settings = RecorderSettings(output=out, devices={family: RecordedDevice(url)},
                                duration=seconds, status=False, fsync=False, timing=timing)
    return Recorder(settings).run()


def _of(log: Path, kind: str) -> list[dict[str, Any]]:
    return [d for d in diagnostics(log) if d["kind"] == kind]


def _gaps(times: list[float]) -> list[float]:
    return [b - a for a, b in pairwise(times)]


@contextmanager
def _counted_opens(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[float]]:
    """Every TcpLink.open call, timed (independently of the worker's own counts)."""
    calls: list[float] = []
    real = device_links.TcpLink.open

    def counted(self: device_links.TcpLink) -> None:
        calls.append(time.monotonic())
        real(self)

    monkeypatch.setattr(device_links.TcpLink, "open", counted)
    yield calls


# ---------------------------------------------------------------------- the recorder's links
def test_backoff_rule_and_its_bounds() -> None:
    t = LinkTiming()
    assert [t.backoff(n) for n in range(8)] == [0.2, 0.2, 0.4, 0.8, 1.6, 2.0, 2.0, 2.0]
    assert t.backoff(10_000) == 2.0
    for bad in ({"backoff_initial": 0.0}, {"backoff_max": 0.1}, {"backoff_factor": 0.5},
                {"healthy_after": -1.0}):
        with pytest.raises(ValueError):
            LinkTiming(**bad)


@pytest.mark.parametrize("flag", ["--nav350", "--nav", "--mcu"])
def test_a_link_that_opens_and_drops_at_once_is_retried_with_backoff(flag: str,
                                                                      tmp_path: Path) -> None:
    """``lgvtool record FLAG tcp://...`` for 3 s against a server that accepts and closes
    every connection: a handful of connections (not tens of thousands), each drop counted on
    /diagnostics, the reopen waiting at least the initial back-off every time."""
    from lgvtool.cli import cli

    out = tmp_path / "drops.mcap"
    with Server() as server:
        t0 = time.monotonic()
        result = CliRunner().invoke(cli, ["record", flag, server.url, "-o", str(out),
                                          "--duration", str(SECONDS)])
        took = time.monotonic() - t0
    assert result.exit_code == 0, result.output
    assert took < SECONDS + 3.0
    n = server.connections
    assert 2 <= n <= MOST_CONNECTIONS, n
    assert min(_gaps(server.accepted)) >= 0.1  # never reopened without waiting
    (stats,) = _of(out, "link_stats")
    assert stats["details"]["connections"] == n
    drops = [d for d in _of(out, "link_down") if "open_s" in d["details"]]
    assert len(drops) >= n - 1 and stats["details"]["drops"] == len(drops)
    assert [d["details"]["drops"] for d in drops] == list(range(1, len(drops) + 1))
    assert [d["details"]["attempts"] for d in drops] == list(range(1, len(drops) + 1))
    assert all(not d["details"]["healthy"] for d in drops)
    waits = [d["details"]["backoff_s"] for d in drops]
    assert waits == sorted(waits) and 0.1 <= waits[0] <= 0.2 and waits[-1] <= 2.0
    assert len(_of(out, "link_open")) == 1 and len(_of(out, "link_up")) >= n - 2


def test_the_backoff_starts_again_only_after_a_healthy_link(tmp_path: Path) -> None:
    """Three connections closed at once (the waits grow 0.1, 0.4, 1.6 s), one kept open and
    fed for 1 s (healthy: open 0.5 s with data), then closed: the next reopen comes after the
    initial 0.1 s, not the 2 s cap; and the connections after it grow again from there."""
    timing = LinkTiming(backoff_initial=0.1, backoff_factor=4.0, backoff_max=2.0,
                        healthy_after=0.5)
    feed = feed_mcu_frames(1.0)
    out = tmp_path / "healthy.mcap"
    with Server(lambda n: feed if n == 4 else close_at_once) as server:
        _record(out, "mcu", server.url, timing, 3.7)
    acc = server.accepted
    assert len(acc) >= 5, acc
    gaps = _gaps(acc)
    assert gaps[1] >= 0.35 and gaps[2] >= 1.5  # growing while no link is healthy
    fed_closed = server.closed[3]
    assert acc[4] - fed_closed < 1.0  # the initial back-off again, not the 2 s cap
    assert len(messages(out, topics.MCU_FRAME)) >= 20
    drops = [d["details"] for d in _of(out, "link_down") if "open_s" in d["details"]]
    assert [d["healthy"] for d in drops[:4]] == [False, False, False, True]
    assert [d["attempts"] for d in drops[:4]] == [1, 2, 3, 0]
    assert drops[2]["backoff_s"] > 1.0 and drops[3]["backoff_s"] <= 0.1
    assert drops[3]["open_s"] >= 0.9
    if len(drops) > 4:
        assert not drops[4]["healthy"] and drops[4]["attempts"] == 1


def test_a_refused_connect_backs_off_and_a_stop_is_noticed_in_the_wait(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Nothing listens: connects at 0, 0.2, 0.6, 1.4 s (then 3.0); one link_down logged, every
    failed connect counted; a stop in the middle of a 1.6 s wait ends the recording at once."""
    probe = socket.socket()
    probe.bind(("127.0.0.1", 0))
    url = f"tcp://127.0.0.1:{probe.getsockname()[1]}"
    probe.close()  # nothing listens there now: connection refused
    out = tmp_path / "refused.mcap"
    settings = RecorderSettings(output=out, devices={"mcu": RecordedDevice(url)},
                                status=False, fsync=False)
    with _counted_opens(monkeypatch) as calls:
        recorder = Recorder(settings)
        th = threading.Thread(target=recorder.run)
        th.start()
        time.sleep(2.2)
        t_stop = time.monotonic()
        recorder.stop("test")
        th.join(5.0)
        stopped_in = time.monotonic() - t_stop
    assert not th.is_alive()
    assert stopped_in < 1.0  # the worker waits on the stop event, it does not sleep
    assert 3 <= len(calls) <= 6, calls
    assert min(_gaps(calls)) >= 0.15
    (down,) = _of(out, "link_down")
    assert down["details"]["attempts"] == 1 and down["details"]["backoff_s"] <= 0.2
    (stats,) = _of(out, "link_stats")
    assert stats["details"]["failed_opens"] == len(calls)
    assert stats["details"]["connections"] == 0


def test_a_silent_devices_link_is_reopened_after_the_backoff(tmp_path: Path) -> None:
    """The MCU link opens but nothing comes: the worker reopens it after ``reconnect_after``
    s of silence, and each reopen waits for the back-off too (it grows: the link is never
    healthy), instead of every ``reconnect_after`` s."""
    timing = LinkTiming(backoff_initial=0.2, backoff_max=0.8, silence=0.2, reconnect_after=0.3)
    out = tmp_path / "silent.mcap"
    with Server(lambda n: hold_silent) as server:
        _record(out, "mcu", server.url, timing, 3.0)
    acc = server.accepted
    assert 2 <= len(acc) <= 6, acc  # every 0.3 s without the back-off: 10
    gaps = _gaps(acc)
    assert min(gaps) >= 0.45 and max(gaps) >= 0.9
    (stats,) = _of(out, "link_stats")
    assert stats["details"]["quiet_reconnects"] >= len(acc) - 1
    assert stats["details"]["drops"] == 0 and not _of(out, "link_down")


# ---------------------------------------------------------------------- the NAV200 session
class _Line:
    """The NAV200 session and a virtual NAV200 on a perfect line, with pose requests of the
    codes in ``refuse`` answered by an error reply (``error``: class, group, detail)."""

    def __init__(self, settings: Nav200Settings, refuse: set[str],
                 error: tuple[int, int, int] = (1, 1, 1)) -> None:
        self.session = Nav200Session(settings)
        self.device = VirtualNav200(circle_playback(30.0))
        self.refuse = refuse
        self.error = error
        self.sent: list[str] = []
        self.events: list[Any] = []

    def run(self, t0: float, t1: float, dt: float = 0.005) -> float:
        t = t0
        while t < t1:
            self.session.set_speed(0.3, 0.0, 0.1, t)
            req = self.session.poll(t)
            if req is not None:
                self.sent.append(req.code)
                if req.code in self.refuse:
                    replies = [build_error_reply(req, *self.error)]
                else:
                    replies = self.device.feed(req.encode(), t)
                for r in replies:
                    self.session.feed(r, t + 0.005)
            self.events += self.session.pop_events()
            t += dt
        return t

    def diags(self, kind: str) -> list[DecodeEvent]:
        return [e for e in self.events if isinstance(e, DecodeEvent) and e.kind == kind]

    def poses(self) -> int:
        return sum(isinstance(e, PoseReceived) for e in self.events)


def test_a_refused_pw_gives_speed_input_up_for_the_device_session() -> None:
    """A NAV200 that does not know Pw ("unknown command"): before, the session went through
    the whole sequence (the map upload included) again after every refusal, forever, and no
    pose was recorded. Now: 3 tries, one diagnostic, then PP; a new device session tries Pw
    again."""
    line = _Line(Nav200Settings(speed_input=True), refuse={"Pw"})
    line.session.start(0.0)
    t = line.run(0.0, 10.0)
    assert line.sent.count("Pw") == 3
    assert line.sent.count("UA") == 3 and line.sent.count("PA") == 3
    (given_up,) = line.diags("speed_input_given_up")
    assert given_up.details["refusals"] == 3 and given_up.details["detail"] == 1
    assert len(line.diags("positioning_lost")) == 2
    assert line.poses() >= 15 and line.sent[-1] == "PP"
    line.session.link_up(t)  # the link reopened: a new device session
    line.run(t, t + 10.0)
    assert line.sent.count("Pw") == 6 and len(line.diags("speed_input_given_up")) == 2


def test_a_refused_pose_request_re_enters_positioning_a_bounded_number_of_times() -> None:
    """A NAV200 that acknowledges PA but refuses every PP ("wrong command"): positioning is
    entered again 3 times, then given up for the device session (one diagnostic) while the
    polling goes on; an accepted pose re-arms it (a later device reset is recovered)."""
    line = _Line(Nav200Settings(upload_map=False, resume_tries=3), refuse={"PP"},
                 error=(1, 2, 3))
    line.session.start(0.0)
    t = line.run(0.0, 6.0)
    assert len(line.diags("positioning_lost")) == 3
    (given_up,) = line.diags("positioning_given_up")
    assert given_up.details["tries"] == 3 and given_up.details["request"] == "PP"
    assert line.sent.count("PA") == 4  # the first entry and 3 re-entries
    polls = line.sent.count("PP")
    t = line.run(t, t + 4.5)
    assert line.sent.count("PA") == 4 and line.sent.count("PP") - polls >= 8
    line.refuse = set()  # the device answers again: poses, and the re-entry re-armed
    t = line.run(t, t + 2.0)
    assert line.poses() >= 3
    line.device.reset()  # standby: "wrong command" to PP until positioning is entered again
    before = line.poses()
    line.run(t, t + 2.0)
    assert len(line.diags("positioning_lost")) == 4 and line.sent.count("PA") == 5
    assert line.poses() > before
