"""Incremental, resynchronising decoder of a NAV350 byte stream (either direction, both dialects).

A ``0x02`` is only a candidate: ``02 02 02 02`` starts a CoLa-B frame, which becomes a
telegram when its length is possible (3..35000 payload bytes), its XOR checksum checks and its
payload is a command this codec knows; ``02 73`` (``STX s``) starts a CoLa-A telegram, which must
be printable text up to an ``03``. After a bad candidate, scanning restarts at the byte after its
start, so a good telegram that a cut-off one overlaps is still found. Counters and events as for
the NAV200 (:class:`~lgvtool.wire.decode_events.DecoderStats`): ``bad_checksum``, ``bad_length``
(impossible or oversized length, arguments that do not fit the layout), ``unknown_command``,
``truncated`` (at :meth:`flush`), ``error_replies`` (``sFA``, also a ``device_error`` event),
``bytes_skipped``.
"""

from __future__ import annotations

import re

from lgvtool.devices.nav350.nav350_cola import (
    ASCII,
    BINARY,
    ETX,
    MAX_PAYLOAD,
    Frame,
    split_payload,
    xor_checksum,
)
from lgvtool.devices.nav350.nav350_telegrams import SOPAS_ERRORS, Telegram, decode_frame
from lgvtool.wire.decode_events import ERROR
from lgvtool.wire.resync_stream import Accept, Reject, SkipFrame, StreamDecoder, Verdict, Wait
from lgvtool.wire.wire_errors import WireError

__all__ = ["Nav350StreamDecoder"]

_NOT_TEXT = re.compile(rb"[^\x20-\x7e]")
_STX = b"\x02"


class Nav350StreamDecoder(StreamDecoder[Telegram]):
    """``feed(chunk) -> list[Telegram]``.

    :param deliver_unknown: deliver intact telegrams of an unknown name too (with ``value``
        None), as a device must to answer them; they are counted as ``unknown_command`` either
        way.
    """

    source = "nav350"

    def __init__(self, *, deliver_unknown: bool = False) -> None:
        super().__init__()
        self.deliver_unknown = deliver_unknown

    def _find_start(self, buf: bytearray, pos: int) -> int:
        return buf.find(_STX, pos)

    def _keep_back(self, buf: bytearray) -> int:
        return 0

    def _examine(self, buf: bytearray, pos: int) -> Verdict:
        n = len(buf) - pos
        if n < 2:
            return Wait()
        second = buf[pos + 1]
        if second == 0x73:
            return self._ascii(buf, pos)
        if second != 0x02:
            return Reject(None)
        if n < 4:
            return Wait()
        if buf[pos + 2] != 0x02 or buf[pos + 3] != 0x02:
            return Reject(None)
        if n < 8:
            return Wait()
        length = int.from_bytes(buf[pos + 4:pos + 8], "big")
        if length < 3 or length > MAX_PAYLOAD:
            return Reject("bad_length", f"NAV350 CoLa-B length {length} outside 3..{MAX_PAYLOAD}")
        size = 9 + length
        if n < size:
            return Wait(size)
        payload = bytes(buf[pos + 8:pos + 8 + length])
        if xor_checksum(payload) != buf[pos + 8 + length]:
            return Reject("bad_checksum", "NAV350 CoLa-B telegram with a bad checksum")
        try:
            frame = split_payload(BINARY, payload)
        except WireError:
            return Reject("unknown_command", "NAV350 CoLa-B payload is not a CoLa command")
        return self._decode(frame, size)

    def _ascii(self, buf: bytearray, pos: int) -> Verdict:
        end = buf.find(ETX, pos + 2, pos + 2 + MAX_PAYLOAD)
        if end < 0:
            if len(buf) - pos >= MAX_PAYLOAD + 2:
                return Reject("bad_length", f"NAV350 CoLa-A telegram longer than {MAX_PAYLOAD}")
            bad = _NOT_TEXT.search(buf, pos + 1)
            return Reject(None) if bad is not None else Wait()
        text = bytes(buf[pos + 1:end])
        if _NOT_TEXT.search(text) is not None:
            return Reject(None)
        try:
            frame = split_payload(ASCII, text)
        except WireError:
            return Reject(None)
        return self._decode(frame, end + 1 - pos)

    def _decode(self, frame: Frame, size: int) -> Verdict:
        try:
            return Accept(decode_frame(frame, size), size)
        except WireError as exc:
            if exc.kind == "unknown_command":
                if self.deliver_unknown:
                    self.stats.unknown_command += 1
                    self._event("unknown_command", str(exc), name=frame.name, telegram_kind=frame.kind)
                    return Accept(Telegram(frame.kind, frame.name, None, frame.dialect, size),
                                  size)
                return SkipFrame("unknown_command", size, str(exc))
            return SkipFrame("bad_length", size, f"NAV350 {frame.kind} {frame.name}: {exc}")

    def _delivered(self, frame: Telegram, offset: int) -> None:
        if frame.is_error:
            code = int(frame.fields[0]) if frame.fields else -1
            self.stats.error_replies += 1
            self._event("device_error", f"NAV350 {frame.describe()}", level=ERROR,
                        offset_bytes=offset, sopas_error=code,
                        meaning=SOPAS_ERRORS.get(code, "unknown code"))
