"""The live server serves Foxglove clients of either subprotocol name: ``foxglove.sdk.v1``
(foxglove-sdk's) and ``foxglove.websocket.v1`` (the npm ``@foxglove/ws-protocol`` library,
Lichtblick, older Foxglove releases), through :class:`lgvtool.live.front.SubprotocolFront`;
any other name is refused with a line saying what was offered and what is accepted."""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

import websockets
from foxglove_client import collect
from websockets.typing import Subprotocol

from lgvtool.live.drawing import TOPICS as DRAWING_TOPICS
from lgvtool.live.front import (
    BUFFER_BYTES,
    FrameTracker,
    _rewrite_protocol,
    choose_subprotocol,
    client_close_frame,
    offered_subprotocols,
)
from lgvtool.live.live_server import LiveAddress, LiveServer
from lgvtool.log import LogReader

SAMPLE_LOG = Path(__file__).resolve().parents[2] / "sample_logs" / "paper-circle.mcap"
OLD = "foxglove.websocket.v1"
NEW = "foxglove.sdk.v1"
ACCEPTED = "accepted: foxglove.sdk.v1 and foxglove.websocket.v1"
#: the channels of the in-process server: topic -> schema name
CHANNELS = {"/test/a": "lgvtool.McuFrame", "/test/b": "lgvtool.NavPose",
            "/test/c": "foxglove.Log", "/test/once": "lgvtool.ReflectorMap"}


def _each(n: int) -> dict[str, int]:
    """``n`` messages of every channel published often, the one published once."""
    return {t: 1 if t == "/test/once" else n for t in CHANNELS}


def test_the_subprotocol_chosen() -> None:
    assert offered_subprotocols([("Sec-WebSocket-Protocol", "a, foxglove.websocket.v1"),
                                 ("Host", "x"), ("sec-websocket-protocol", " b ")]) == [
        "a", OLD, "b"]
    assert choose_subprotocol([OLD]) == OLD
    assert choose_subprotocol([NEW]) == NEW
    assert choose_subprotocol([OLD, NEW]) == NEW  # the SDK's own name when both are offered
    assert choose_subprotocol(["x", "foxglove.websocket.v2"]) is None
    assert choose_subprotocol([]) is None
    head = (b"GET / HTTP/1.1\r\nHost: h\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n"
            b"sec-websocket-protocol: other\r\nSec-WebSocket-Key: k\r\n\r\n")
    assert _rewrite_protocol(head, NEW) == (b"GET / HTTP/1.1\r\nHost: h\r\nSec-WebSocket-Key: k"
                                            b"\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n")


