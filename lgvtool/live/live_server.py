"""The live server: log topics as Foxglove WebSocket channels (``foxglove-sdk``).

Each topic becomes one channel the first time a message is published on it, with the schema
name, the ``jsonschema`` schema and the ``json`` encoding the log gives it, so a Foxglove panel
that opens a log file opens the live view unchanged. The server binds ``127.0.0.1`` unless a
host is given. Publishing never blocks: the SDK keeps a bounded backlog per client and drops the
oldest message of a client that cannot keep up, so a slow or vanished client never holds up the
caller (the recorder's writer thread). A client that subscribes to a channel is sent the last
message of that channel at once (the map and the scene are published once, at the start; a
client connecting later still sees them).

foxglove-sdk's server listens on ``127.0.0.1`` at a port of its own; the user's address is
served by :class:`lgvtool.live.front.SubprotocolFront`, which accepts clients offering the
subprotocol ``foxglove.sdk.v1`` or its older name ``foxglove.websocket.v1`` (which the SDK
refuses) and relays them to the SDK's server.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from lgvtool.errors import InputError
from lgvtool.extras import require

if TYPE_CHECKING:
    from foxglove import Channel
    from foxglove.websocket import ChannelView, Client

__all__ = ["DEFAULT_HOST", "DEFAULT_PORT", "LiveAddress", "LiveServer", "parse_address"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
#: the WebSocket subprotocol foxglove-sdk speaks (the foxglove.websocket.v1 protocol, renamed)
SUBPROTOCOL = "foxglove.sdk.v1"
#: the SDK server's message backlog per client (its default): past it a slow client's oldest
#: messages are dropped
BACKLOG = 1024


def _to_stderr(line: str) -> None:
    print(f"lgvtool: live view: {line}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class LiveAddress:
    """Where the live server listens: ``host`` (name or address) and TCP ``port`` (0: any)."""

    host: str = DEFAULT_HOST
    port: int = DEFAULT_PORT

    def __str__(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{host}:{self.port}"


def parse_address(text: str) -> LiveAddress:
    """``[HOST:]PORT`` (``[v6addr]:PORT`` for IPv6) as a :class:`LiveAddress`; the host
    defaults to ``127.0.0.1``. Raises :class:`InputError` on anything else."""
    s = text.strip()
    host = DEFAULT_HOST
    port_text = s
    if s.startswith("["):
        end = s.find("]")
        if end < 0 or s[end + 1:end + 2] != ":":
            raise InputError(f"--live: {text!r} is not [HOST:]PORT")
        host, port_text = s[1:end], s[end + 2:]
    elif ":" in s:
        host, _, port_text = s.rpartition(":")
    if not host:
        raise InputError(f"--live: {text!r} has an empty host")
    try:
        port = int(port_text)
    except ValueError:
        raise InputError(f"--live: {text!r} is not [HOST:]PORT (the port must be a number)"
                         ) from None
    if not 0 <= port <= 65535:
        raise InputError(f"--live: port {port} is outside 0-65535")
    return LiveAddress(host, port)


def _check_host(address: LiveAddress) -> None:
    """Resolve the host now, so a name that does not resolve fails with a clear line."""
    import socket

    try:
        socket.getaddrinfo(address.host, address.port, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as exc:
        raise InputError(f"--live: host {address.host!r} does not resolve ({exc})") from None


class _Listener:
    """Server callbacks: a new subscription is sent the channel's last message."""

    def __init__(self, server: LiveServer) -> None:
        self._server = server

    def on_subscribe(self, client: Client, channel: ChannelView) -> None:
        self._server.resend_last(str(channel.topic))

    def __getattr__(self, name: str) -> Any:
        if name.startswith("on_"):
            return lambda *args: None
        raise AttributeError(name)


