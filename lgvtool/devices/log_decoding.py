"""The one path from raw device bytes to the log's decoded messages.

Every device family has a log decoder (``devices/<family>/<family>_logdecode.py``) behind the
:class:`LogDecoder` interface: raw chunks of the family's raw topics go in with the host time
they were logged at (integer ns since the Unix epoch), decoded messages ``(topic, message dict,
log time ns)`` and decoder events come out. :func:`decode_chunk` and :func:`finish_decoding`
drive one: they feed it and write what it yields to a :class:`DecodedOutput`. ``lgvtool decode``
(:mod:`lgvtool.app.decode_job`), the simulator's log writer (``sim/logfile.py``) and the
recorder's MCU worker all decode through them; the NAV workers' poses come from their host
sessions (which own the request timing) and are built by the same :mod:`lgvtool.log.messages`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol

from lgvtool.json_types import JSONObject, JSONRecord
from lgvtool.wire.decode_events import DecodeEvent, DecoderStats

if TYPE_CHECKING:
    from lgvtool.log.writer import LogWriter

__all__ = ["Decoded", "DecodedOutput", "DecodedQueue", "LogDecoder", "WriterOutput", "decode_chunk",
           "error_summary", "finish_decoding"]

#: A decoded message: topic, message dict, log time in ns.
Decoded = tuple[str, JSONObject, int]


class LogDecoder(Protocol):
    """A device family's decoder of its raw log topics (see the module docstring)."""

    #: topics whose messages this decoder writes; a re-decode drops their old messages
    decoded_topics: frozenset[str]
    #: diagnostic sources of its events
    sources: frozenset[str]
    #: the kinds its events can have: a re-decode drops the old diagnostics of ``sources``
    #: with these kinds (it writes them anew) and keeps the others, which no decoding of the
    #: raw bytes can give again (the recorder's link and session events: link_down,
    #: device_silent, positioning_lost, clock, ...)
    event_kinds: frozenset[str]
    #: log time of the last chunk fed, ns (0 before the first)
    last_ns: int

    def chunk(self, topic: str, data: bytes, t_ns: int) -> None:
        """One raw chunk of ``topic`` logged at ``t_ns``."""

    def finish(self, t_ns: int) -> None:
        """End of the log: decode what remains, count what is cut off; what that completes
        gets log time ``t_ns``."""

    def pop_messages(self) -> list[Decoded]:
        """Decoded messages since the last call, in order."""

    def pop_events(self) -> list[DecodeEvent]:
        """Decoder events since the last call, in order."""

    def report(self) -> JSONObject:
        """The family's section of the decode report (JSON-able, stable keys)."""

    def summary(self) -> list[str]:
        """Human-readable report lines: what was decoded, the error counts."""

    def stats_metadata(self) -> dict[str, dict[str, int]]:
        """Decoder counters for the ``decode`` metadata record, name -> stats."""


class DecodedQueue:
    """What a family's log decoder shares: the messages decoded since the last
    :meth:`pop_messages`, and the log time of the last chunk fed (:attr:`last_ns`)."""

    def __init__(self) -> None:
        self.last_ns = 0
        self._messages: list[Decoded] = []

    def emit(self, topic: str, message: JSONObject, t_ns: int) -> None:
        """Queue ``message`` for ``topic`` at log time ``t_ns``."""
        self._messages.append((topic, message, t_ns))

    def pop_messages(self) -> list[Decoded]:
        """Decoded messages since the last call, in order."""
        out, self._messages = self._messages, []
        return out


class DecodedOutput(Protocol):
    """Where decoded messages and events go (:class:`~lgvtool.devices.logsink.LogSink`, or a
    :class:`~lgvtool.log.LogWriter` through :class:`WriterOutput`)."""

    def message(self, topic: str, message: JSONRecord, t_ns: int) -> None:
        """A decoded message dict for ``topic`` at log time ``t_ns``."""

    def event(self, event: DecodeEvent, t_ns: int) -> None:
        """A decoder event as a diagnostic at log time ``t_ns``."""


class WriterOutput:
    """A :class:`~lgvtool.log.LogWriter` as a :class:`DecodedOutput`."""

    def __init__(self, writer: LogWriter) -> None:
        self.writer = writer

    def message(self, topic: str, message: JSONRecord, t_ns: int) -> None:
        """Write ``message`` on ``topic``."""
        self.writer.write(topic, message, t_ns)

    def event(self, event: DecodeEvent, t_ns: int) -> None:
        """Write ``event`` on /diagnostics."""
        self.writer.write_diagnostic(event.source, event.kind, event.message, t_ns,
                                     level=event.level, count=event.count,
                                     details=event.details)


def _drain(decoder: LogDecoder, t_ns: int, out: DecodedOutput) -> int:
    for topic, message, at in decoder.pop_messages():
        out.message(topic, message, at)
    events = decoder.pop_events()
    for event in events:
        out.event(event, t_ns)
    return len(events)


def decode_chunk(decoder: LogDecoder, topic: str, data: bytes, t_ns: int,
                 out: DecodedOutput) -> int:
    """Feed one raw chunk logged at ``t_ns``; write its messages, then its events (at
    ``t_ns``); return the number of events."""
    decoder.chunk(topic, data, t_ns)
    return _drain(decoder, t_ns, out)


def finish_decoding(decoder: LogDecoder, out: DecodedOutput, t_ns: int | None = None) -> int:
    """End of the log: write what :meth:`LogDecoder.finish` completes, then its events, at
    ``t_ns`` (None: the decoder's last chunk time); return the number of events."""
    t = decoder.last_ns if t_ns is None else t_ns
    decoder.finish(t)
    return _drain(decoder, t, out)


def error_summary(stats: Mapping[str, int]) -> str:
    """The non-zero error counters of ``stats`` (``DecoderStats.as_dict()``), in a fixed order:
    ``"bad_checksum 2, seq_gaps 1, frames_missing 3"``, or ``"none"``."""
    kinds = DecoderStats.ERROR_KINDS
    keys = ("bytes_skipped", *kinds[: kinds.index("seq_gaps") + 1], "frames_missing",
            *kinds[kinds.index("seq_gaps") + 1 :])
    found = [f"{k} {stats[k]}" for k in keys if stats.get(k)]
    return ", ".join(found) if found else "none"
