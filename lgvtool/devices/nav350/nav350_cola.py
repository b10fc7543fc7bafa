"""SOPAS CoLa framing of the NAV350, both dialects, and the field cursors of telegram bodies.

CoLa-B (binary)::

    02 02 02 02 | N (u32 big-endian, payload bytes) | payload (N bytes) | XOR of the payload

CoLa-A (ASCII)::

    02 | payload text | 03

The payload is the command text (``sMN SetAccessMode``), then, if there are arguments, one
space and the arguments: in CoLa-B raw big-endian values back to back, in CoLa-A one token per
value separated by spaces. CoLa-A numbers are written as upper-case hex when unsigned and as
decimal with an explicit sign when signed; reals as the hex of their IEEE-754 bits
(docs/protocol.md marks what is inferred).

The same body code serves both dialects: it reads and writes through a :class:`Reader` /
:class:`Writer` whose binary and ASCII forms share one method set.
"""

from __future__ import annotations

import struct
import sys
from array import array
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from lgvtool.wire.wire_errors import BadLengthError, BadSyncError, ChecksumError, TruncatedError

__all__ = [
    "ASCII",
    "BINARY",
    "ETX",
    "MAX_PAYLOAD",
    "STX",
    "STX4",
    "AsciiReader",
    "AsciiWriter",
    "BinaryReader",
    "BinaryWriter",
    "Frame",
    "Reader",
    "Writer",
    "encode_frame",
    "parse_frame",
    "reader_for",
    "writer_for",
    "xor_checksum",
]

#: The two dialects.
BINARY, ASCII = "binary", "ascii"
STX, ETX = 0x02, 0x03
STX4 = b"\x02\x02\x02\x02"
#: Largest payload accepted, bytes (the operating instructions: a telegram is at most 35 kB).
MAX_PAYLOAD = 35_000


def xor_checksum(data: bytes | bytearray | memoryview) -> int:
    """XOR of all bytes of ``data`` (0 for none): the CoLa-B checksum of a payload.

    Folds the bytes as one big integer, so an 8 kB payload takes microseconds, not a loop.
    """
    n = len(data)
    if n == 0:
        return 0
    if n >= 256:  # whole 8-byte words at C speed, then the rest
        import numpy as np

        words = n // 8
        folded = int(np.bitwise_xor.reduce(np.frombuffer(data, dtype=np.uint64, count=words)))
        tail = xor_checksum(bytes(data[words * 8:])) if n % 8 else 0
        return xor_checksum(folded.to_bytes(8, "little")) ^ tail
    x = int.from_bytes(data, "big")
    width = 1
    while width < n:
        width *= 2
    bits = width * 8
    while bits > 8:
        bits //= 2
        x = (x >> bits) ^ (x & ((1 << bits) - 1))
    return x


@dataclass(frozen=True, slots=True)
class Frame:
    """One framed telegram: its ``dialect``, the command ``kind`` (``sMN``, ``sAN``, ...),
    the ``name`` (``mNPOSGetData``; empty for ``sFA``) and the argument bytes ``args`` (raw
    binary values, or the ASCII argument text)."""

    dialect: str
    kind: str
    name: str
    args: bytes


