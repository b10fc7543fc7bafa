"""Incremental decoder of the MCU byte stream, with sequence-gap tracking."""

from __future__ import annotations

from lgvtool.devices.mcu.mcu_frame import (
    MCU_VERSION,
    SYNC,
    V1_LEN,
    McuFrame,
    McuStatus,
    decode_mcu_frame,
    frame_size_for_len,
)
from lgvtool.wire.checksum import crc16_ccitt_false
from lgvtool.wire.decode_events import INFO, WARNING
from lgvtool.wire.resync_stream import Accept, Reject, SkipFrame, StreamDecoder, Verdict, Wait
from lgvtool.wire.units import seq_delta

#: A forward sequence jump of at least this many steps is taken as a jump backwards.
SEQ_BACKWARDS = 0x8000


class McuStreamDecoder(StreamDecoder[McuFrame]):
    """Decode MCU frames from bytes in any chunking; ``feed(chunk) -> list[McuFrame]``.

    Errors are counted in ``stats`` (bytes_skipped, bad_checksum, bad_length, unknown_version,
    truncated) and reported by ``pop_events()``. Sequence numbers are tracked across frames:
    a jump forward of n > 1 counts one ``seq_gaps`` and n - 1 ``frames_missing`` and reports a
    ``seq_gap`` event with ``missing_frames`` and ``first_missing_seq``; a repeated number
    counts ``seq_repeats``; a jump backwards ``seq_resets``. Frames with the MCU_RESET status
    bit start a new sequence (``mcu_resets`` counts each run of them).
    """

    source = "mcu"

    def __init__(self) -> None:
        super().__init__()
        self.last_frame: McuFrame | None = None
        self._in_reset = False

    def _find_start(self, buf: bytearray, pos: int) -> int:
        return buf.find(SYNC, pos)

    def _keep_back(self, buf: bytearray) -> int:
        return 1 if buf and buf[-1] == SYNC[0] else 0

    def _complete_at(self, buf: bytearray, pos: int) -> bool:
        """True when a complete frame with a valid CRC (any version) starts at ``buf[pos]``."""
        if pos + 4 > len(buf) or buf[pos : pos + 2] != SYNC or buf[pos + 2] < 1:
            return False
        length = buf[pos + 2]
        if buf[pos + 3] == MCU_VERSION and length != V1_LEN:
            return False
        size = frame_size_for_len(length)
        if pos + size > len(buf):
            return False
        received = buf[pos + size - 2] | (buf[pos + size - 1] << 8)
        return crc16_ccitt_false(buf[pos + 2 : pos + size - 2]) == received

    def _examine(self, buf: bytearray, pos: int) -> Verdict:
        n = len(buf) - pos
        if n < 3:
            return Wait()
        length = buf[pos + 2]
        if length < 1:
            return Reject("bad_length", "MCU frame LEN 0")
        if n < 4:
            return Wait(frame_size_for_len(length))
        version = buf[pos + 3]
        if version == MCU_VERSION and length != V1_LEN:
            return Reject("bad_length", f"MCU frame version 1 with LEN {length}")
        size = frame_size_for_len(length)
        if n < size:
            return Wait(size)
        expected = crc16_ccitt_false(buf[pos + 2 : pos + size - 2])
        received = buf[pos + size - 2] | (buf[pos + size - 1] << 8)
        if expected != received:
            return Reject("bad_checksum", f"MCU CRC {received:04X}, computed {expected:04X}")
        if self._overlaps_frame(buf, pos, size):
            return Reject("bad_length", "MCU candidate overlaps a complete frame")
        if version != MCU_VERSION:
            return SkipFrame("unknown_version", size, f"MCU frame version {version} skipped")
        return Accept(decode_mcu_frame(buf[pos : pos + size]), size)

    def _delivered(self, frame: McuFrame, offset: int) -> None:
        previous = self.last_frame
        self.last_frame = frame
        if frame.has(McuStatus.MCU_RESET):
            if not self._in_reset:
                self._in_reset = True
                self.stats.mcu_resets += 1
                self._event(
                    "mcu_reset",
                    f"MCU restarted (seq {frame.seq})",
                    level=INFO,
                    offset_bytes=offset,
                    seq=frame.seq,
                )
            return
        self._in_reset = False
        if previous is None:
            return
        step = seq_delta(previous.seq, frame.seq)
        if step == 1:
            return
        if step == 0:
            self.stats.seq_repeats += 1
            self._event(
                "seq_repeat", f"MCU seq {frame.seq} repeated", offset_bytes=offset, seq=frame.seq
            )
        elif step < SEQ_BACKWARDS:
            missing = step - 1
            first = (previous.seq + 1) & 0xFFFF
            self.stats.seq_gaps += 1
            self.stats.frames_missing += missing
            self._event(
                "seq_gap",
                f"{missing} MCU frames missing from seq {first}",
                level=WARNING,
                count=missing,
                offset_bytes=offset,
                missing_frames=missing,
                first_missing_seq=first,
                seq=frame.seq,
            )
        else:
            self.stats.seq_resets += 1
            self._event(
                "seq_reset",
                f"MCU seq jumped back from {previous.seq} to {frame.seq}",
                offset_bytes=offset,
                previous_seq=previous.seq,
                seq=frame.seq,
            )
