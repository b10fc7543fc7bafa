"""A minimal Foxglove WebSocket client for the tests (the ``websockets`` package).

It speaks the foxglove.websocket.v1 protocol: it reads ``serverInfo`` and ``advertise``,
subscribes to the topics asked for and decodes the binary ``messageData`` frames (opcode 1,
subscription id u32, log time u64, payload). It offers both subprotocol names, the protocol's
own and foxglove-sdk's (``foxglove.sdk.v1``, the same protocol), unless told which to offer.
"""

from __future__ import annotations

import asyncio
import json
import struct
import time
from dataclasses import dataclass, field
from typing import Any

SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]


@dataclass
class Received:
    """What a client saw: the server's info, the channels advertised by topic, the messages
    per topic (log time ns, decoded JSON), and the wall time from subscribing to each topic's
    first message, s."""

    subprotocol: str | None = None
    server_info: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, dict[str, Any]] = field(default_factory=dict)
    messages: dict[str, list[tuple[int, Any]]] = field(default_factory=dict)
    first_after_subscribe_s: dict[str, float] = field(default_factory=dict)
    times: list[int] = field(default_factory=list)


async def _collect(url: str, topics: set[str] | None, *, until: float,
                   wanted: int | dict[str, int],
                   disconnect_after: int | None, subprotocols: list[str]) -> Received:
    import websockets

    got = Received()
    subscribed: dict[int, str] = {}
    sub_time: dict[str, float] = {}
    next_id = 1
    total = 0
    async with websockets.connect(url, subprotocols=subprotocols,  # type: ignore[arg-type]
                                  open_timeout=5, max_size=None,
                                  # foxglove-sdk 0.30 often leaves a client's close frame
                                  # unanswered while it streams (the close times out)
                                  close_timeout=1) as ws:
        got.subprotocol = ws.subprotocol
        while time.monotonic() < until:
            try:
                frame = await asyncio.wait_for(ws.recv(), max(0.01, until - time.monotonic()))
            except (TimeoutError, websockets.ConnectionClosed):
                break
            if isinstance(frame, str):
                msg = json.loads(frame)
                if msg["op"] == "serverInfo":
                    got.server_info = msg
                elif msg["op"] == "advertise":
                    subs = []
                    for ch in msg["channels"]:
                        got.channels[ch["topic"]] = ch
                        if topics is None or ch["topic"] in topics:
                            subscribed[next_id] = ch["topic"]
                            subs.append({"id": next_id, "channelId": ch["id"]})
                            sub_time[ch["topic"]] = time.monotonic()
                            next_id += 1
                    if subs:
                        await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
                elif msg["op"] == "time":
                    got.times.append(int(msg["timestamp"]))
                continue
            opcode = frame[0]
            if opcode == 2:  # time
                got.times.append(struct.unpack_from("<Q", frame, 1)[0])
                continue
            if opcode != 1:
                continue
            sub_id, t_ns = struct.unpack_from("<IQ", frame, 1)
            topic = subscribed[sub_id]
            if topic not in got.first_after_subscribe_s:
                got.first_after_subscribe_s[topic] = time.monotonic() - sub_time[topic]
            got.messages.setdefault(topic, []).append((t_ns, json.loads(frame[13:])))
            total += 1
            if disconnect_after is not None and total >= disconnect_after:
                break
            if topics is not None and all(
                    len(got.messages.get(t, [])) >= (wanted.get(t, 1) if isinstance(wanted, dict)
                                                     else wanted) for t in topics):
                break
    return got


def collect(url: str, topics: set[str] | None = None, *, timeout: float = 20.0,
            wanted: int | dict[str, int] = 1, disconnect_after: int | None = None,
            subprotocols: list[str] | None = None) -> Received:
    """Connect to ``url`` offering ``subprotocols`` (None: both names), subscribe to
    ``topics`` (None: every channel) as they are advertised, and receive until each has
    ``wanted`` messages (a dict: per topic, 1 for a topic it lacks), ``disconnect_after``
    messages in all have arrived (then drop the connection), or ``timeout`` s have passed."""
    return asyncio.run(_collect(url, topics, until=time.monotonic() + timeout, wanted=wanted,
                                disconnect_after=disconnect_after,
                                subprotocols=subprotocols or SUBPROTOCOLS))