def encode_frame(dialect: str, kind: str, name: str, args: bytes = b"") -> bytes:
    """The framed telegram of ``kind name args`` in ``dialect``."""
    head = kind if not name else f"{kind} {name}"
    payload = head.encode("ascii") + (b" " + args if args or kind == "sFA" else b"")
    if dialect == ASCII:
        if STX in payload or ETX in payload:
            raise BadSyncError("CoLa-A text must not contain STX or ETX")
        return bytes([STX]) + payload + bytes([ETX])
    if len(payload) > MAX_PAYLOAD:
        raise BadLengthError(f"CoLa-B payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    return STX4 + len(payload).to_bytes(4, "big") + payload + bytes([xor_checksum(payload)])


def split_payload(dialect: str, payload: bytes) -> Frame:
    """Split a payload into kind, name and arguments (BadSyncError if it is no command)."""
    if len(payload) < 3 or payload[0] != 0x73:  # 's'
        raise BadSyncError("payload does not start with a CoLa command kind")
    kind = payload[:3].decode("ascii", "replace")
    if not kind[1:].isalpha():
        raise BadSyncError(f"payload starts with {kind!r}, not a CoLa command kind")
    if len(payload) == 3:
        return Frame(dialect, kind, "", b"")
    if payload[3] != 0x20:
        raise BadSyncError(f"no space after {kind!r}")
    if kind == "sFA":
        return Frame(dialect, kind, "", payload[4:])
    end = payload.find(b" ", 4)
    if end < 0:
        name, args = payload[4:], b""
    else:
        name, args = payload[4:end], payload[end + 1:]
    if not name or not name.isalnum():
        raise BadSyncError(f"{kind} telegram without a valid name")
    return Frame(dialect, kind, name.decode("ascii"), bytes(args))


def parse_frame(data: bytes) -> Frame:
    """Parse exactly one framed telegram (either dialect); typed WireError when it is not."""
    if data[:4] == STX4:
        if len(data) < 9:
            raise TruncatedError(f"CoLa-B frame of {len(data)} bytes is shorter than 9")
        n = int.from_bytes(data[4:8], "big")
        if n > MAX_PAYLOAD:
            raise BadLengthError(f"CoLa-B payload length {n} exceeds {MAX_PAYLOAD}")
        if len(data) < 9 + n:
            raise TruncatedError(f"CoLa-B frame announces {n} payload bytes, has {len(data) - 9}")
        if len(data) > 9 + n:
            raise BadLengthError(f"{len(data) - 9 - n} bytes after the CoLa-B checksum")
        payload = data[8:8 + n]
        if xor_checksum(payload) != data[8 + n]:
            raise ChecksumError("CoLa-B checksum does not match")
        return split_payload(BINARY, payload)
    if data[:1] == bytes([STX]):
        if data[-1:] != bytes([ETX]):
            raise TruncatedError("CoLa-A telegram without ETX")
        return split_payload(ASCII, data[1:-1])
    raise BadSyncError("telegram does not start with STX")


# ---------------------------------------------------------------------------------- cursors
_LITTLE = sys.byteorder == "little"
#: array typecodes of exactly 2 and 4 bytes
_ARRAY_CODE = {"H": "H", "I": "I" if array("I").itemsize == 4 else "L"}
_BY_LETTER = {"B": "u8", "H": "u16", "I": "u32", "h": "i16", "i": "i32", "f": "f32"}
_STRUCTS: dict[str, struct.Struct] = {}


def _struct(codes: str) -> struct.Struct:
    st = _STRUCTS.get(codes)
    if st is None:
        st = _STRUCTS[codes] = struct.Struct(">" + codes)
    return st


class Reader:
    """Reads the argument values of one telegram body, in order."""

    def u8(self) -> int: raise NotImplementedError
    def u16(self) -> int: raise NotImplementedError
    def u32(self) -> int: raise NotImplementedError
    def i16(self) -> int: raise NotImplementedError
    def i32(self) -> int: raise NotImplementedError
    def f32(self) -> float: raise NotImplementedError
    def text(self, n: int) -> str:
        """A fixed-length string of ``n`` characters."""
        raise NotImplementedError
    def flex(self) -> str:
        """A string with its u16 length before it."""
        raise NotImplementedError
    def u16s(self, n: int) -> array[int]:
        """``n`` u16 values as an array."""
        raise NotImplementedError
    def u32s(self, n: int) -> array[int]:
        """``n`` u32 values as an array."""
        raise NotImplementedError
    def group(self, codes: str) -> tuple[Any, ...]:
        """Several values at once, one struct letter each (B u8, H u16, I u32, h i16, i i32,
        f f32)."""
        raise NotImplementedError
    def done(self) -> bool:
        """True when every argument has been read."""
        raise NotImplementedError

    def end(self) -> None:
        """Raise BadLengthError when arguments are left over."""
        if not self.done():
            raise BadLengthError("telegram has more arguments than its layout")


class BinaryReader(Reader):
    """Big-endian values back to back."""

    __slots__ = ("buf", "pos")

    def __init__(self, buf: bytes) -> None:
        self.buf = buf
        self.pos = 0

    def _take(self, fmt: str, size: int) -> int | float:
        p = self.pos
        if p + size > len(self.buf):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + size
        value: int | float = struct.unpack_from(fmt, self.buf, p)[0]
        return value

    def u8(self) -> int:
        p = self.pos
        if p >= len(self.buf):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + 1
        return self.buf[p]

    def u16(self) -> int: return int(self._take(">H", 2))
    def u32(self) -> int: return int(self._take(">I", 4))
    def i16(self) -> int: return int(self._take(">h", 2))
    def i32(self) -> int: return int(self._take(">i", 4))
    def f32(self) -> float: return float(self._take(">f", 4))

    def text(self, n: int) -> str:
        p = self.pos
        if p + n > len(self.buf):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + n
        return self.buf[p:p + n].decode("ascii", "replace")

    def flex(self) -> str:
        return self.text(self.u16())

    def _array(self, code: str, size: int, n: int) -> array[int]:
        p = self.pos
        if p + size * n > len(self.buf):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + size * n
        out = array(_ARRAY_CODE[code], self.buf[p:p + size * n])
        if _LITTLE:
            out.byteswap()
        return out

    def u16s(self, n: int) -> array[int]: return self._array("H", 2, n)
    def u32s(self, n: int) -> array[int]: return self._array("I", 4, n)

    def group(self, codes: str) -> tuple[Any, ...]:
        st = _struct(codes)
        p = self.pos
        if p + st.size > len(self.buf):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + st.size
        return st.unpack_from(self.buf, p)

    def done(self) -> bool: return self.pos >= len(self.buf)


class AsciiReader(Reader):
    """Space-separated tokens: unsigned hex, signed decimal with a sign, reals as hex bits."""

    __slots__ = ("pos", "tokens")

    def __init__(self, text: bytes) -> None:
        self.tokens = text.split()
        self.pos = 0

    def _token(self) -> bytes:
        p = self.pos
        if p >= len(self.tokens):
            raise BadLengthError("telegram ends inside its arguments")
        self.pos = p + 1
        return self.tokens[p]

    def _int(self, lo: int, hi: int) -> int:
        tok = self._token()
        try:
            v = int(tok, 10) if tok[:1] in (b"+", b"-") else int(tok, 16)
        except ValueError:
            raise BadLengthError(f"CoLa-A token {tok!r} is not a number") from None
        if not lo <= v <= hi:
            raise BadLengthError(f"CoLa-A value {v} out of range")
        return v

    def u8(self) -> int: return self._int(0, 0xFF)
    def u16(self) -> int: return self._int(0, 0xFFFF)
    def u32(self) -> int: return self._int(0, 0xFFFFFFFF)
    def i16(self) -> int: return self._int(-0x8000, 0x7FFF)
    def i32(self) -> int: return self._int(-0x80000000, 0x7FFFFFFF)

    def f32(self) -> float:
        bits = self._int(0, 0xFFFFFFFF)
        return float(struct.unpack(">f", bits.to_bytes(4, "big"))[0])

    def text(self, n: int) -> str:
        return self._token().decode("ascii", "replace")

    def flex(self) -> str:
        n = self.u16()
        return "" if n == 0 else self._token().decode("ascii", "replace")

    def u16s(self, n: int) -> array[int]: return array("H", (self.u16() for _ in range(n)))
    def u32s(self, n: int) -> array[int]:
        return array(_ARRAY_CODE["I"], (self.u32() for _ in range(n)))

    def group(self, codes: str) -> tuple[Any, ...]:
        return tuple(getattr(self, _BY_LETTER[c])() for c in codes)

    def done(self) -> bool: return self.pos >= len(self.tokens)


class Writer:
    """Writes argument values of one telegram body, in order; :meth:`data` gives the bytes."""

    def u8(self, v: int) -> Writer: raise NotImplementedError
    def u16(self, v: int) -> Writer: raise NotImplementedError
    def u32(self, v: int) -> Writer: raise NotImplementedError
    def i16(self, v: int) -> Writer: raise NotImplementedError
    def i32(self, v: int) -> Writer: raise NotImplementedError
    def f32(self, v: float) -> Writer: raise NotImplementedError
    def text(self, s: str) -> Writer: raise NotImplementedError
    def flex(self, s: str) -> Writer: raise NotImplementedError
    def u16s(self, vs: Sequence[int]) -> Writer: raise NotImplementedError
    def u32s(self, vs: Sequence[int]) -> Writer: raise NotImplementedError
    def data(self) -> bytes: raise NotImplementedError


def _check(v: int, lo: int, hi: int) -> int:
    from lgvtool.wire.wire_errors import EncodeError

    iv = int(v)
    if not lo <= iv <= hi:
        raise EncodeError(f"value {v} does not fit the field ({lo}..{hi})")
    return iv


class BinaryWriter(Writer):
    """Big-endian values back to back."""

    def __init__(self) -> None:
        self._parts: list[bytes] = []

    def _put(self, fmt: str, v: float) -> Writer:
        self._parts.append(struct.pack(fmt, v))
        return self

    def u8(self, v: int) -> Writer: return self._put(">B", _check(v, 0, 0xFF))
    def u16(self, v: int) -> Writer: return self._put(">H", _check(v, 0, 0xFFFF))
    def u32(self, v: int) -> Writer: return self._put(">I", _check(v, 0, 0xFFFFFFFF))
    def i16(self, v: int) -> Writer: return self._put(">h", _check(v, -0x8000, 0x7FFF))
    def i32(self, v: int) -> Writer: return self._put(">i", _check(v, -0x80000000, 0x7FFFFFFF))
    def f32(self, v: float) -> Writer: return self._put(">f", float(v))

    def text(self, s: str) -> Writer:
        self._parts.append(s.encode("ascii"))
        return self

    def flex(self, s: str) -> Writer:
        self.u16(len(s))
        return self.text(s)

    def _array(self, code: str, vs: Sequence[int]) -> Writer:
        a = array(_ARRAY_CODE[code], vs)
        if _LITTLE:
            a.byteswap()
        self._parts.append(a.tobytes())
        return self

    def u16s(self, vs: Sequence[int]) -> Writer: return self._array("H", vs)
    def u32s(self, vs: Sequence[int]) -> Writer: return self._array("I", vs)

    def data(self) -> bytes:
        return b"".join(self._parts)


class AsciiWriter(Writer):
    """Tokens separated by one space."""

    def __init__(self) -> None:
        self._tokens: list[str] = []

    def _hex(self, v: int, lo: int, hi: int) -> Writer:
        self._tokens.append(f"{_check(v, lo, hi):X}")
        return self

    def _signed(self, v: int, lo: int, hi: int) -> Writer:
        self._tokens.append(f"{_check(v, lo, hi):+d}")
        return self

    def u8(self, v: int) -> Writer: return self._hex(v, 0, 0xFF)
    def u16(self, v: int) -> Writer: return self._hex(v, 0, 0xFFFF)
    def u32(self, v: int) -> Writer: return self._hex(v, 0, 0xFFFFFFFF)
    def i16(self, v: int) -> Writer: return self._signed(v, -0x8000, 0x7FFF)
    def i32(self, v: int) -> Writer: return self._signed(v, -0x80000000, 0x7FFFFFFF)

    def f32(self, v: float) -> Writer:
        self._tokens.append(struct.pack(">f", float(v)).hex().upper())
        return self

    def text(self, s: str) -> Writer:
        if not s or " " in s:
            raise BadSyncError(f"CoLa-A cannot carry the string {s!r} as one token")
        self._tokens.append(s)
        return self

    def flex(self, s: str) -> Writer:
        self.u16(len(s))
        return self.text(s) if s else self

    def u16s(self, vs: Sequence[int]) -> Writer:
        for v in vs:
            self.u16(v)
        return self

    def u32s(self, vs: Sequence[int]) -> Writer:
        for v in vs:
            self.u32(v)
        return self

    def data(self) -> bytes:
        return " ".join(self._tokens).encode("ascii")


def reader_for(frame: Frame) -> Reader:
    """A reader of ``frame``'s arguments in its dialect."""
    return AsciiReader(frame.args) if frame.dialect == ASCII else BinaryReader(frame.args)


def writer_for(dialect: str) -> Writer:
    """An empty writer of ``dialect``."""
    return AsciiWriter() if dialect == ASCII else BinaryWriter()
