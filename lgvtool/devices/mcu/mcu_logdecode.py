"""Decode a log's MCU traffic (/mcu/rx) into /mcu/frame, through the one decoding path
(:mod:`lgvtool.devices.log_decoding`).

Used by ``lgvtool decode``, by the simulator's log writer and by the recorder's MCU worker
(which passes its :class:`~lgvtool.devices.mcu.mcu_session.McuLink`, so that the same frames
also give the vehicle's motion). A frame's message gets the log time of the chunk that
completed it; its ``timestamp`` is that time too.
"""

from __future__ import annotations

from lgvtool.devices.log_decoding import DecodedQueue, error_summary
from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.mcu.mcu_session import McuLink
from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.json_types import JSONObject
from lgvtool.log import topics
from lgvtool.log.messages import mcu_frame_message
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import STREAM_EVENT_KINDS, DecodeEvent

__all__ = ["McuLogDecoder"]


class McuLogDecoder(DecodedQueue):
    """The MCU's :class:`~lgvtool.devices.log_decoding.LogDecoder`: /mcu/rx -> /mcu/frame.

    :param stream: the stream decoder to feed (default: a fresh
        :class:`~lgvtool.devices.mcu.mcu_stream.McuStreamDecoder`).
    """

    decoded_topics = frozenset({topics.MCU_FRAME})
    sources = frozenset({"mcu"})
    event_kinds = STREAM_EVENT_KINDS

    def __init__(self, stream: McuStreamDecoder | McuLink | None = None) -> None:
        super().__init__()
        self.stream = stream if stream is not None else McuStreamDecoder()
        self.frames = 0

    def _frames(self, frames: list[McuFrame], t_ns: int) -> None:
        ts = stamp(t_ns)
        for frame in frames:
            self.emit(topics.MCU_FRAME, mcu_frame_message(frame, ts), t_ns)
        self.frames += len(frames)

    def chunk(self, topic: str, data: bytes, t_ns: int) -> None:
        """Bytes the host read from the MCU at ``t_ns``."""
        if topic == topics.MCU_RX:
            self._frames(self.stream.feed(data), t_ns)
            self.last_ns = t_ns

    def finish(self, t_ns: int) -> None:
        """End of the log: the frames still buffered, at ``t_ns``."""
        self._frames(self.stream.flush(), t_ns)

    def pop_events(self) -> list[DecodeEvent]:
        """Decoder events since the last call."""
        return self.stream.pop_events()

    def report(self) -> JSONObject:
        """``{"frames", "stats"}``."""
        return {"frames": self.frames, "stats": dict(self.stream.stats.as_dict())}

    def summary(self) -> list[str]:
        """``mcu: N frames; errors: ...``."""
        return [f"mcu: {self.frames} frames; errors: {error_summary(self.stream.stats.as_dict())}"]

    def stats_metadata(self) -> dict[str, dict[str, int]]:
        """``{"mcu": stats}``."""
        return {"mcu": self.stream.stats.as_dict()}
