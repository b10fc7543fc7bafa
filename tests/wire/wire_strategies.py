"""Hypothesis strategies and helpers shared by the wire tests."""

from __future__ import annotations

import random
from collections.abc import Callable

from hypothesis import strategies as st

from lgvtool.devices.mcu.mcu_frame import McuFrame, decode_mcu_frame
from lgvtool.devices.nav200.nav200_commands import (
    COMMANDS,
    REPLIES,
    ErrorReply,
    Reply,
    Request,
    decode_reply,
    decode_request,
)
from lgvtool.devices.nav200.nav200_payloads import Payload, VersionText
from lgvtool.wire.wire_errors import UnknownVersionError, WireError

INT_RANGES = {
    "B": (0, 0xFF),
    "b": (-0x80, 0x7F),
    "H": (0, 0xFFFF),
    "h": (-0x8000, 0x7FFF),
    "I": (0, 0xFFFFFFFF),
    "i": (-0x80000000, 0x7FFFFFFF),
}

letters = st.sampled_from("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz")
latin1_char = st.characters(min_codepoint=0, max_codepoint=255)


def payload_strategy(cls: type[Payload]) -> st.SearchStrategy[Payload]:
    """Any payload of layout ``cls``, every field over its whole wire range."""
    if cls is VersionText:
        return st.builds(VersionText, st.text(latin1_char, max_size=250))
    fmt = cls.FORMAT.format.lstrip("<")
    return st.builds(cls, *[st.integers(*INT_RANGES[c]) for c in fmt])


def request_strategy(code: str | None = None) -> st.SearchStrategy[Request]:
    """Any request (of ``code`` when given)."""
    codes = st.just(code) if code else st.sampled_from(sorted(COMMANDS))
    return codes.flatmap(
        lambda c: payload_strategy(COMMANDS[c].request).map(lambda p: Request(c, p))
    )


error_reply_strategy = st.builds(
    ErrorReply,
    letters,
    latin1_char,
    st.integers(0, 255),
    st.integers(0, 255),
    st.integers(0, 255),
)


def reply_strategy(code: str | None = None) -> st.SearchStrategy[Reply | ErrorReply]:
    """Any reply (of ``code`` when given), error replies included when no code is given."""
    if code:
        return payload_strategy(REPLIES[code]).map(lambda p: Reply(code, p))
    normal = st.sampled_from(sorted(REPLIES)).flatmap(reply_strategy)
    return st.one_of(normal, error_reply_strategy)


mcu_frame_strategy = st.builds(
    McuFrame,
    seq=st.integers(0, 0xFFFF),
    mcu_time_ms=st.integers(0, 0xFFFFFFFF),
    enc_left=st.integers(*INT_RANGES["i"]),
    enc_right=st.integers(*INT_RANGES["i"]),
    gyro_raw=st.integers(*INT_RANGES["h"]),
    gyro_scale_udeg_s=st.integers(0, 0xFFFF),
    steering_cdeg=st.integers(*INT_RANGES["h"]),
    drive_speed_mm_s=st.integers(*INT_RANGES["h"]),
    status=st.integers(0, 0xFFFF),
)

chunking_strategy = st.one_of(
    st.just("bytes"), st.just("all"), st.lists(st.integers(1, 64), min_size=1, max_size=40)
)


def split(data: bytes, chunking: str | list[int]) -> list[bytes]:
    """Cut ``data`` into chunks: one byte each, all at once, or cycling through given sizes."""
    if isinstance(chunking, str):
        if chunking == "all":
            return [data]
        return [data[i : i + 1] for i in range(len(data))]
    chunks: list[bytes] = []
    pos, k = 0, 0
    while pos < len(data):
        size = chunking[k % len(chunking)]
        chunks.append(data[pos : pos + size])
        pos += size
        k += 1
    return chunks


def corrupt(frame: bytes, rng: random.Random) -> bytes:
    """A damaged copy of ``frame``: a flipped byte, a truncation, or a doubled byte."""
    how = rng.randrange(3)
    if how == 0:
        i = rng.randrange(len(frame))
        flip = rng.randrange(1, 256)
        return frame[:i] + bytes([frame[i] ^ flip]) + frame[i + 1 :]
    if how == 1:
        return frame[: rng.randrange(1, len(frame))]
    i = rng.randrange(2, len(frame))  # doubling the first byte would leave an intact frame
    return frame[:i] + frame[i - 1 : i] + frame[i:]


def nav200_candidate_checks(data: bytes, pos: int, *, replies: bool) -> bool:
    """True when the bytes at ``pos`` form a complete telegram that a decoder would accept."""
    if data[pos] != 0x02 or pos + 1 >= len(data):
        return False
    end = pos + data[pos + 1]
    if end > len(data):
        return False
    try:
        (decode_reply if replies else decode_request)(data[pos:end])
    except WireError:
        return False
    return True


def mcu_candidate_checks(data: bytes, pos: int) -> bool:
    """True when the bytes at ``pos`` form a frame with a valid CRC (any version)."""
    if data[pos : pos + 2] != b"\xa5\x5a" or pos + 2 >= len(data):
        return False
    end = pos + data[pos + 2] + 5
    if end > len(data):
        return False
    try:
        decode_mcu_frame(data[pos:end])
    except UnknownVersionError:
        return True
    except WireError:
        return False
    return True


def ambiguous(
    data: bytes,
    good: list[tuple[int, int]],
    check: Callable[[bytes, int], bool],
    *,
    lookahead: bool = False,
) -> bool:
    """True when no decoder could recover exactly the good frames of ``data``.

    That is when a candidate outside the good frames checks (an 8-bit BCC passes about 1 in
    256 damaged candidates, and some cut-off telegrams by construction) and does not overlap a
    good frame that the decoder would prefer: one lying wholly inside it, or, with
    ``lookahead`` (the whole stream fed at once), one starting inside it. Also when a good
    frame overlaps a complete frame that checks. The stream tests leave those streams out.
    """
    inside = bytearray(len(data))
    starts = bytearray(len(data) + 1)
    for start, end in good:
        inside[start:end] = b"\x01" * (end - start)
        starts[start] = 1
        if any(check(data, p) for p in range(start + 1, end)):
            return True
    for p in range(len(data)):
        if inside[p] or not check(data, p):
            continue
        end = p + data[p + 1]
        inner_start = any(starts[p + 1 : end])
        inner_whole = any(p < s and e <= end for s, e in good)
        if not (inner_start if lookahead else inner_whole):
            return True
    return False


def mcu_ambiguous(data: bytes, frames: list[tuple[int, int]]) -> bool:
    """True when a position outside ``frames`` (good and deliberately skipped frames) holds a
    frame with a valid CRC: the decoder would take it (about 1 in 65536 damaged candidates)."""
    inside = bytearray(len(data))
    for start, end in frames:
        inside[start:end] = b"\x01" * (end - start)
    return any(not inside[p] and mcu_candidate_checks(data, p) for p in range(len(data)))
