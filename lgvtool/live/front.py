"""The live server's front door: Foxglove WebSocket clients of either subprotocol name.

foxglove-sdk's server accepts only clients that offer the subprotocol ``foxglove.sdk.v1``;
a client that offers only the protocol's older name, ``foxglove.websocket.v1`` (the npm
``@foxglove/ws-protocol`` library, Lichtblick, older Foxglove releases), is answered HTTP 400
inside the SDK's handshake, and the SDK prints only "handshake failed". The messages of the
two names are the same (serverInfo, advertise, subscribe, the binary messageData and time
frames, unadvertise, ...: foxglove-sdk's ``protocol::v1`` module is the foxglove.websocket.v1
spec), so what differs is the name in the HTTP upgrade alone.

:class:`SubprotocolFront` listens on the user's address and lets foxglove-sdk listen on
``127.0.0.1`` at a port of its own (0: any). For each client it reads the HTTP upgrade
request, and

- when the client offers ``foxglove.sdk.v1`` or ``foxglove.websocket.v1``: opens a TCP
  connection to the SDK's server, sends it the same request offering ``foxglove.sdk.v1``,
  passes the SDK's ``101 Switching Protocols`` back with the name the client offered
  (``foxglove.sdk.v1`` when it offered both), then relays the bytes both ways unchanged: the
  WebSocket frames (the client's masking, the Sec-WebSocket-Key/Accept pair, pings and the
  close handshake) are the two ends' own, nothing is decoded or re-framed;
- otherwise: answers HTTP 400 itself, with a body naming what was offered and what is accepted,
  and calls ``warn`` with one line saying the same.

Nothing is buffered without bound. Each connection holds at most ``buffer_bytes`` waiting for
a client (plus one socket read): past that, the front stops reading the SDK's side of that
client, which then queues at most its message backlog (1024 messages) for the client and drops
the oldest beyond it, the policy of a client connected to the SDK directly. A client still
behind after ``slow_notice_s`` (over a quarter of ``buffer_bytes`` still waiting for it) is said
to be slow (``warn``, once); one still behind after ``stall_close_s`` is disconnected (and said
so). At most ``max_clients`` are connected at once; the next is answered HTTP 503 and said so.
A client gone without the WebSocket close handshake has a close frame sent for it to the SDK's
server, which otherwise prints an error line for every message it still tries to send it.

foxglove-sdk's sockets leave Nagle's algorithm on (no ``TCP_NODELAY``): of several messages sent
back to back (the last message of each channel, resent on subscribing), the second waits for
the acknowledgement of the first, which a receiver delays by up to 40 ms. The front acknowledges
at once what it reads from the SDK (``TCP_QUICKACK``, where the system has it; re-armed at each
read), so a client served through it has the first message of each of its channels within about
1 ms of subscribing (directly from the SDK: 41-43 ms); its own sockets have ``TCP_NODELAY``
(asyncio's default).

The front runs an asyncio event loop on a thread of its own (``live-front``).
"""

from __future__ import annotations

import asyncio
import contextlib
import os
import socket
import threading
import time
from collections.abc import Callable, Coroutine
from concurrent.futures import Future
from typing import TypedDict, TypeVar

#: what a coroutine run on the front's loop gives
T = TypeVar("T")

__all__ = ["ACCEPTED_SUBPROTOCOLS", "SDK_SUBPROTOCOL", "FrameTracker", "FrontStats",
           "SubprotocolFront", "choose_subprotocol", "client_close_frame", "offered_subprotocols"]

#: the name foxglove-sdk's server accepts
SDK_SUBPROTOCOL = "foxglove.sdk.v1"
#: the names the front accepts, in the order it prefers them when a client offers several
ACCEPTED_SUBPROTOCOLS = (SDK_SUBPROTOCOL, "foxglove.websocket.v1")

