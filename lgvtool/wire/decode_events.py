"""Error counters and events reported by the stream decoders and the NAV200 host session.

A decoder never raises from ``feed()``: every problem is counted in a :class:`DecoderStats` and,
where a log or a user should hear about it, also reported as a :class:`DecodeEvent`, which maps
one to one onto an ``lgvtool.Diagnostic`` message.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from lgvtool.json_types import JSONObject, JSONRecord, as_int

#: Severity levels, as in foxglove.Log and lgvtool.Diagnostic.
DEBUG, INFO, WARNING, ERROR, FATAL = 1, 2, 3, 4, 5


@dataclass
class DecoderStats:
    """Counts of what a stream decoder has seen since it was created (all dimensionless counts).

    Invariant: ``bytes_received == bytes_decoded + bytes_skipped + bytes_pending`` where
    ``bytes_pending`` is what the decoder still holds waiting for more input.
    """

    #: bytes passed to ``feed()``
    bytes_received: int = 0
    #: bytes that belong to a delivered frame or telegram
    bytes_decoded: int = 0
    #: bytes not part of any delivered frame (garbage, rejected candidates, skipped frames)
    bytes_skipped: int = 0
    #: frames or telegrams delivered
    frames: int = 0
    #: candidates whose BCC (NAV200) or CRC-16 (MCU) did not check
    bad_checksum: int = 0
    #: candidates with an impossible length or one that does not match the command / version
    bad_length: int = 0
    #: MCU frames with a valid CRC but an unknown format version (skipped whole)
    unknown_version: int = 0
    #: NAV200 telegrams with a valid BCC but unknown mode/function letters
    unknown_command: int = 0
    #: incomplete frames discarded by ``flush()`` at the end of the stream
    truncated: int = 0
    #: MCU sequence gaps (one per jump)
    seq_gaps: int = 0
    #: MCU frames missing in those gaps (sum of the gap sizes)
    frames_missing: int = 0
    #: MCU frames that repeat the previous sequence number
    seq_repeats: int = 0
    #: MCU sequence jumps backwards (out of order, or a restart without the MCU_RESET bit)
    seq_resets: int = 0
    #: MCU restarts announced by the MCU_RESET status bit
    mcu_resets: int = 0
    #: NAV200 error replies (function 'E')
    error_replies: int = 0
    #: NAV200 replies that do not answer the pending request (host session)
    unexpected_reply: int = 0
    #: NAV200 requests superseded before their reply arrived (host session)
    unanswered: int = 0

    #: counters that are errors (all but the byte and frame totals)
    ERROR_KINDS = (
        "bad_checksum",
        "bad_length",
        "unknown_version",
        "unknown_command",
        "truncated",
        "seq_gaps",
        "seq_repeats",
        "seq_resets",
        "mcu_resets",
        "error_replies",
        "unexpected_reply",
        "unanswered",
    )

    def as_dict(self) -> dict[str, int]:
        """All counters by name, in declaration order."""
        return {f.name: int(getattr(self, f.name)) for f in fields(self)}

    def errors(self) -> dict[str, int]:
        """The non-zero error counters by kind (``bytes_skipped`` included when non-zero)."""
        out = {k: int(getattr(self, k)) for k in ("bytes_skipped", *self.ERROR_KINDS)}
        return {k: v for k, v in out.items() if v}

    @property
    def total_errors(self) -> int:
        """Sum of the error counters (not counting skipped bytes or missing frames)."""
        return sum(int(getattr(self, k)) for k in self.ERROR_KINDS)

    def merge(self, other: DecoderStats) -> DecoderStats:
        """A new stats object with the counters of ``self`` and ``other`` added."""
        return DecoderStats(
            **{f.name: getattr(self, f.name) + getattr(other, f.name) for f in fields(self)}
        )


#: The kinds of the events a stream decoder reports (:class:`DecodeEvent`): the error counters
#: of :class:`DecoderStats` it raises, skipped bytes, the MCU's sequence checks and a device's
#: error reply. A re-decode of a log writes these anew (``lgvtool decode``).
STREAM_EVENT_KINDS = frozenset({
    "bad_checksum", "bad_length", "unknown_version", "unknown_command", "truncated",
    "bytes_skipped", "seq_gap", "seq_repeat", "seq_reset", "mcu_reset", "device_error"})


@dataclass(frozen=True)
class DecodeEvent:
    """Something a decoder reports: an error, a resynchronisation, a sequence gap.

    The fields match ``lgvtool.Diagnostic``: ``kind`` is a machine-readable name (the
    :class:`DecoderStats` counter for errors, e.g. ``bad_checksum``; ``bytes_skipped``,
    ``seq_gap``, ``seq_repeat``, ``seq_reset``, ``mcu_reset``, ``device_error``,
    ``unexpected_reply``, ``unanswered`` otherwise), ``details`` keys carry their unit in
    the name (``offset_bytes``, ``first_missing_seq``, ...). ``offset_bytes`` is the position in
    the decoder's input stream (bytes since the first byte fed) where the event happened.
    """

    source: str
    kind: str
    message: str
    level: int = WARNING
    count: int = 1
    details: JSONObject = field(default_factory=dict)

    def diagnostic(self, timestamp: JSONRecord) -> JSONObject:
        """This event as an ``lgvtool.Diagnostic`` message dict at host time ``timestamp``.

        ``timestamp`` is ``{"sec": s, "nsec": ns}``.
        """
        return {
            "timestamp": {"sec": as_int(timestamp["sec"]), "nsec": as_int(timestamp["nsec"])},
            "level": self.level,
            "source": self.source,
            "kind": self.kind,
            "message": self.message,
            "count": self.count,
            "details": dict(self.details),
        }
