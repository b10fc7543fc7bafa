"""Typed errors of the wire codecs.

Every error carries a machine-readable :attr:`WireError.kind`, the same string under which the
stream decoders count it in :class:`lgvtool.wire.decode_events.DecoderStats`. They are user-facing
(bad bytes in a user's log or on a user's serial line), so they subclass
:class:`lgvtool.errors.LgvError` and the command line reports them as one line (exit code 2).
"""

from __future__ import annotations

from lgvtool.errors import LgvError


class WireError(LgvError):
    """Bytes that do not form a valid frame or telegram, or a value that cannot be encoded."""

    kind: str = "wire_error"


class TruncatedError(WireError):
    """The bytes end before the frame or telegram does."""

    kind = "truncated"


class BadLengthError(WireError):
    """A length field is impossible, or does not match the command or frame version."""

    kind = "bad_length"


class ChecksumError(WireError):
    """The NAV200 XOR BCC or the MCU CRC-16 does not check."""

    kind = "bad_checksum"


class BadSyncError(WireError):
    """The bytes do not start with the frame's start marker (NAV200 STX, MCU sync word)."""

    kind = "bad_sync"


class UnknownVersionError(WireError):
    """An MCU frame with a valid CRC but a format version this lgvtool does not know."""

    kind = "unknown_version"


class UnknownCommandError(WireError):
    """A NAV200 telegram with a valid BCC whose mode/function letters are not in the table."""

    kind = "unknown_command"


class UnexpectedReplyError(WireError):
    """A NAV200 reply that does not answer the request the host session has pending."""

    kind = "unexpected_reply"


class EncodeError(WireError, ValueError):
    """A value is out of the range its wire field can carry (e.g. X beyond int32 mm)."""

    kind = "encode_range"


class DeviceErrorReply(WireError):
    """The NAV200 answered with an error telegram (function 'E').

    Raised by host-side code that wants an exception for it; ``reply`` is the decoded
    :class:`lgvtool.devices.nav200.nav200_commands.ErrorReply` with readable F1-F3 meanings.
    """

    kind = "device_error"

    def __init__(self, reply: object) -> None:
        super().__init__(f"NAV200 error reply: {reply}")
        self.reply = reply