#: the longest HTTP request or response head read (bytes)
MAX_HEAD = 16384
#: time a client has to send its upgrade request, and the SDK's server to answer it (s)
HANDSHAKE_TIMEOUT_S = 10.0
#: bytes waiting for one client before the front stops reading the SDK's side of it
BUFFER_BYTES = 256 * 1024
#: a client still behind (over a quarter of BUFFER_BYTES waiting for it, the low-water mark)
#: after this long (s) is said to be slow
SLOW_NOTICE_S = 2.0
#: a client still behind after this long (s) is disconnected
STALL_CLOSE_S = 30.0
#: time the SDK's server has to close a connection after the front sent it a close frame for
#: a client gone without one (s)
CLOSE_WAIT_S = 1.0
#: clients connected at once
MAX_CLIENTS = 100
#: the same refusal (client host and reason) is said at most once in this long (s)
_REPEAT_S = 10.0


def offered_subprotocols(headers: list[tuple[str, str]]) -> list[str]:
    """The subprotocol names of every ``Sec-WebSocket-Protocol`` header, in order."""
    return [p.strip() for name, value in headers if name.lower() == "sec-websocket-protocol"
            for p in value.split(",") if p.strip()]


def choose_subprotocol(offered: list[str]) -> str | None:
    """The accepted name the front answers with (``foxglove.sdk.v1`` first), None: none."""
    return next((p for p in ACCEPTED_SUBPROTOCOLS if p in offered), None)


def _parse_head(head: bytes) -> tuple[str, list[tuple[str, str]]]:
    """The first line and the ``(name, value)`` headers of an HTTP head (CRLF lines)."""
    lines = head.decode("latin-1").split("\r\n")
    headers = []
    for line in lines[1:]:
        name, sep, value = line.partition(":")
        if sep:
            headers.append((name.strip(), value.strip()))
    return lines[0], headers


def _rewrite_protocol(head: bytes, name: str) -> bytes:
    """``head`` (ending in the blank line) with its ``Sec-WebSocket-Protocol`` headers replaced
    by one offering/answering ``name``."""
    lines = head.decode("latin-1").split("\r\n")[:-2]
    kept = [ln for ln in lines
            if ln.partition(":")[0].strip().lower() != "sec-websocket-protocol"]
    kept.append(f"Sec-WebSocket-Protocol: {name}")
    return ("\r\n".join(kept) + "\r\n\r\n").encode("latin-1")


def _peer(transport: asyncio.BaseTransport) -> str:
    peer = transport.get_extra_info("peername")
    if isinstance(peer, tuple) and len(peer) >= 2:
        host = f"[{peer[0]}]" if ":" in str(peer[0]) else str(peer[0])
        return f"{host}:{peer[1]}"
    return str(peer)


def _http(status: str, body: str) -> bytes:
    data = body.encode()
    return (f"HTTP/1.1 {status}\r\nContent-Type: text/plain; charset=utf-8\r\n"
            f"Content-Length: {len(data)}\r\nConnection: close\r\n\r\n").encode() + data


class FrameTracker:
    """Follows the frame boundaries of one direction of a WebSocket stream from the frames'
    headers (the payloads are skipped, not read), and whether a close frame passed."""

    def __init__(self) -> None:
        self._head = bytearray()
        self._skip = 0
        self.close_seen = False

    @property
    def at_boundary(self) -> bool:
        """True between two frames."""
        return not self._skip and not self._head

    def feed(self, data: bytes) -> None:
        i, n = 0, len(data)
        while i < n:
            if self._skip:
                k = min(self._skip, n - i)
                self._skip -= k
                i += k
                continue
            self._head.append(data[i])
            i += 1
            h = self._head
            if len(h) < 2:
                continue
            size = h[1] & 0x7F
            ext = 2 if size == 126 else 8 if size == 127 else 0
            if len(h) < 2 + ext + (4 if h[1] & 0x80 else 0):
                continue
            if ext:
                size = int.from_bytes(h[2:2 + ext], "big")
            if h[0] & 0x0F == 8:
                self.close_seen = True
            self._skip = size
            self._head = bytearray()


def client_close_frame(code: int = 1001, reason: bytes = b"client went away") -> bytes:
    """A WebSocket close frame as a client sends it (masked)."""
    payload = code.to_bytes(2, "big") + reason[:123]
    mask = os.urandom(4)
    return (bytes([0x88, 0x80 | len(payload)]) + mask
            + bytes(b ^ mask[i % 4] for i, b in enumerate(payload)))


class ClientCounts(TypedDict):
    """The clients a front served and refused, those slow or disconnected for stalling, and
    the clients served per subprotocol."""

    served: int
    refused: int
    slow: int
    stalled: int
    by_subprotocol: dict[str, int]


