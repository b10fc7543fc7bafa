"""Byte-exact wire codecs: pure functions, no I/O, no clocks.

- :mod:`lgvtool.wire.nav200`: the SICK NAV200 telegrams (requests, replies, error replies),
  host-side request builders, device-side reply builders, stream decoders for both directions,
  and a host session that matches replies to requests;
- :mod:`lgvtool.wire.mcu`: the MCU frame (version 1) and wrap-around helpers;
  :mod:`lgvtool.wire.mcu_stream`: its stream decoder with sequence-gap events;
- :mod:`lgvtool.wire.messages`: decoded frames as ``lgvtool.McuFrame`` / ``lgvtool.NavPose``
  message dicts;
- :mod:`lgvtool.wire.events`: the error counters and events of the decoders;
- :mod:`lgvtool.wire.errors`: typed errors.

Byte layouts and worked examples: ``docs/protocol.md``.
"""

from __future__ import annotations

from lgvtool.wire.checksum import crc16_ccitt_false, xor_bcc
from lgvtool.wire.errors import (
    BadLengthError,
    BadSyncError,
    ChecksumError,
    DeviceErrorReply,
    EncodeError,
    TruncatedError,
    UnexpectedReplyError,
    UnknownCommandError,
    UnknownVersionError,
    WireError,
)
from lgvtool.wire.events import DecodeEvent, DecoderStats
from lgvtool.wire.mcu import (
    McuFrame,
    McuStatus,
    clock_delta_ms,
    counter_delta,
    decode_mcu_frame,
    encode_mcu_frame,
    seq_delta,
)
from lgvtool.wire.mcu_stream import McuStreamDecoder
from lgvtool.wire.messages import mcu_frame_message, nav_pose_message, timestamp_from_ns
from lgvtool.wire.nav200_commands import ErrorReply, Reply, Request, decode_reply, decode_request
from lgvtool.wire.nav200_payloads import Pose
from lgvtool.wire.nav200_session import Exchange, Nav200HostSession
from lgvtool.wire.nav200_stream import Nav200ReplyDecoder, Nav200RequestDecoder

__all__ = [
    "BadLengthError",
    "BadSyncError",
    "ChecksumError",
    "DecodeEvent",
    "DecoderStats",
    "DeviceErrorReply",
    "EncodeError",
    "ErrorReply",
    "Exchange",
    "McuFrame",
    "McuStatus",
    "McuStreamDecoder",
    "Nav200HostSession",
    "Nav200ReplyDecoder",
    "Nav200RequestDecoder",
    "Pose",
    "Reply",
    "Request",
    "TruncatedError",
    "UnexpectedReplyError",
    "UnknownCommandError",
    "UnknownVersionError",
    "WireError",
    "clock_delta_ms",
    "counter_delta",
    "crc16_ccitt_false",
    "decode_mcu_frame",
    "decode_reply",
    "decode_request",
    "encode_mcu_frame",
    "mcu_frame_message",
    "nav_pose_message",
    "seq_delta",
    "timestamp_from_ns",
    "xor_bcc",
]
