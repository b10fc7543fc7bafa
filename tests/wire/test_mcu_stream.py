"""The MCU stream decoder: garbage, corruption, chunking, sequence gaps and wrap-around."""

from __future__ import annotations

import random

from hypothesis import assume, given, settings
from hypothesis import strategies as st
from wire_strategies import (
    chunking_strategy,
    corrupt,
    mcu_ambiguous,
    mcu_frame_strategy,
    split,
)

from lgvtool.devices.mcu.mcu_frame import McuFrame, McuStatus
from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.wire.checksum import crc16_ccitt_false

STREAM = settings(max_examples=60, deadline=None)

soup_bytes = st.lists(
    st.one_of(st.integers(0, 255), st.sampled_from([0xA5, 0x5A, 0x19, 0x01, 0x00, 0xFF])),
    max_size=800,
).map(bytes)


def run(decoder: McuStreamDecoder, data: bytes, chunking: str | list[int]) -> list[McuFrame]:
    out: list[McuFrame] = []
    for chunk in split(data, chunking):
        out += decoder.feed(chunk)
        s = decoder.stats
        assert s.bytes_received == s.bytes_decoded + s.bytes_skipped + decoder.pending_bytes
    out += decoder.flush()
    assert decoder.pending_bytes == 0
    s = decoder.stats
    assert s.bytes_received == s.bytes_decoded + s.bytes_skipped
    return out


def frame(seq: int, status: int = 0) -> McuFrame:
    return McuFrame(
        seq=seq, mcu_time_ms=seq * 100, enc_left=seq, enc_right=-seq, gyro_raw=0, status=status
    )


def future_version_frame(rng: random.Random) -> bytes:
    body = bytes([2]) + rng.randbytes(rng.randrange(0, 40))
    covered = bytes([len(body)]) + body
    return b"\xa5\x5a" + covered + crc16_ccitt_false(covered).to_bytes(2, "little")


@STREAM
@given(st.one_of(st.binary(max_size=2000), soup_bytes), chunking_strategy)
def test_byte_soup_never_raises(data: bytes, chunking: str | list[int]) -> None:
    decoder = McuStreamDecoder()
    frames = run(decoder, data, chunking)
    assert len(frames) == decoder.stats.frames
    decoder.pop_events()


@STREAM
@given(
    st.lists(mcu_frame_strategy, min_size=1, max_size=12),
    st.integers(0, 2**32),
    chunking_strategy,
)
def test_frames_survive_garbage_and_damage(
    frames: list[McuFrame], seed: int, chunking: str | list[int]
) -> None:
    rng = random.Random(seed)
    encoded = [f.encode() for f in frames]
    data = bytearray()
    spans = []
    skipped: list[tuple[int, int]] = []
    future = 0
    for raw in encoded:
        for _ in range(rng.randrange(3)):
            kind = rng.randrange(4)
            if kind == 0:
                data += rng.randbytes(rng.randrange(60))
            elif kind == 1:
                data += corrupt(rng.choice(encoded), rng)
            elif kind == 2:
                data += rng.choice([b"\xa5", b"\xa5\x5a", b"\xa5\x5a\x19", b"\xa5\x5a\xff\x01"])
            else:
                raw_future = future_version_frame(rng)
                skipped.append((len(data), len(data) + len(raw_future)))
                data += raw_future
                future += 1
        spans.append((len(data), len(data) + len(raw)))
        data += raw
    assume(not mcu_ambiguous(bytes(data), spans + skipped))
    decoder = McuStreamDecoder()
    assert run(decoder, bytes(data), chunking) == frames
    assert decoder.stats.unknown_version == future


def test_sequence_gap_event() -> None:
    decoder = McuStreamDecoder()
    data = b"".join(frame(s).encode() for s in (0, 1, 2, 5, 6))
    assert [f.seq for f in decoder.feed(data)] == [0, 1, 2, 5, 6]
    assert decoder.stats.seq_gaps == 1
    assert decoder.stats.frames_missing == 2
    (event,) = decoder.pop_events()
    assert event.kind == "seq_gap"
    assert event.count == 2
    assert event.details["missing_frames"] == 2
    assert event.details["first_missing_seq"] == 3


