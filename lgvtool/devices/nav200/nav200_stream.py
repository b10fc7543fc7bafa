"""Incremental decoders of NAV200 byte streams, one per direction.

:class:`Nav200ReplyDecoder` (host side) decodes what the device sends; :class:`Nav200RequestDecoder`
(device side, and for re-decoding logged host traffic) decodes what the host sends. Both share
the framing. A 0x02 inside data is only a candidate start: it becomes a telegram only when its
LEN is possible (>= 5, and equal to the command's LEN when the letters are known), both letters
are ASCII letters, and the BCC checks.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import TypeVar

from lgvtool.devices.nav200.nav200_commands import (
    DeviceReply,
    ErrorReply,
    Request,
    decode_reply,
    decode_request,
    is_known_reply,
    is_known_request,
    reply_length,
    request_length,
)
from lgvtool.devices.nav200.nav200_framing import MIN_LEN, STX, is_letter, parse_telegram
from lgvtool.wire.checksum import xor_bcc
from lgvtool.wire.decode_events import ERROR
from lgvtool.wire.resync_stream import Accept, Reject, StreamDecoder, Verdict, Wait
from lgvtool.wire.wire_errors import WireError

_STX = bytes([STX])

T = TypeVar("T")


class _Nav200Decoder(StreamDecoder[T]):
    """Framing-level scanning shared by both directions."""

    source = "nav200"

    def _find_start(self, buf: bytearray, pos: int) -> int:
        return buf.find(_STX, pos)

    @abstractmethod
    def _known(self, code: str) -> bool:
        """True when ``code`` is a telegram of this direction."""

    @abstractmethod
    def _length(self, code: str) -> int | None:
        """LEN of a known ``code`` (None: variable)."""

    @abstractmethod
    def _decode(self, raw: bytes) -> T:
        """Decode one intact, known telegram."""

    def _complete_at(self, buf: bytearray, pos: int) -> bool:
        """True when a complete, known telegram with a valid BCC starts at ``buf[pos]``.

        An 8-bit XOR cannot tell a telegram from the first bytes of a cut-off one followed by
        complete telegrams and the first bytes of the next one: their XORs cancel. A candidate
        that overlaps another complete, valid telegram is taken for such a cut-off one
        (:meth:`StreamDecoder._overlaps_frame`).
        """
        if pos + 4 > len(buf):
            return False
        length = buf[pos + 1]
        if length < MIN_LEN or pos + length > len(buf):
            return False
        if not (is_letter(buf[pos + 2]) and is_letter(buf[pos + 3])):
            return False
        code = chr(buf[pos + 2]) + chr(buf[pos + 3])
        if not self._known(code):
            return False
        expected = self._length(code)
        if expected is not None and expected != length:
            return False
        return xor_bcc(buf[pos : pos + length]) == 0

    def _examine(self, buf: bytearray, pos: int) -> Verdict:
        n = len(buf) - pos
        if n < 2:
            return Wait()
        length = buf[pos + 1]
        if length < MIN_LEN:
            return Reject("bad_length", f"NAV200 LEN {length} < {MIN_LEN}")
        if n >= 3 and not is_letter(buf[pos + 2]):
            return Reject(None)
        if n < 4:
            return Wait(length)
        if not is_letter(buf[pos + 3]):
            return Reject(None)
        code = chr(buf[pos + 2]) + chr(buf[pos + 3])
        known = self._known(code)
        expected = self._length(code) if known else None
        if expected is not None and length != expected:
            return Reject("bad_length", f"NAV200 {code} with LEN {length}, expected {expected}")
        if n < length:
            return Wait(length)
        raw = bytes(buf[pos : pos + length])
        if xor_bcc(raw) != 0:
            return Reject("bad_checksum", f"NAV200 {code} telegram with a bad BCC")
        if not known:
            return Reject("unknown_command", f"NAV200 telegram with unknown code {code!r}")
        if self._overlaps_frame(buf, pos, length):
            return Reject("bad_length", f"NAV200 {code} candidate overlaps a complete telegram")
        try:
            return Accept(self._decode(raw), length)
        except WireError as exc:
            return Reject(exc.kind, str(exc))


class Nav200ReplyDecoder(_Nav200Decoder[DeviceReply]):
    """Host side: decode device replies; ``feed(chunk) -> list[Reply | ErrorReply]``.

    Error replies are delivered (they are valid telegrams) and also counted in
    ``stats.error_replies`` and reported as ``device_error`` events with their meanings.
    """

    def _known(self, code: str) -> bool:
        return is_known_reply(code)

    def _length(self, code: str) -> int | None:
        return reply_length(code)

    def _decode(self, raw: bytes) -> DeviceReply:
        return decode_reply(parse_telegram(raw))

    def _delivered(self, frame: DeviceReply, offset: int) -> None:
        if isinstance(frame, ErrorReply):
            self.stats.error_replies += 1
            self._event(
                "device_error",
                f"NAV200 {frame.describe()}",
                level=ERROR,
                offset_bytes=offset,
                rejected_function=frame.rejected_function,
                error_class=frame.error_class,
                group=frame.group,
                detail=frame.detail,
            )


class Nav200RequestDecoder(_Nav200Decoder[Request]):
    """Device side: decode host requests; ``feed(chunk) -> list[Request]``."""

    def _known(self, code: str) -> bool:
        return is_known_request(code)

    def _length(self, code: str) -> int | None:
        return request_length(code)

    def _decode(self, raw: bytes) -> Request:
        return decode_request(parse_telegram(raw))