class LiveServer:
    """A Foxglove WebSocket server publishing log messages.

    :param address: where to listen (the front, :class:`lgvtool.live.front.SubprotocolFront`;
        foxglove-sdk's server itself listens on ``127.0.0.1`` at a port of its own).
    :param name: server name shown by Foxglove.
    :param warn: called with one line when the front refuses a client (what it offered, what
        is accepted) or a client falls behind; default: printed on stderr, after
        ``lgvtool: live view:``.
    :raises InputError: the host does not resolve, the port is in use, or ``foxglove-sdk`` is
        not installed.
    """

    def __init__(self, address: LiveAddress, *, name: str = "lgvtool",
                 warn: Callable[[str], None] | None = None) -> None:
        _check_host(address)
        require("--live", "live", "foxglove")
        import foxglove
        from foxglove.websocket import Capability

        from lgvtool.live.front import SubprotocolFront

        self._fox = foxglove
        self._context = foxglove.Context()
        self._last: dict[str, tuple[bytes, int]] = {}
        try:
            self._server = foxglove.start_server(
                name=name, host="127.0.0.1", port=0, context=self._context,
                capabilities=[Capability.Time], server_listener=_Listener(self),
                message_backlog_size=BACKLOG)
        except (RuntimeError, OSError, ValueError) as exc:
            why = str(exc).removeprefix("FoxgloveError: ")
            raise InputError(f"--live {address}: cannot start the server: {why}") from None
        #: where foxglove-sdk's own server listens (loopback; clients offering foxglove.sdk.v1
        #: only; for measurements)
        self.sdk_address = LiveAddress("127.0.0.1", int(self._server.port))
        self.front = SubprotocolFront(address.host, address.port, self.sdk_address.port,
                                      warn=warn or _to_stderr, backlog=BACKLOG)
        try:
            port = self.front.start()
        except OSError as exc:
            self._server.stop()
            raise InputError(f"--live {address}: cannot listen: {exc.strerror or exc}"
                             ) from None
        self.address = LiveAddress(address.host, port)
        self._channels: dict[str, Channel] = {}
        self._lock = threading.Lock()
        self._closed = False
        #: messages published per topic
        self.counts: dict[str, int] = {}

    @property
    def url(self) -> str:
        """The ``ws://`` URL clients connect to."""
        return f"ws://{self.address}"

    @property
    def sdk_url(self) -> str:
        """The ``ws://`` URL of foxglove-sdk's own server, behind the front (loopback,
        ``foxglove.sdk.v1`` only): for measuring the front."""
        return f"ws://{self.sdk_address}"

    def channel_id(self, topic: str) -> int | None:
        """The id of the channel of ``topic``, None before its first message."""
        ch = self._channels.get(topic)
        return None if ch is None else int(ch.id())

    def _channel(self, topic: str, schema_name: str) -> Channel:
        ch = self._channels.get(topic)
        if ch is None:
            from lgvtool.log.schemas import schema_bytes

            with self._lock:
                ch = self._channels.get(topic)
                if ch is None:
                    schema = self._fox.Schema(name=schema_name, encoding="jsonschema",
                                              data=schema_bytes(schema_name))
                    ch = self._fox.Channel(topic, schema=schema, message_encoding="json",
                                           context=self._context)
                    self._channels[topic] = ch
        return ch

    def prepare(self, channels: dict[str, str]) -> None:
        """Advertise ``{topic: schema name}`` now, before their first message.

        A client that subscribes the moment a channel is advertised can be refused by the
        server ("unknown channel") while the channel is being registered; channels made before
        any client connects do not meet that race."""
        for topic, schema in channels.items():
            if schema:
                self._channel(topic, schema)

    def publish(self, topic: str, schema_name: str, data: bytes, log_time_ns: int) -> None:
        """Publish one JSON-encoded message of schema ``schema_name`` on ``topic`` (thread-safe,
        never blocks)."""
        if self._closed:
            return
        self._channel(topic, schema_name).log(data, log_time=int(log_time_ns))
        self._last[topic] = (data, int(log_time_ns))
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def resend_last(self, topic: str) -> None:
        """Publish the last message of ``topic`` again (for a client that just subscribed)."""
        last = self._last.get(topic)
        ch = self._channels.get(topic)
        if last is not None and ch is not None and not self._closed:
            ch.log(last[0], log_time=last[1])

    def broadcast_time(self, t_ns: int) -> None:
        """Tell clients the current time of the data (ns since the epoch): a log played back."""
        if not self._closed:
            self._server.broadcast_time(int(t_ns))

    def close(self) -> None:
        """Stop the server (idempotent)."""
        if self._closed:
            return
        self._closed = True
        for ch in self._channels.values():
            ch.close()
        self._server.stop()
        self.front.close()

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