class FrontStats:
    """Counts of the front's clients: served (upgraded), refused (no accepted subprotocol,
    not a WebSocket request, too many clients), said to be slow, disconnected for stalling,
    and served per subprotocol name."""

    def __init__(self) -> None:
        self.served = 0
        self.refused = 0
        self.slow = 0
        self.stalled = 0
        self.by_subprotocol: dict[str, int] = {}

    def as_dict(self) -> ClientCounts:
        return {"served": self.served, "refused": self.refused, "slow": self.slow,
                "stalled": self.stalled, "by_subprotocol": dict(self.by_subprotocol)}


class _Client(asyncio.Protocol):
    """One client's connection: its upgrade request, then the relay to the SDK's server."""

    def __init__(self, front: SubprotocolFront) -> None:
        self.front = front
        self.transport: asyncio.Transport | None = None
        self.upstream: _Upstream | None = None
        self.peer = "?"
        self.head = bytearray()
        self.handshaking = True
        self.relaying = False
        self.closed = False
        self.pending = b""
        self.timers: dict[str, asyncio.TimerHandle] = {}
        self.said_slow = False
        #: the client's frames to the SDK's server (a few small ones: subscriptions)
        self.sent = FrameTracker()

    # -- the client's side ------------------------------------------------------------
    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        self.peer = _peer(transport)
        transport.set_write_buffer_limits(high=self.front.buffer_bytes)
        self.front.clients.add(self)
        self.later("handshake", HANDSHAKE_TIMEOUT_S, self.handshake_timeout)

    def later(self, name: str, delay: float, what: Callable[[], None]) -> None:
        self.cancel(name)
        self.timers[name] = self.front.loop.call_later(delay, what)

    def cancel(self, name: str) -> None:
        timer = self.timers.pop(name, None)
        if timer is not None:
            timer.cancel()

    def handshake_timeout(self) -> None:
        self.timers.pop("handshake", None)
        if not self.relaying and not self.closed:
            self.front.say(self.peer, "timeout",
                           f"dropped the client at {self.peer}: its WebSocket handshake did not "
                           f"complete within {HANDSHAKE_TIMEOUT_S:g} s")
            self.close()

    def data_received(self, data: bytes) -> None:
        if self.relaying:
            assert self.upstream is not None and self.upstream.transport is not None
            self.upstream.transport.write(data)
            self.sent.feed(data)
            return
        if not self.handshaking:  # connecting to the SDK's server: kept until then
            self.pending += data
            return
        self.head += data
        end = self.head.find(b"\r\n\r\n")
        if end < 0:
            if len(self.head) > MAX_HEAD:
                self.refuse("431 Request Header Fields Too Large",
                            f"the request head is over {MAX_HEAD} bytes",
                            f"refused the client at {self.peer}: its request head is over "
                            f"{MAX_HEAD} bytes")
            return
        request, self.pending = bytes(self.head[:end + 4]), bytes(self.head[end + 4:])
        self.head.clear()
        self.handshaking = False
        self.handshake(request)

    def handshake(self, request: bytes) -> None:
        if len(self.front.clients) > self.front.max_clients:  # answered once it has asked
            self.refuse("503 Service Unavailable",
                        f"{self.front.max_clients} clients are connected, the most served at "
                        f"once\n", f"refused the client at {self.peer}: "
                        f"{self.front.max_clients} clients are connected already (the most)")
            return
        first, headers = _parse_head(request)
        upgrade = any(n.lower() == "upgrade" and "websocket" in v.lower() for n, v in headers)
        accepted = " and ".join(ACCEPTED_SUBPROTOCOLS)
        if not upgrade:
            self.refuse("400 Bad Request",
                        f"this is a Foxglove WebSocket server: connect with a WebSocket client "
                        f"offering the subprotocol {' or '.join(ACCEPTED_SUBPROTOCOLS)}\n",
                        f"refused the client at {self.peer}: {first[:80]!r} is no WebSocket "
                        f"upgrade request; accepted: WebSocket clients offering "
                        f"{' or '.join(ACCEPTED_SUBPROTOCOLS)}",
                        key="not websocket")
            return
        offered = offered_subprotocols(headers)
        chosen = choose_subprotocol(offered)
        if chosen is None:
            what = (f"the WebSocket subprotocol{'s' if len(offered) > 1 else ''} "
                    + ", ".join(repr(p) for p in offered) if offered
                    else "no WebSocket subprotocol (no Sec-WebSocket-Protocol header)")
            self.refuse("400 Bad Request",
                        f"no accepted WebSocket subprotocol: the client offered {what}; this "
                        f"Foxglove WebSocket server accepts {accepted}\n",
                        f"refused the client at {self.peer}: it offered {what}; accepted: "
                        f"{accepted}", key=f"offered {offered}")
            return
        assert self.transport is not None
        self.transport.pause_reading()
        self.front.loop.create_task(self.connect(_rewrite_protocol(request, SDK_SUBPROTOCOL),
                                                 chosen))

    async def connect(self, request: bytes, chosen: str) -> None:
        try:
            await self.front.loop.create_connection(lambda: _Upstream(self, chosen),
                                                    "127.0.0.1", self.front.upstream_port)
        except OSError as exc:
            self.refuse("503 Service Unavailable", "the live server is not reachable\n",
                        f"could not serve the client at {self.peer}: the live server at "
                        f"127.0.0.1:{self.front.upstream_port} is not reachable ({exc})")
            return
        up = self.upstream
        assert up is not None and up.transport is not None
        if self.closed:
            up.transport.close()
            return
        up.transport.write(request + self.pending)
        self.sent.feed(self.pending)
        self.pending = b""

    def refuse(self, status: str, body: str, line: str, key: str | None = None) -> None:
        self.front.stats.refused += 1
        self.front.say(self.peer, key or status, line)
        if self.transport is not None and not self.transport.is_closing():
            self.transport.write(_http(status, body))
        self.close()

    def pause_writing(self) -> None:  # the client is behind: read no more for it
        if self.upstream is not None and self.upstream.transport is not None:
            self.upstream.transport.pause_reading()
        self.later("slow", self.front.slow_notice_s, self.slow)
        self.later("stall", self.front.stall_close_s, self.stall)

    def resume_writing(self) -> None:
        self.cancel("slow")
        self.cancel("stall")
        if self.upstream is not None and self.upstream.transport is not None:
            self.upstream.transport.resume_reading()

    def slow(self) -> None:
        self.timers.pop("slow", None)
        if not self.said_slow and not self.closed:
            self.said_slow = True
            self.front.stats.slow += 1
            self.front.say(self.peer, "slow",
                           f"the client at {self.peer} is not keeping up: its oldest messages "
                           f"are dropped (at most {self.front.backlog} are kept for it)")

    def stall(self) -> None:
        self.timers.pop("stall", None)
        if not self.closed:
            self.front.stats.stalled += 1
            self.front.say(self.peer, "stall",
                           f"disconnected the client at {self.peer}: it has been behind for "
                           f"{self.front.stall_close_s:g} s without catching up")
            self.close(abort_client=True)

    def eof_received(self) -> bool:
        return False  # the transport closes; connection_lost closes the other side

    def connection_lost(self, exc: Exception | None) -> None:
        self.close()
        self.front.clients.discard(self)

    # -- both ------------------------------------------------------------------------
    def close(self, *, abort_client: bool = False) -> None:
        """Close both sides: what is already buffered for each is still sent (unless
        ``abort_client``: not the client's). A client gone without its close frame has one sent
        for it to the SDK's server, which would otherwise try to send it each message until it
        notices (a line on stderr each time)."""
        if self.closed:
            return
        self.closed = True
        for name in list(self.timers):
            self.cancel(name)
        up = None if self.upstream is None else self.upstream.transport
        if up is not None and not up.is_closing():
            if self.relaying and not self.sent.close_seen and self.sent.at_boundary:
                # the SDK's server stops sending once it has read the close frame: until it
                # closes (or 1 s) what it sends is read and dropped
                assert self.upstream is not None
                self.upstream.dropping = True
                up.write(client_close_frame())
                up.resume_reading()
                self.front.loop.call_later(CLOSE_WAIT_S, up.close)
            else:
                up.close()
        t = self.transport
        if t is not None and not t.is_closing():
            if abort_client:
                t.abort()
            else:
                t.close()

    def abort(self) -> None:
        """Drop both connections now, buffers and all."""
        self.closed = True
        for t in (self.transport, None if self.upstream is None else self.upstream.transport):
            if t is not None:
                t.abort()