def test_sequence_wraps_without_gap() -> None:
    decoder = McuStreamDecoder()
    data = b"".join(frame(s).encode() for s in (65533, 65534, 65535, 0, 1))
    assert len(decoder.feed(data)) == 5
    assert decoder.stats.seq_gaps == 0
    assert decoder.pop_events() == []


def test_gap_across_wrap() -> None:
    decoder = McuStreamDecoder()
    decoder.feed(frame(65534).encode() + frame(2).encode())
    assert decoder.stats.frames_missing == 3
    (event,) = decoder.pop_events()
    assert event.details["first_missing_seq"] == 65535


def test_gap_split_across_chunks() -> None:
    decoder = McuStreamDecoder()
    data = frame(10).encode() + frame(20).encode()
    frames = []
    for i in range(len(data)):
        frames += decoder.feed(data[i : i + 1])
    assert [f.seq for f in frames] == [10, 20]
    assert decoder.stats.frames_missing == 9


def test_repeat_backwards_and_reset() -> None:
    decoder = McuStreamDecoder()
    seqs = [
        (100, 0),
        (100, 0),
        (50, 0),
        (0, McuStatus.MCU_RESET),
        (1, McuStatus.MCU_RESET),
        (2, 0),
        (3, 0),
    ]
    decoder.feed(b"".join(frame(s, st).encode() for s, st in seqs))
    stats = decoder.stats
    assert (stats.seq_repeats, stats.seq_resets, stats.mcu_resets, stats.seq_gaps) == (1, 1, 1, 0)
    kinds = [e.kind for e in decoder.pop_events()]
    assert kinds == ["seq_repeat", "seq_reset", "mcu_reset"]


def test_error_counts_and_resync() -> None:
    good = frame(1).encode()
    bad_crc = good[:-1] + bytes([good[-1] ^ 0xFF])
    bad_len = good[:2] + bytes([24]) + good[3:]
    rng = random.Random(3)
    decoder = McuStreamDecoder()
    data = bad_crc + bad_len + future_version_frame(rng) + good + good[:12]
    frames = decoder.feed(data)
    assert frames == [frame(1)]
    assert decoder.flush() == []
    stats = decoder.stats
    assert stats.bad_checksum >= 1
    assert stats.bad_length >= 1
    assert stats.unknown_version == 1
    assert stats.truncated == 1
    assert set(stats.errors()) >= {"bad_checksum", "bad_length", "unknown_version", "truncated"}


def test_trailing_sync_byte_is_kept() -> None:
    decoder = McuStreamDecoder()
    raw = frame(7).encode()
    assert decoder.feed(b"\x00\x00" + raw[:1]) == []
    assert decoder.pending_bytes == 1
    assert decoder.feed(raw[1:]) == [frame(7)]
    assert decoder.stats.bytes_skipped == 2


def spurious_prefix(real: bytes, shift: int) -> bytes:
    """``shift`` bytes that, followed by ``real``, form a 30-byte version-1 candidate whose CRC
    checks: the candidate's CRC bytes are bytes of the real frame, two filler bytes chosen to
    match (CRC-16 takes each value for some pair)."""
    head = b"\xa5\x5a\x19\x01"
    filler_len = shift - len(head)
    for k in range(1 << 16):
        filler = bytes(filler_len - 2) + k.to_bytes(2, "little")
        candidate = (head + filler + real)[:30]
        if crc16_ccitt_false(candidate[2:28]) == int.from_bytes(candidate[28:30], "little"):
            return head + filler
    raise AssertionError("no filler makes the candidate check")


def test_spurious_frame_overlapping_a_real_one_is_rejected() -> None:
    real = frame(5).encode()
    prefix = spurious_prefix(real, 10)
    data = frame(4).encode() + prefix + real + frame(6).encode()
    decoder = McuStreamDecoder()
    # whole stream at once, and byte by byte (the real frame is complete when it is judged)
    assert decoder.feed(data) + decoder.flush() == [frame(4), frame(5), frame(6)]
    assert decoder.stats.bad_length == 1
    assert decoder.stats.bytes_skipped == len(prefix)
    one = McuStreamDecoder()
    got = [f for i in range(len(data)) for f in one.feed(data[i:i + 1])] + one.flush()
    # fed byte by byte the candidate completes before the real frame does: it is taken (the
    # rule never holds a frame back), and the real frame it overlaps is lost
    assert len(got) == 3 and got[0] == frame(4) and got[-1] == frame(6)
