"""The NAV200 reply matcher: pairs each reply with the request it answers (part of the codec).

Not a session: the host session of a recording is
:class:`lgvtool.devices.nav200.nav200_session.Nav200Session`, which runs one of these; the log
decoder (:mod:`lgvtool.devices.nav200.nav200_logdecode`) runs another over logged traffic.

No I/O and no clock: the caller writes the bytes that :meth:`Nav200ReplyMatcher.send` returns,
feeds what it reads, and calls :meth:`Nav200ReplyMatcher.cancel` when its own timeout expires.
To re-decode logged traffic, pass the logged host bytes to :meth:`Nav200ReplyMatcher.sent` and
the device bytes to :meth:`Nav200ReplyMatcher.feed`, in log-time order.
"""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.devices.nav200.nav200_commands import DeviceReply, Request, reply_matches
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder, Nav200RequestDecoder
from lgvtool.wire.decode_events import WARNING, DecodeEvent, DecoderStats


@dataclass(frozen=True)
class Exchange:
    """A reply and the request it answers (``request`` is None for an unexpected reply)."""

    request: Request | None
    reply: DeviceReply

    @property
    def matched(self) -> bool:
        """True when the reply answers a pending request."""
        return self.request is not None


class Nav200ReplyMatcher:
    """Request/reply bookkeeping of a NAV200 host, one request in flight at a time.

    ``stats`` are the reply decoder's counters plus ``unexpected_reply`` (a reply that does not
    answer the pending request, or arrives with none pending) and ``unanswered`` (a request
    superseded or cancelled before its reply). ``request_stats`` count the decoded host bytes
    given to :meth:`sent`.
    """

    def __init__(self) -> None:
        self._replies = Nav200ReplyDecoder()
        self._requests = Nav200RequestDecoder()
        self._events: list[DecodeEvent] = []
        self.pending: Request | None = None

    @property
    def stats(self) -> DecoderStats:
        """Counters of the device -> host direction and of the request/reply matching."""
        return self._replies.stats

    @property
    def request_stats(self) -> DecoderStats:
        """Counters of the host -> device bytes given to :meth:`sent`."""
        return self._requests.stats

    def send(self, request: Request) -> bytes:
        """Make ``request`` the pending one and return its bytes to write to the device."""
        self._set_pending(request)
        return request.encode()

    def sent(self, chunk: bytes | bytearray | memoryview) -> list[Request]:
        """Host bytes that were written (e.g. from a log): decode them, track the last request."""
        requests = self._requests.feed(chunk)
        for request in requests:
            self._set_pending(request)
        return requests

    def feed(self, chunk: bytes | bytearray | memoryview) -> list[Exchange]:
        """Device bytes received: return the completed replies with their requests."""
        return [self._match(reply) for reply in self._replies.feed(chunk)]

    def flush(self) -> list[Exchange]:
        """End of both streams: decode what remains, count truncated telegrams."""
        self._requests.flush()
        return [self._match(reply) for reply in self._replies.flush()]

    def cancel(self) -> Request | None:
        """Give up waiting for the pending request (the caller's timeout); return it."""
        request = self.pending
        if request is not None:
            self._unanswered(request)
        self.pending = None
        return request

    def pop_events(self) -> list[DecodeEvent]:
        """Events since the last call: decoder errors of both directions, then matching ones."""
        events = self._replies.pop_events() + self._requests.pop_events() + self._events
        self._events = []
        return events

    def _set_pending(self, request: Request) -> None:
        if self.pending is not None:
            self._unanswered(self.pending)
        self.pending = request

    def _unanswered(self, request: Request) -> None:
        self.stats.unanswered += 1
        self._events.append(
            DecodeEvent(
                "nav200",
                "unanswered",
                f"NAV200 {request.code} got no reply",
                WARNING,
                1,
                {"request": request.code},
            )
        )

    def _match(self, reply: DeviceReply) -> Exchange:
        request = self.pending
        if request is not None and reply_matches(request, reply):
            self.pending = None
            return Exchange(request, reply)
        self.stats.unexpected_reply += 1
        expected = request.reply_code if request is not None else None
        self._events.append(
            DecodeEvent(
                "nav200",
                "unexpected_reply",
                f"NAV200 {reply.code} reply "
                + (f"does not answer {request.code}" if request else "with no request pending"),
                WARNING,
                1,
                {"reply": reply.code, "expected_reply": expected},
            )
        )
        return Exchange(None, reply)
