"""Decode a log's NAV350 traffic (/nav350/tx, /nav350/rx) into /nav/pose and /nav/reflectors.

Used by ``lgvtool decode`` and by the simulator's NAV350 mode. The requests are decoded from
the tx stream and matched with the replies of the rx stream, in log-time order; clock reads
(``mNAVGetTimestamp``) feed the same online estimate the recorder keeps, so a re-decoded log
gets the same device-to-host times as the recording (both use only what came before).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from lgvtool.devices.log_decoding import error_summary
from lgvtool.devices.nav350.nav350_clock import ClockEstimator
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.devices.nav350.nav350_telegrams import PoseData, Telegram
from lgvtool.json_types import JSONObject
from lgvtool.log import topics
from lgvtool.log.messages import nav350_pose_message, nav350_scan_message
from lgvtool.wire.decode_events import STREAM_EVENT_KINDS, DecodeEvent, DecoderStats

__all__ = ["Nav350LogDecoder"]

_REPLY_KIND = {"sMN": "sAN", "sRN": "sRA", "sWN": "sWA", "sEN": "sEA"}


@dataclass
class Nav350LogDecoder:
    """The NAV350's :class:`~lgvtool.devices.log_decoding.LogDecoder`: feed raw chunks with
    :meth:`chunk` (or :meth:`sent` and :meth:`received`; host ns); collect messages
    ``(topic, message, log_time_ns)`` from :meth:`pop_messages` and events from
    :meth:`pop_events`. ``map_id``: device global id -> map id (None: the same)."""

    decoded_topics: frozenset[str] = frozenset({topics.NAV_POSE, topics.NAV_REFLECTORS})
    sources: frozenset[str] = frozenset({"nav350"})
    event_kinds: frozenset[str] = STREAM_EVENT_KINDS

    map_id: Mapping[int, int] | None = None
    requests: Nav350StreamDecoder = field(default_factory=Nav350StreamDecoder)
    replies: Nav350StreamDecoder = field(default_factory=Nav350StreamDecoder)
    clock: ClockEstimator = field(default_factory=ClockEstimator)
    poses: int = 0
    scans: int = 0
    landmarks: int = 0
    last_ns: int = 0
    _pending: list[tuple[Telegram, int]] = field(default_factory=list)
    _messages: list[tuple[str, dict[str, Any], int]] = field(default_factory=list)

    def _host_ns(self, tick: int) -> int | None:
        host = self.clock.host_time_of(tick)
        return None if host is None else round(host * 1e9)

    def chunk(self, topic: str, data: bytes, t_ns: int) -> None:
        """One raw chunk of /nav350/tx (host wrote) or /nav350/rx (host read) at ``t_ns``."""
        if topic == topics.NAV350_TX:
            self.sent(data, t_ns)
        elif topic == topics.NAV350_RX:
            self.received(data, t_ns)
        else:
            return
        self.last_ns = t_ns

    def sent(self, data: bytes, t_ns: int) -> None:
        """Bytes the host wrote at ``t_ns``."""
        for request in self.requests.feed(data):
            if request.is_request:
                self._pending.append((request, t_ns))
                del self._pending[:-8]

    def received(self, data: bytes, t_ns: int) -> None:
        """Bytes the host read at ``t_ns``."""
        for reply in self.replies.feed(data):
            self._on_reply(reply, t_ns)

    def _match(self, reply: Telegram) -> tuple[Telegram, int] | None:
        for i, (req, t) in enumerate(self._pending):
            if reply.is_error or (reply.kind == _REPLY_KIND.get(req.kind)
                                  and reply.name == req.name):
                del self._pending[:i + 1]
                return req, t
        return None

    def _on_reply(self, reply: Telegram, t_ns: int) -> None:
        if reply.kind == "sMA":
            return
        matched = self._match(reply)
        if reply.name == "mNAVGetTimestamp" and matched is not None and reply.fields:
            self.clock.add(int(reply.fields[1]), matched[1] / 1e9, t_ns / 1e9)
        elif reply.name in ("mNPOSGetData", "mNLMDGetData") and isinstance(reply.value,
                                                                            PoseData):
            self._on_data(reply.value, t_ns)

    def _on_data(self, data: PoseData, t_ns: int) -> None:
        pose = nav350_pose_message(data, t_ns, self._host_ns)
        if pose is not None:
            self._messages.append((topics.NAV_POSE, pose, t_ns))
            self.poses += 1
        scan = nav350_scan_message(data, t_ns, self._host_ns, self.map_id)
        if scan is not None:
            self._messages.append((topics.NAV_REFLECTORS, scan, t_ns))
            self.scans += 1
            observations = scan["observations"]
            assert isinstance(observations, list)  # as nav350_scan_message builds it
            self.landmarks += len(observations)

    def pop_messages(self) -> list[tuple[str, JSONObject, int]]:
        """Decoded messages since the last call, in order."""
        out, self._messages = self._messages, []
        return out

    def pop_events(self) -> list[DecodeEvent]:
        """Decoder events of both directions since the last call."""
        return [*self.requests.pop_events(), *self.replies.pop_events()]

    def finish(self, t_ns: int) -> None:
        """End of the log: decode what remains (at ``t_ns``), count telegrams cut off."""
        self.requests.flush()
        for reply in self.replies.flush():
            self._on_reply(reply, t_ns)

    def report(self) -> JSONObject:
        """``{"poses", "scans", "landmarks", "stats"}`` (stats: of the reply stream)."""
        return {"poses": self.poses, "scans": self.scans, "landmarks": self.landmarks,
                "stats": dict(self.stats.as_dict())}

    def summary(self) -> list[str]:
        """``nav350: N poses, M scans (K landmarks); errors: ...``."""
        return [f"nav350: {self.poses} poses, {self.scans} scans ({self.landmarks} landmarks);"
                f" errors: {error_summary(self.stats.as_dict())}"]

    def stats_metadata(self) -> dict[str, dict[str, int]]:
        """``{"nav350": reply stats}``."""
        return {"nav350": self.stats.as_dict()}

    @property
    def stats(self) -> DecoderStats:
        """Counters of the reply stream."""
        return self.replies.stats
