"""NAV200 stream decoders: garbage, corruption, any chunking; never an exception."""

from __future__ import annotations

import functools
import random
from typing import TypeVar

from hypothesis import assume, given, settings
from hypothesis import strategies as st
from wire_strategies import (
    ambiguous,
    chunking_strategy,
    corrupt,
    nav200_candidate_checks,
    reply_strategy,
    request_strategy,
    split,
)

from lgvtool.devices.nav200.nav200_commands import ErrorReply, Reply, Request, decode_reply
from lgvtool.devices.nav200.nav200_framing import encode_telegram
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.devices.nav200.nav200_replies import (
    build_ack_reply,
    build_error_reply,
    build_pose_reply,
)
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder, Nav200RequestDecoder
from lgvtool.wire.decode_events import DecoderStats
from lgvtool.wire.resync_stream import StreamDecoder

T = TypeVar("T")

STREAM = settings(max_examples=60, deadline=None)

#: Bytes that steer the soup into the decoder's deeper paths: STX, plausible LENs, letters.
soup_bytes = st.lists(
    st.one_of(
        st.integers(0, 255),
        st.sampled_from([0x02, 0x05, 0x06, 0x07, 0x09, 0x0F, 0x11, 0x00, 0xFF]),
        st.sampled_from(b"SRMPUDEAVTPNvwLOCIG"),
    ),
    max_size=600,
).map(bytes)


def check_accounting(stats: DecoderStats, pending: int) -> None:
    assert stats.bytes_received == stats.bytes_decoded + stats.bytes_skipped + pending


def run(decoder: StreamDecoder[T], data: bytes, chunking: str | list[int]) -> list[T]:
    out: list[T] = []
    for chunk in split(data, chunking):
        out += decoder.feed(chunk)
        check_accounting(decoder.stats, decoder.pending_bytes)
    out += decoder.flush()
    check_accounting(decoder.stats, decoder.pending_bytes)
    assert decoder.pending_bytes == 0
    return out


@STREAM
@given(st.one_of(st.binary(max_size=2000), soup_bytes), chunking_strategy)
def test_byte_soup_never_raises(data: bytes, chunking: str | list[int]) -> None:
    replies = Nav200ReplyDecoder()
    assert len(run(replies, data, chunking)) == replies.stats.frames
    requests = Nav200RequestDecoder()
    assert len(run(requests, data, chunking)) == requests.stats.frames
    for decoder in (replies, requests):
        for event in decoder.pop_events():
            assert event.kind in {*DecoderStats.ERROR_KINDS, "bytes_skipped", "device_error"}


def build_stream(
    messages: list[bytes], seed: int, garbage_max: int
) -> tuple[bytes, list[tuple[int, int]], list[bytes]]:
    """Good telegrams with garbage and damaged telegrams between them."""
    rng = random.Random(seed)
    out = bytearray()
    spans = []
    for raw in messages:
        for _ in range(rng.randrange(3)):
            kind = rng.randrange(3)
            if kind == 0:
                out += rng.randbytes(rng.randrange(garbage_max + 1))
            elif kind == 1:
                out += corrupt(rng.choice(messages), rng)
            else:
                letters = rng.choice([b"XZ", b"Qq", b"ab"])
                out += encode_telegram(chr(letters[0]), chr(letters[1]), rng.randbytes(4))
        spans.append((len(out), len(out) + len(raw)))
        out += raw
    out += rng.randbytes(rng.randrange(garbage_max + 1))
    return bytes(out), spans, messages


@STREAM
@given(
    st.lists(reply_strategy(), min_size=1, max_size=12),
    st.integers(0, 2**32),
    chunking_strategy,
)
def test_replies_survive_garbage_and_damage(
    replies: list[Reply], seed: int, chunking: str | list[int]
) -> None:
    data, spans, _ = build_stream([r.encode() for r in replies], seed, 40)
    check = functools.partial(nav200_candidate_checks, replies=True)
    assume(not ambiguous(data, spans, check, lookahead=chunking == "all"))
    decoder = Nav200ReplyDecoder()
    assert run(decoder, data, chunking) == replies
    assert decoder.stats.frames == len(replies)


@STREAM
@given(
    st.lists(request_strategy(), min_size=1, max_size=12),
    st.integers(0, 2**32),
    chunking_strategy,
)
def test_requests_survive_garbage_and_damage(
    requests: list[Request], seed: int, chunking: str | list[int]
) -> None:
    data, spans, _ = build_stream([r.encode() for r in requests], seed, 40)
    check = functools.partial(nav200_candidate_checks, replies=False)
    assume(not ambiguous(data, spans, check, lookahead=chunking == "all"))
    decoder = Nav200RequestDecoder()
    assert run(decoder, data, chunking) == requests