def _masked(opcode: int, payload: bytes) -> bytes:
    mask = os.urandom(4)
    n = len(payload)
    size = (bytes([0x80 | n]) if n < 126 else bytes([0x80 | 126]) + struct.pack(">H", n)
            if n < 65536 else bytes([0x80 | 127]) + struct.pack(">Q", n))
    return (bytes([0x80 | opcode]) + size + mask
            + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


def test_frame_boundaries_and_the_close_frame_are_followed() -> None:
    stream = (_masked(1, b'{"op": "subscribe"}') + _masked(2, b"x" * 300)
              + _masked(1, b"y" * 70000) + client_close_frame())
    for step in (1, 7, 4096, len(stream)):  # however the bytes arrive
        t = FrameTracker()
        boundaries = 0
        for i in range(0, len(stream), step):
            t.feed(stream[i:i + step])
            boundaries += t.at_boundary
            if i + step <= len(stream) - len(client_close_frame()):
                assert not t.close_seen
        assert t.at_boundary and t.close_seen and boundaries >= 1
    t = FrameTracker()
    t.feed(_masked(1, b"abc")[:4])
    assert not t.at_boundary
    close = client_close_frame()
    assert close[0] == 0x88 and close[1] & 0x80  # a masked close frame, as a client sends it
    payload = bytes(b ^ close[2 + i % 4] for i, b in enumerate(close[6:]))
    assert struct.unpack(">H", payload[:2])[0] == 1001


class _Publisher:
    """Publishes on every channel of :data:`CHANNELS` (``/test/once`` once, the others every
    ``period`` s) until stopped; each message holds its number and ``time.monotonic_ns()``."""

    def __init__(self, server: LiveServer, period: float = 0.01, size: int = 0) -> None:
        self.server = server
        self.period = period
        self.pad = "x" * size
        self.sent = 0
        self._stop = threading.Event()
        server.prepare(CHANNELS)
        server.publish("/test/once", CHANNELS["/test/once"], b'{"reflectors": []}', 1)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sent += 1
            for topic in ("/test/a", "/test/b", "/test/c"):
                data = json.dumps({"n": self.sent, "t": time.monotonic_ns(), "pad": self.pad})
                self.server.publish(topic, CHANNELS[topic], data.encode(), 10 + self.sent)
            if self.period:
                self._stop.wait(self.period)

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(10)


@pytest.fixture
def live() -> Iterator[LiveServer]:
    lines: list[str] = []
    server = LiveServer(LiveAddress("127.0.0.1", 0), warn=lines.append)
    server.lines = lines  # type: ignore[attr-defined]
    pub = _Publisher(server)
    yield server
    pub.stop()
    server.close()


@pytest.mark.parametrize("offered", [[OLD], [NEW], [OLD, NEW]], ids=["old", "new", "both"])
def test_a_client_of_either_name_receives_every_channel(live: LiveServer, offered: list[str]
                                                        ) -> None:
    got = collect(live.url, set(CHANNELS), wanted=_each(20), timeout=15.0, subprotocols=offered)
    assert got.subprotocol == (OLD if offered == [OLD] else NEW)
    assert got.server_info["op"] == "serverInfo" and got.server_info["name"] == "lgvtool"
    assert "time" in got.server_info["capabilities"]
    assert set(got.channels) == set(CHANNELS)
    for topic, schema in CHANNELS.items():
        ch = got.channels[topic]
        assert (ch["schemaName"], ch["encoding"], ch["schemaEncoding"]) == (schema, "json",
                                                                              "jsonschema")
    for topic in ("/test/a", "/test/b", "/test/c"):
        ns = [m["n"] for _, m in got.messages[topic]]
        assert len(ns) >= 20 and ns == sorted(ns), topic
    assert got.messages["/test/once"] == [(1, {"reflectors": []})]  # sent on subscribing
    assert live.lines == []  # type: ignore[attr-defined]


def test_the_front_passes_the_sdks_frames_unchanged(live: LiveServer) -> None:
    """Two clients at once, one through the front offering the old name, one at the SDK's
    own server: the same messages, byte for byte."""
    out: dict[str, object] = {}
    direct = threading.Thread(target=lambda: out.update(d=collect(
        live.sdk_url, {"/test/a"}, wanted=100, timeout=15.0, subprotocols=[NEW])))
    direct.start()
    front = collect(live.url, {"/test/a"}, wanted=100, timeout=15.0, subprotocols=[OLD])
    direct.join(20)
    d = out["d"]
    assert front.channels == d.channels and front.server_info == d.server_info  # type: ignore[attr-defined]
    common = {n for n, _ in front.messages["/test/a"]} & {n for n, _ in d.messages["/test/a"]}  # type: ignore[attr-defined]
    assert len(common) >= 50
    assert ({(t, json.dumps(m)) for t, m in front.messages["/test/a"] if t in common}
            == {(t, json.dumps(m)) for t, m in d.messages["/test/a"] if t in common})  # type: ignore[attr-defined]


def _handshake(port: int, protocols: str | None, upgrade: bool = True) -> bytes:
    """A raw HTTP upgrade request; the whole answer (until the server closes or 2 s)."""
    with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
        key = base64.b64encode(os.urandom(16)).decode()
        req = f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
        if upgrade:
            req += (f"Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                    "Sec-WebSocket-Version: 13\r\n")
        if protocols is not None:
            req += f"Sec-WebSocket-Protocol: {protocols}\r\n"
        s.sendall((req + "\r\n").encode())
        s.settimeout(2.0)
        data = b""
        try:
            while chunk := s.recv(65536):
                data += chunk
                if b"\r\n\r\n" in data and data.startswith(b"HTTP/1.1 101"):
                    break
        except TimeoutError:
            pass
        return data


def test_an_unknown_name_is_refused_with_a_clear_line(live: LiveServer) -> None:
    lines: list[str] = live.lines  # type: ignore[attr-defined]
    with pytest.raises(websockets.InvalidStatus) as err:
        collect(live.url, subprotocols=["foxglove.websocket.v2"], timeout=5.0)
    assert err.value.response.status_code == 400
    body = err.value.response.body.decode()
    assert "'foxglove.websocket.v2'" in body and "foxglove.sdk.v1 and foxglove.websocket.v1" in body
    assert len(lines) == 1, lines
    assert re.fullmatch(r"refused the client at 127\.0\.0\.1:\d+: it offered the WebSocket "
                        r"subprotocol 'foxglove\.websocket\.v2'; " + ACCEPTED, lines[0]), lines
    # no subprotocol at all, several unknown ones, and a plain HTTP request: refused and said
    lines.clear()
    assert _handshake(live.address.port, None).startswith(b"HTTP/1.1 400 ")
    assert _handshake(live.address.port, "a, b").startswith(b"HTTP/1.1 400 ")
    plain = _handshake(live.address.port, None, upgrade=False)
    assert plain.startswith(b"HTTP/1.1 400 ") and b"Foxglove WebSocket server" in plain
    assert len(lines) == 3, lines
    assert "offered no WebSocket subprotocol (no Sec-WebSocket-Protocol header); " + ACCEPTED in lines[0]
    assert "offered the WebSocket subprotocols 'a', 'b'; " + ACCEPTED in lines[1]
    assert "'GET / HTTP/1.1' is no WebSocket upgrade request" in lines[2]
    # the same refusal again at once is not said again
    _handshake(live.address.port, "a, b")
    assert len(lines) == 3
    # the old name's handshake answers it (the SDK's Sec-WebSocket-Accept, the client's name)
    ok = _handshake(live.address.port, OLD)
    assert ok.startswith(b"HTTP/1.1 101 ")
    assert b"\r\nSec-WebSocket-Protocol: foxglove.websocket.v1\r\n" in ok
    assert live.front.stats.refused == 5 and live.front.stats.by_subprotocol[OLD] >= 1


def test_many_clients_at_once(live: LiveServer) -> None:
    results: list[object] = []

    def one(i: int) -> None:
        results.append(collect(live.url, set(CHANNELS), wanted=_each(10), timeout=20.0,
                               subprotocols=[[OLD], [NEW], [OLD, NEW]][i % 3]))

    threads = [threading.Thread(target=one, args=(i,)) for i in range(24)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert len(results) == 24
    for got in results:
        assert all(len(got.messages.get(t, [])) >= (1 if t == "/test/once" else 10)  # type: ignore[attr-defined]
                   for t in CHANNELS)
    assert live.front.stats.served >= 24 and live.lines == []  # type: ignore[attr-defined]


def test_past_the_most_clients_one_is_refused_and_said(live: LiveServer) -> None:
    live.front.max_clients = 2
    held = [socket.create_connection(("127.0.0.1", live.address.port)) for _ in range(2)]
    try:
        time.sleep(0.2)
        answer = _handshake(live.address.port, OLD)
    finally:
        for s in held:
            s.close()
    assert answer.startswith(b"HTTP/1.1 503 ")
    lines: list[str] = live.lines  # type: ignore[attr-defined]
    assert len(lines) == 1 and "2 clients are connected already (the most)" in lines[0], lines
    time.sleep(0.2)
    assert _handshake(live.address.port, OLD).startswith(b"HTTP/1.1 101 ")  # room again


def _stalled_client(url: str, ready: threading.Event, done: threading.Event) -> None:
    """Subscribes to /test/a offering the old name, then reads nothing until ``done``."""
    async def run() -> None:
        async with websockets.connect(url, subprotocols=[Subprotocol(OLD)], max_queue=1,
                                      open_timeout=5, close_timeout=1) as ws:
            while True:
                msg = json.loads(await ws.recv())
                if msg["op"] == "advertise":
                    ids = [c["id"] for c in msg["channels"] if c["topic"] == "/test/a"]
                    if ids:
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                            {"id": 7, "channelId": ids[0]}]}))
                        break
            ready.set()
            while not done.is_set():
                await asyncio.sleep(0.05)

    with contextlib.suppress(websockets.ConnectionClosed):
        asyncio.run(run())


