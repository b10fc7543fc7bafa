"""Decode a log's NAV200 traffic (/nav200/tx, /nav200/rx) into /nav/pose, through the one
decoding path (:mod:`lgvtool.devices.log_decoding`).

Used by ``lgvtool decode`` and by the simulator's log writer. The host bytes go through the
request decoder and the device bytes through the reply decoder of a
:class:`~lgvtool.devices.nav200.nav200_matcher.Nav200ReplyMatcher`, in log-time order; every
pose reply (PP and friends) becomes a pose message with the log time of the chunk that
completed it, also the replies completed when the log ends.
"""

from __future__ import annotations

from lgvtool.devices.log_decoding import DecodedQueue, error_summary
from lgvtool.devices.nav200.nav200_commands import Reply
from lgvtool.devices.nav200.nav200_matcher import Exchange, Nav200ReplyMatcher
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.json_types import JSONObject
from lgvtool.log import topics
from lgvtool.log.messages import nav_pose_message
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import STREAM_EVENT_KINDS, DecodeEvent

__all__ = ["Nav200LogDecoder"]

#: Counters of the request stream that are not errors.
_NOT_ERRORS = ("bytes_received", "bytes_decoded", "frames")


class Nav200LogDecoder(DecodedQueue):
    """The NAV200's :class:`~lgvtool.devices.log_decoding.LogDecoder`:
    /nav200/tx + /nav200/rx -> /nav/pose."""

    decoded_topics = frozenset({topics.NAV_POSE})
    sources = frozenset({"nav200"})
    #: the stream's, and the reply matcher's requests left unanswered and replies that answer
    #: none
    event_kinds = STREAM_EVENT_KINDS | {"unanswered", "unexpected_reply"}

    def __init__(self) -> None:
        super().__init__()
        self.matcher = Nav200ReplyMatcher()
        self.requests = self.replies = self.poses = 0

    def _exchanges(self, exchanges: list[Exchange], t_ns: int) -> None:
        for exchange in exchanges:
            self.replies += 1
            reply = exchange.reply
            if isinstance(reply, Reply) and isinstance(reply.payload, Pose):
                self.emit(topics.NAV_POSE, nav_pose_message(reply, stamp(t_ns)), t_ns)
                self.poses += 1

    def chunk(self, topic: str, data: bytes, t_ns: int) -> None:
        """Bytes the host wrote (/nav200/tx) or read (/nav200/rx) at ``t_ns``."""
        if topic == topics.NAV_TX:
            self.requests += len(self.matcher.sent(data))
        elif topic == topics.NAV_RX:
            self._exchanges(self.matcher.feed(data), t_ns)
        else:
            return
        self.last_ns = t_ns

    def finish(self, t_ns: int) -> None:
        """End of the log: the replies still buffered, at ``t_ns``."""
        self._exchanges(self.matcher.flush(), t_ns)

    def pop_events(self) -> list[DecodeEvent]:
        """Decoder and matching events since the last call."""
        return self.matcher.pop_events()

    def report(self) -> JSONObject:
        """``{"replies", "poses", "requests", "stats", "request_stats"}``."""
        return {"replies": self.replies, "poses": self.poses, "requests": self.requests,
                "stats": dict(self.matcher.stats.as_dict()),
                "request_stats": dict(self.matcher.request_stats.as_dict())}

    def summary(self) -> list[str]:
        """The replies, poses and requests decoded, and the error counts."""
        stats = self.matcher.stats.as_dict()
        request_stats = self.matcher.request_stats.as_dict()
        lines = [f"nav200: {self.replies} replies ({self.poses} poses), {self.requests} "
                 f"requests; errors: {error_summary(stats)}"]
        if any(v for k, v in request_stats.items() if k not in _NOT_ERRORS):
            lines.append(f"nav200 requests: errors: {error_summary(request_stats)}")
        return lines

    def stats_metadata(self) -> dict[str, dict[str, int]]:
        """``{"nav200": reply stats, "nav200_requests": request stats}``."""
        return {"nav200": self.matcher.stats.as_dict(),
                "nav200_requests": self.matcher.request_stats.as_dict()}
