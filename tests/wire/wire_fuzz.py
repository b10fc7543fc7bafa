"""A seeded random fuzzer of the stream decoders: byte soups, damaged and spliced frames, and
random chunking. Shared by the test suite (a few thousand inputs) and
``benchmarks/fuzz_decoders.py`` (10^6 inputs)."""

from __future__ import annotations

import random
from collections.abc import Callable

from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.devices.nav200.nav200_replies import build_error_reply, build_pose_reply, build_version_reply
from lgvtool.devices.nav200.nav200_stream import Nav200ReplyDecoder, Nav200RequestDecoder
from lgvtool.wire.resync_stream import StreamDecoder


def _mcu_frames(rng: random.Random) -> bytes:
    return b"".join(McuFrame(seq=rng.randrange(65536), mcu_time_ms=rng.randrange(1 << 32),
                             enc_left=rng.randrange(-(1 << 31), 1 << 31),
                             enc_right=rng.randrange(-(1 << 31), 1 << 31),
                             gyro_raw=rng.randrange(-32768, 32768),
                             status=rng.randrange(65536)).encode()
                    for _ in range(rng.randrange(1, 6)))


def _nav_replies(rng: random.Random) -> bytes:
    parts = []
    for _ in range(rng.randrange(1, 6)):
        k = rng.randrange(3)
        if k == 0:
            parts.append(build_pose_reply(rng.uniform(-100, 100), rng.uniform(-100, 100),
                                          rng.uniform(-4, 4), rng.randrange(256),
                                          rng.randrange(256)))
        elif k == 1:
            parts.append(build_version_reply(rng.randrange(10), rng.randrange(10),
                                             rng.randrange(10)))
        else:
            parts.append(build_error_reply("PP", 1, 1, 1))
    return b"".join(parts)


def _nav_requests(rng: random.Random) -> bytes:
    from lgvtool.devices.nav200 import nav200_requests as rq

    makers = [rq.request_pose, rq.request_version, rq.request_standby,
              lambda: rq.request_read_reflector(rng.randrange(4), rng.randrange(32)),
              lambda: rq.request_change_reflector(rng.randrange(4), rng.randrange(32),
                                                  rng.uniform(-50, 50), rng.uniform(-50, 50))]
    return b"".join(rng.choice(makers)().encode() for _ in range(rng.randrange(1, 6)))


#: per decoder: how to make it, and valid traffic to damage
DECODERS: dict[str, tuple[Callable[[], StreamDecoder[object]], Callable[[random.Random], bytes]]] = {
    "mcu": (McuStreamDecoder, _mcu_frames),  # type: ignore[dict-item]
    "nav200-reply": (Nav200ReplyDecoder, _nav_replies),  # type: ignore[dict-item]
    "nav200-request": (Nav200RequestDecoder, _nav_requests),  # type: ignore[dict-item]
}


def fuzz_input(rng: random.Random, valid: Callable[[random.Random], bytes]) -> bytes:
    """One input: random bytes, or valid traffic with flipped bits, dropped, repeated or
    inserted bytes, cut off, or spliced with random bytes."""
    kind = rng.randrange(5)
    if kind == 0:
        return rng.randbytes(rng.randrange(0, 300))
    data = bytearray(valid(rng))
    if kind == 1:
        for _ in range(rng.randrange(1, 4)):
            i = rng.randrange(len(data))
            data[i] ^= 1 << rng.randrange(8)
    elif kind == 2:
        for _ in range(rng.randrange(1, 4)):
            i = rng.randrange(len(data))
            op = rng.randrange(3)
            if op == 0:
                del data[i]
            elif op == 1:
                data.insert(i, rng.randrange(256))
            else:
                data[i:i] = data[i:i + rng.randrange(1, 8)]
            if not data:
                break
    elif kind == 3:
        data = data[:rng.randrange(len(data) + 1)]
    else:
        cut = rng.randrange(len(data) + 1)
        data = data[:cut] + bytearray(rng.randbytes(rng.randrange(0, 40))) + data[cut:]
    return bytes(data)


def run_one(make: Callable[[], StreamDecoder[object]], data: bytes, rng: random.Random) -> None:
    """Feed ``data`` in random chunks, then flush; check the byte accounting. Raises on any
    decoder failure."""
    decoder = make()
    pos = 0
    while pos < len(data):
        n = rng.randrange(1, 64)
        decoder.feed(data[pos:pos + n])
        pos += n
    decoder.flush()
    decoder.pop_events()
    s = decoder.stats
    if s.bytes_received != s.bytes_decoded + s.bytes_skipped or decoder.pending_bytes:
        raise AssertionError(f"byte accounting broken: {s}")


def fuzz(name: str, count: int, seed: int) -> list[tuple[bytes, BaseException]]:
    """Run ``count`` inputs through decoder ``name``; the inputs that made it fail."""
    make, valid = DECODERS[name]
    rng = random.Random(seed)
    failures: list[tuple[bytes, BaseException]] = []
    for _ in range(count):
        data = fuzz_input(rng, valid)
        try:
            run_one(make, data, rng)
        except Exception as exc:  # every failure is a finding
            failures.append((data, exc))
    return failures
