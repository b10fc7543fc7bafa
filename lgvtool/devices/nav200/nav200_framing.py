"""NAV200 telegram framing: STX, LEN, mode, function, data, XOR BCC.

::

    off  size  field
    0    1     STX = 0x02
    1    1     LEN = length of the whole telegram (STX through BCC) = 5 + n
    2    1     mode, one ASCII letter (S, R, M, P, U, D)
    3    1     function, one ASCII letter ('E' marks an error reply)
    4    n     data, packed, little-endian
    4+n  1     BCC = XOR of every byte from STX through the last data byte

The same framing carries requests (host -> device) and replies (device -> host).
"""

from __future__ import annotations

from dataclasses import dataclass

from lgvtool.wire.checksum import xor_bcc
from lgvtool.wire.wire_errors import (
    BadLengthError,
    BadSyncError,
    ChecksumError,
    EncodeError,
    TruncatedError,
)

#: Start of every telegram.
STX = 0x02
#: Smallest possible LEN: STX, LEN, mode, function, BCC with no data.
MIN_LEN = 5
#: Largest possible LEN (one byte).
MAX_LEN = 255
#: Largest data block: MAX_LEN - 5.
MAX_DATA = MAX_LEN - MIN_LEN


def is_letter(byte: int) -> bool:
    """True for an ASCII letter A-Z or a-z, the only bytes allowed as mode and function."""
    return 0x41 <= byte <= 0x5A or 0x61 <= byte <= 0x7A


@dataclass(frozen=True)
class Telegram:
    """One NAV200 telegram without its framing: mode and function letters plus raw data.

    ``mode`` and ``function`` are one-character strings (latin-1 decoded bytes).
    """

    mode: str
    function: str
    data: bytes = b""

    @property
    def code(self) -> str:
        """Mode and function together, e.g. ``"PP"``."""
        return self.mode + self.function

    @property
    def length(self) -> int:
        """The LEN field: 5 + number of data bytes."""
        return MIN_LEN + len(self.data)

    def encode(self) -> bytes:
        """The framed bytes: STX, LEN, mode, function, data, BCC."""
        return encode_telegram(self.mode, self.function, self.data)


def encode_telegram(mode: str, function: str, data: bytes = b"") -> bytes:
    """Frame ``data`` as a telegram; EncodeError for non-letter codes or data over 250 bytes."""
    if len(mode) != 1 or len(function) != 1:
        raise EncodeError(f"mode and function must be one letter each: {mode!r} {function!r}")
    head = (mode + function).encode("latin-1", errors="replace")
    if not (is_letter(head[0]) and is_letter(head[1])):
        raise EncodeError(f"mode and function must be ASCII letters: {mode!r} {function!r}")
    if len(data) > MAX_DATA:
        raise EncodeError(f"telegram data too long: {len(data)} > {MAX_DATA} bytes")
    body = bytes([STX, MIN_LEN + len(data)]) + head + bytes(data)
    return body + bytes([xor_bcc(body)])


def parse_telegram(raw: bytes | bytearray | memoryview) -> Telegram:
    """Parse exactly one framed telegram (``raw`` holds the whole telegram and nothing else).

    Raises BadSyncError (no STX), TruncatedError, BadLengthError (LEN < 5, or LEN not equal to
    the number of bytes), ChecksumError (BCC). The letters are not checked against the command
    table here: see :mod:`lgvtool.devices.nav200.nav200_commands`.
    """
    buf = bytes(raw)
    if not buf:
        raise TruncatedError("empty NAV200 telegram")
    if buf[0] != STX:
        raise BadSyncError(f"NAV200 telegram does not start with STX: {buf[0]:02X}")
    if len(buf) < 2:
        raise TruncatedError("NAV200 telegram truncated before LEN")
    length = buf[1]
    if length < MIN_LEN:
        raise BadLengthError(f"NAV200 LEN {length} is below the minimum of {MIN_LEN}")
    if len(buf) < length:
        raise TruncatedError(f"NAV200 telegram truncated: {len(buf)} of {length} bytes")
    if len(buf) > length:
        raise BadLengthError(f"NAV200 LEN {length} but {len(buf)} bytes given")
    if xor_bcc(buf) != 0:
        raise ChecksumError(f"NAV200 BCC {buf[-1]:02X}, computed {xor_bcc(buf[:-1]):02X}")
    return Telegram(chr(buf[2]), chr(buf[3]), buf[4:-1])