class _Upstream(asyncio.Protocol):
    """The front's connection to the SDK's server for one client."""

    def __init__(self, client: _Client, chosen: str) -> None:
        self.client = client
        self.chosen = chosen
        self.transport: asyncio.Transport | None = None
        self.head = bytearray()
        #: the client is gone: what the SDK's server sends is dropped
        self.dropping = False
        self._quickack: Callable[[], None] | None = None

    def connection_made(self, transport: asyncio.BaseTransport) -> None:
        assert isinstance(transport, asyncio.Transport)
        self.transport = transport
        transport.set_write_buffer_limits(high=self.client.front.buffer_bytes)
        self.client.upstream = self
        self.client.front.upstreams.add(self)
        sock = transport.get_extra_info("socket")
        if hasattr(socket, "TCP_QUICKACK") and sock is not None:  # Linux
            # acknowledge at once: the SDK's Nagle then holds no message back for 40 ms
            self._quickack = lambda: sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_QUICKACK, 1)
            self._quickack()

    def data_received(self, data: bytes) -> None:
        if self._quickack is not None:
            self._quickack()
        if self.dropping:
            return
        c = self.client
        assert c.transport is not None
        if c.relaying:
            c.transport.write(data)
            return
        self.head += data
        end = self.head.find(b"\r\n\r\n")
        if end < 0:
            if len(self.head) > MAX_HEAD:
                c.front.say(c.peer, "upstream", f"dropped the client at {c.peer}: the live "
                            f"server's answer to its handshake is over {MAX_HEAD} bytes")
                c.abort()
            return
        response, rest = bytes(self.head[:end + 4]), bytes(self.head[end + 4:])
        self.head.clear()
        first, _ = _parse_head(response)
        c.relaying = True
        c.cancel("handshake")
        if first.split(" ")[1:2] == ["101"]:
            if self.chosen != SDK_SUBPROTOCOL:  # else the SDK's answer as it is
                response = _rewrite_protocol(response, self.chosen)
            c.front.stats.served += 1
            by = c.front.stats.by_subprotocol
            by[self.chosen] = by.get(self.chosen, 0) + 1
        else:  # the SDK refused it: its answer goes to the client as it is
            c.front.say(c.peer, "upstream", f"the live server refused the client at {c.peer} "
                        f"({first})")
        c.transport.write(response + rest)
        c.transport.resume_reading()

    def pause_writing(self) -> None:  # the SDK's server is behind the client: rare
        if self.client.transport is not None and not self.dropping:
            self.client.transport.pause_reading()

    def resume_writing(self) -> None:
        if self.client.transport is not None and not self.dropping:
            self.client.transport.resume_reading()

    def eof_received(self) -> bool:
        return False

    def connection_lost(self, exc: Exception | None) -> None:
        self.client.front.upstreams.discard(self)
        self.client.close()