def test_a_client_that_stops_reading_is_bounded_dropped_and_said() -> None:
    """A client that reads nothing: what waits for it in the front stays under its bound (the
    SDK drops its oldest messages beyond its backlog), another client goes on receiving, and
    the stalled one is said slow, then disconnected."""
    lines: list[str] = []
    server = LiveServer(LiveAddress("127.0.0.1", 0), warn=lines.append)
    server.front.slow_notice_s = 0.3
    server.front.stall_close_s = 4.0
    pub = _Publisher(server, period=0.0005, size=4000)  # about 3 x 2000 x 4 kB a second
    ready, done = threading.Event(), threading.Event()
    slow = threading.Thread(target=_stalled_client, args=(server.url, ready, done))
    slow.start()
    try:
        assert ready.wait(10)
        peak = 0
        t_end = time.monotonic() + 2.0
        while time.monotonic() < t_end:
            peak = max(peak, *server.front.waiting_bytes(), 0)
            time.sleep(0.02)
        # one read of the SDK's socket (256 kB at most) can land past the bound
        assert 0 < peak <= BUFFER_BYTES + 256 * 1024, peak
        # the others are not held up
        got = collect(server.url, {"/test/a"}, wanted=200, timeout=10.0, subprotocols=[OLD])
        assert len(got.messages["/test/a"]) >= 200
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and server.front.stats.stalled == 0:
            time.sleep(0.1)
    finally:
        done.set()
        slow.join(10)
        pub.stop()
        server.close()
    assert pub.sent > 2000
    assert server.front.stats.slow == 1 and server.front.stats.stalled == 1, lines
    said = [ln for ln in lines if "not keeping up" in ln or "disconnected" in ln]
    assert len(said) == 2, lines
    assert "its oldest messages are dropped (at most 1024 are kept for it)" in said[0]
    assert said[1].endswith("it has been behind for 4 s without catching up")