def test_stx_inside_data_is_not_a_start() -> None:
    # X = 0x0202 mm puts two STX bytes in the data; LEN 17 of an STX-started candidate fails.
    reply = Reply("PP", Pose(0x0202, 0x02050202, 0x0202, 2, 2))
    raw = reply.encode()
    assert raw.count(0x02) > 3
    for chunking in ("bytes", "all", [3, 5]):
        assert run(Nav200ReplyDecoder(), raw * 3, chunking) == [reply] * 3


def test_bad_checksum_does_not_lose_next_telegram() -> None:
    good = build_pose_reply(1, 2, 0.5, 90, 5)
    bad = good[:-1] + bytes([good[-1] ^ 0x01])
    decoder = Nav200ReplyDecoder()
    frames = decoder.feed(bad + good)
    assert len(frames) == 1
    assert decoder.stats.bad_checksum == 1
    assert decoder.stats.bytes_skipped == len(bad)
    kinds = [e.kind for e in decoder.pop_events()]
    assert kinds == ["bad_checksum", "bytes_skipped"]


def test_truncated_telegram_then_good_one() -> None:
    good = build_pose_reply(1, 2, 0.5, 90, 5)
    short = build_ack_reply("PA")
    decoder = Nav200ReplyDecoder()
    # A PP reply cut after 6 bytes, followed by a PA reply and another PP reply.
    frames = run(decoder, good[:6] + short + good, "bytes")
    assert frames == [decode_reply(short), decode_reply(good)]
    assert decoder.stats.bad_checksum + decoder.stats.bad_length >= 1


def test_impossible_and_wrong_length() -> None:
    decoder = Nav200ReplyDecoder()
    assert decoder.feed(b"\x02\x04PA\x00") == []
    assert decoder.stats.bad_length == 1
    # PP reply with LEN 5 (that is the request's length): rejected as soon as the code is seen.
    assert decoder.feed(b"\x02\x05PP") == []
    assert decoder.stats.bad_length == 2
    assert decoder.pending_bytes == 0


def test_unknown_command_and_truncated_counts() -> None:
    decoder = Nav200ReplyDecoder()
    assert decoder.feed(encode_telegram("X", "Y", b"\x01\x02")) == []
    assert decoder.stats.unknown_command == 1
    assert decoder.feed(build_pose_reply(0, 0, 0, 0, 0)[:10]) == []
    assert decoder.flush() == []
    assert decoder.stats.truncated == 1
    assert decoder.stats.errors()["truncated"] == 1


def test_error_reply_is_delivered_and_counted() -> None:
    decoder = Nav200ReplyDecoder()
    frames = decoder.feed(build_error_reply("PP", 1, 7, 9))
    assert len(frames) == 1 and isinstance(frames[0], ErrorReply)
    assert decoder.stats.error_replies == 1
    (event,) = decoder.pop_events()
    assert event.kind == "device_error"
    assert event.details["detail"] == 9
    diag = event.diagnostic({"sec": 1, "nsec": 2})
    assert diag["source"] == "nav200" and diag["level"] == 4


def test_cut_off_telegram_whose_xor_cancels() -> None:
    # The first k bytes of a PP reply, complete telegrams, then the same k bytes again: the
    # XOR over 17 bytes is 0 by construction. The complete telegrams must win.
    good = build_pose_reply(1, 2, 0.5, 90, 5)
    for middle, k in (
        (build_ack_reply("PA"), 6),
        (build_error_reply("PP", 1, 7, 9), 4),
    ):
        data = good[:k] + middle + good
        assert len(good[:k] + middle + good[:k]) == 17
        decoder = Nav200ReplyDecoder()
        frames = run(decoder, data, "bytes")
        assert frames == [decode_reply(middle), decode_reply(good)]
        assert decoder.stats.bad_length == 1


def test_seeded_fuzz_never_crashes_a_decoder() -> None:
    """A few thousand inputs per decoder (the 10^6 run is benchmarks/fuzz_decoders.py)."""
    from wire_fuzz import DECODERS, fuzz

    for name in DECODERS:
        failures = fuzz(name, 1500, seed=7)
        assert failures == [], (name, failures[:1])