class SubprotocolFront:
    """Serve Foxglove WebSocket clients of either subprotocol name on ``host:port``, relaying
    them to foxglove-sdk's server on ``127.0.0.1:upstream_port``.

    :param warn: called (on the front's thread) with one line per refusal, slow or stalled
        client; the same line for the same client host is said at most once in 10 s.
    :param backlog: the SDK server's message backlog per client, for the slow client's line.
    """

    def __init__(self, host: str, port: int, upstream_port: int, *,
                 warn: Callable[[str], None], backlog: int = 1024,
                 buffer_bytes: int = BUFFER_BYTES, max_clients: int = MAX_CLIENTS,
                 slow_notice_s: float = SLOW_NOTICE_S, stall_close_s: float = STALL_CLOSE_S
                 ) -> None:
        self.host = host
        self.port = port
        self.upstream_port = upstream_port
        self.warn = warn
        self.backlog = backlog
        self.buffer_bytes = buffer_bytes
        self.max_clients = max_clients
        self.slow_notice_s = slow_notice_s
        self.stall_close_s = stall_close_s
        self.stats = FrontStats()
        self.clients: set[_Client] = set()
        self.upstreams: set[_Upstream] = set()
        self.loop = asyncio.new_event_loop()
        self.loop.set_exception_handler(self._loop_error)
        self._servers: list[asyncio.Server] = []
        self._said: dict[tuple[str, str], float] = {}
        self._thread: threading.Thread | None = None
        self._closed = False

    def start(self) -> int:
        """Listen (every address ``host`` resolves to, on one port) and start the loop's
        thread; returns the port. Raises :class:`OSError` when it cannot listen."""
        self._thread = threading.Thread(target=self.loop.run_forever, name="live-front",
                                        daemon=True)
        self._thread.start()
        try:
            self.port = self.call(self._listen()).result()
        except BaseException:
            self.close()
            raise
        return self.port

    def call(self, coro: Coroutine[object, object, T]) -> Future[T]:
        """Run ``coro`` on the front's loop (thread-safe)."""
        return asyncio.run_coroutine_threadsafe(coro, self.loop)

    async def _listen(self) -> int:
        infos = socket.getaddrinfo(self.host, self.port, type=socket.SOCK_STREAM,
                                   flags=socket.AI_PASSIVE)
        port = self.port
        unique = list({(family, addr[0]): (family, kind, proto, addr)
                       for family, kind, proto, _, addr in infos}.values())
        for family, kind, proto, addr in unique:
            sock = socket.socket(family, kind, proto)
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                if family == socket.AF_INET6 and len(unique) > 1:  # "::" alone: both families
                    sock.setsockopt(socket.IPPROTO_IPV6, socket.IPV6_V6ONLY, 1)
                sock.bind((addr[0], port, *addr[2:]))
                sock.listen(128)
                sock.setblocking(False)
            except OSError:
                sock.close()
                raise
            # the first address's port (the one chosen when 0 was asked) for every address
            port = sock.getsockname()[1]
            self._servers.append(await self.loop.create_server(lambda: _Client(self),
                                                               sock=sock))
        return port

    def waiting_bytes(self) -> list[int]:
        """Bytes waiting to be sent to each connected client (thread-safe)."""
        async def sizes() -> list[int]:
            return [c.transport.get_write_buffer_size() for c in self.clients
                    if c.transport is not None]

        return list(self.call(sizes()).result(5.0))

    def say(self, host_port: str, key: str, line: str) -> None:
        """``warn(line)``, unless the same ``key`` for the same client host was said in the
        last 10 s."""
        host = host_port.rpartition(":")[0]
        now = time.monotonic()
        if now - self._said.get((host, key), -1e9) < _REPEAT_S:
            return
        self._said[(host, key)] = now
        if len(self._said) > 1000:
            self._said = {k: t for k, t in self._said.items() if now - t < _REPEAT_S}
        with contextlib.suppress(Exception):  # a failing warn must not stop the front
            self.warn(line)

    def _loop_error(self, loop: asyncio.AbstractEventLoop, context: dict[str, object]) -> None:
        exc = context.get("exception")
        what = f"{type(exc).__name__}: {exc}" if exc is not None else context.get("message")
        self.say("front:0", "error", f"the live server's front failed ({what}); its other "
                 f"clients go on")

    async def _shutdown(self, grace_s: float) -> None:
        for server in self._servers:
            server.close()
        for c in list(self.clients):
            c.close()  # what is buffered for it is still sent: the SDK's close frame
        deadline = time.monotonic() + grace_s
        while (self.clients or self.upstreams) and time.monotonic() < deadline:
            await asyncio.sleep(0.01)
        for c in list(self.clients):
            c.abort()
        for u in list(self.upstreams):
            if u.transport is not None:
                u.transport.abort()
        for server in self._servers:
            await server.wait_closed()

    def close(self, grace_s: float = 1.0) -> None:
        """Stop listening, close every client's connection (what is buffered for it is sent
        for up to ``grace_s`` s), stop the loop's thread (idempotent)."""
        if self._closed:
            return
        self._closed = True
        if self._thread is not None and self._thread.is_alive():
            with contextlib.suppress(Exception):
                self.call(self._shutdown(grace_s)).result(grace_s + 5.0)
            self.loop.call_soon_threadsafe(self.loop.stop)
            self._thread.join(5.0)
        if not self.loop.is_running():
            self.loop.close()