def test_a_client_gone_without_closing_leaves_the_sdk_quiet(caplog: pytest.LogCaptureFixture
                                                             ) -> None:
    """A client that drops its connection mid-stream (TCP reset, no close frame): the front
    sends the SDK's server a close frame for it. Connected to foxglove-sdk directly, such a
    client costs a logged error (on stderr by default) for every message the SDK still tries
    to send it (hundreds); through the front, none."""
    server = LiveServer(LiveAddress("127.0.0.1", 0))
    pub = _Publisher(server, period=0.0005, size=4000)
    try:
        with socket.socket() as s:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
            s.settimeout(5)
            s.connect(("127.0.0.1", server.address.port))
            key = base64.b64encode(os.urandom(16)).decode()
            s.sendall((f"GET / HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: "
                       f"Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                       f"Sec-WebSocket-Protocol: {OLD}\r\n\r\n").encode())
            assert s.recv(12) == b"HTTP/1.1 101"
            time.sleep(0.3)  # advertised by then: channel ids 1-4 in order of preparing
            s.sendall(_masked(1, json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": i} for i in range(1, 5)]}).encode()))
            time.sleep(2.0)  # the client reads nothing: its buffers fill
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        time.sleep(2.0)
    finally:
        pub.stop()
        server.close()
    errors = [r.getMessage() for r in caplog.records if "Error sending" in r.getMessage()]
    assert errors == [], f"{len(errors)} errors: {errors[:3]}"


@pytest.mark.skipif(not hasattr(socket, "TCP_QUICKACK"), reason="Linux's TCP_QUICKACK")
def test_the_first_messages_after_subscribing_are_not_held_back() -> None:
    """foxglove-sdk leaves Nagle's algorithm on: sent straight from it, the second of the
    messages resent on subscribing waits about 40 ms for a delayed acknowledgement. The front
    acknowledges at once: every channel's first message within a few ms (best of 3 tries, for a
    loaded machine)."""
    server = LiveServer(LiveAddress("127.0.0.1", 0))
    try:
        chans = {f"/t/{i}": "foxglove.Log" for i in range(8)}
        server.prepare(chans)
        for t in chans:
            server.publish(t, "foxglove.Log", b'{"message": "last"}', 1)
        slowest = []
        for _ in range(3):
            got = collect(server.url, set(chans), timeout=3.0, subprotocols=[OLD])
            assert set(got.first_after_subscribe_s) == set(chans)
            slowest.append(max(got.first_after_subscribe_s.values()))
    finally:
        server.close()
    assert min(slowest) < 0.02, slowest


def _has_ipv6() -> bool:
    try:
        with socket.socket(socket.AF_INET6) as s:
            s.bind(("::1", 0))
        return True
    except OSError:
        return False


@pytest.mark.parametrize(("host", "connect"), [
    ("0.0.0.0", ["127.0.0.1"]), ("localhost", ["127.0.0.1"]), ("::1", ["[::1]"]),
    ("::", ["[::1]", "127.0.0.1"])])
def test_the_front_binds_the_users_host(host: str, connect: list[str]) -> None:
    if ":" in host and not _has_ipv6():
        pytest.skip("no IPv6 on this machine")
    server = LiveServer(LiveAddress(host, 0))
    try:
        assert server.sdk_address.host == "127.0.0.1"  # the SDK's own server: loopback only
        assert server.address == LiveAddress(host, server.address.port)
        for h in connect:
            got = collect(f"ws://{h}:{server.address.port}", timeout=1.0, subprotocols=[OLD])
            assert got.subprotocol == OLD and got.server_info["op"] == "serverInfo"
    finally:
        server.close()


def test_close_ends_the_clients_and_frees_the_port() -> None:
    server = LiveServer(LiveAddress("127.0.0.1", 0))
    port = server.address.port
    closing = threading.Timer(0.5, server.close)

    async def connected_until_closed() -> str:
        async with websockets.connect(server.url, subprotocols=[Subprotocol(OLD)],
                                      open_timeout=5) as ws:
            closing.start()
            try:
                while True:
                    await asyncio.wait_for(ws.recv(), 10)
            except websockets.ConnectionClosed:
                return "closed"

    assert asyncio.run(connected_until_closed()) == "closed"
    closing.join(10)
    assert not [t for t in threading.enumerate() if t.name == "live-front"]
    again = LiveServer(LiveAddress("127.0.0.1", port))  # the port is free again
    assert again.address.port == port
    again.close()


def test_view_live_serves_a_client_offering_only_the_old_name() -> None:
    """``lgvtool view --live`` of the shipped sample log: a client offering only
    foxglove.websocket.v1 receives every channel; one offering an unknown name is refused,
    and the command says so on stderr."""
    log = SAMPLE_LOG
    p = subprocess.Popen([sys.executable, "-m", "lgvtool", "view", str(log), "--live",
                          "127.0.0.1:0", "--speed", "20", "--wait", "1", "--no-progress"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert p.stderr is not None
        first = p.stderr.readline()
        m = re.search(r"live view on (ws://127\.0\.0\.1:\d+)", first)
        assert m, first
        url = m.group(1)
        with pytest.raises(websockets.InvalidStatus):
            collect(url, subprotocols=["bogus"], timeout=5.0)
        # the log's channels and what the live view draws from them (the reference circle
        # after the first lap: 30 s of data, 1.5 s at 20x)
        expected = set(LogReader(log).topics()) | set(DRAWING_TOPICS)
        got = collect(url, expected, timeout=20.0, subprotocols=[OLD])
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=60)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()
    assert p.returncode == 0, err
    assert got.subprotocol == OLD and got.server_info["op"] == "serverInfo"
    assert set(got.channels) == expected
    assert {t for t, v in got.messages.items() if v} == expected
    assert re.search(r"lgvtool: live view: refused the client at 127\.0\.0\.1:\d+: it offered "
                     r"the WebSocket subprotocol 'bogus'; " + ACCEPTED, err), err
    # the summary counts them
    assert "; 1 client served (1 foxglove.websocket.v1), 1 refused" in err, err
