"""NAV350 codec: the worked bytes of the protocol note, both dialects, the stream decoder."""

from __future__ import annotations

import random
from array import array

import pytest

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_cola import ASCII, BINARY, encode_frame, parse_frame, xor_checksum
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.wire.wire_errors import BadLengthError, ChecksumError


def h(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", "").replace("|", ""))


WORKED = [
    (tg.set_access_mode(), "02 02 02 02 00 00 00 17 73 4D 4E 20 53 65 74 41 63 63 65 73 73 4D "
                           "6F 64 65 20 03 F4 72 47 44 B3"),
    (tg.change_state(4), "02 02 02 02 00 00 00 16 73 4D 4E 20 6D 4E 45 56 41 43 68 61 6E 67 65 "
                         "53 74 61 74 65 20 04 74"),
    (tg.get_pose_data(1, 2), "02 02 02 02 00 00 00 13 73 4D 4E 20 6D 4E 50 4F 53 47 65 74 44 "
                             "61 74 61 20 01 02 7A"),
    (tg.set_speed(1.0, -1.0, 0.5, 123456789), "02 02 02 02 00 00 00 1F 73 4D 4E 20 6D 4E 50 4F "
     "53 53 65 74 53 70 65 65 64 20 03 E8 FC 18 00 00 6F E7 07 5B CD 15 00 19"),
]

POSE_ONLY = ("02 02 02 02 00 00 00 3B | 73 41 4E 20 6D 4E 50 4F 53 47 65 74 44 61 74 61 20 | "
             "00 01 00 01 00 | 00 01 00 00 30 39 FF FF E5 7B 00 01 5F 90 | 00 01 01 00 0F 42 40 "
             "00 00 00 0F 04 00 00 00 00 05 | 00 00 00 00 00 00 | 2E")


@pytest.mark.parametrize(("telegram", "hexbytes"), WORKED)
def test_worked_requests_are_byte_exact(telegram: tg.Telegram, hexbytes: str) -> None:
    assert telegram.encode(BINARY) == h(hexbytes)
    back = tg.decode_frame(parse_frame(h(hexbytes)))
    assert (back.kind, back.name, back.value) == (telegram.kind, telegram.name, telegram.value)


def test_worked_ascii_request() -> None:
    assert tg.get_pose_data(1, 2).encode(ASCII) == h(
        "02 73 4D 4E 20 6D 4E 50 4F 53 47 65 74 44 61 74 61 20 31 20 32 03")
    assert tg.set_access_mode().encode(ASCII) == b"\x02sMN SetAccessMode 3 F4724744\x03"


def test_speed_fields_truncate_toward_zero() -> None:
    assert tg.speed_fields(1.0, -1.0, 0.5, 123456789) == (1000, -1000, 28647, 123456789, 0)
    assert tg.speed_fields(-0.0019, 0.0, -0.5, 2**32 + 5)[::2] == (-1, -28647, 0)
    assert tg.speed_fields(0.0, 0.0, 0.0, 2**32 + 5)[3] == 5


def test_worked_pose_reply() -> None:
    data = tg.PoseData(1, 0, 1, 0, (12345, -6789, 90000), tg.PoseInfo(1, 1_000_000, 15, 4, 0, 5))
    raw = tg.Telegram("sAN", "mNPOSGetData", data).encode()
    assert raw == h(POSE_ONLY)
    assert len(raw) == 68
    assert tg.decode_frame(parse_frame(raw)).value == data


def test_wrong_mode_reply_has_four_flags() -> None:
    data = tg.PoseData(1, 1, 1, 2)
    raw = tg.Telegram("sAN", "mNPOSGetData", data).encode()
    # no pose, so no optional-pose flag: pose, landmark, scan-channel and remission flags
    # (the note's section 7 example, 39 bytes)
    note = h("02 02 02 02 00 00 00 1E 73 41 4E 20 6D 4E 50 4F 53 47 65 74 44 61 74 61 20 "
             "00 01 01 01 02 00 00 00 00 00 00 00 00 76")
    assert raw == note
    assert tg.decode_frame(parse_frame(note)).value == data
    # a reply that ends before the remission flag still decodes (no remission block)
    short = encode_frame(BINARY, "sAN", "mNPOSGetData", h("00 01 01 01 02 00 00 00 00 00 00"))
    assert tg.decode_frame(parse_frame(short)).value == data


def full_reply() -> tg.PoseData:
    marks = tuple(tg.Landmark((1000 * i, -2000 * i), (3000 + i, 45000 * i),
                              tg.LandmarkInfo(i, 10 + i, 1, 1, 90, 1000 + i, 80, 5, 200, 10, 12))
                  for i in range(3))
    dist = tg.ScanChannel("DIST1", 1.0, 0.0, 0, 250, 1000, array("I", range(5000, 6440)))
    rssi = tg.ScanChannel("RSSI1", 1.0, 0.0, 0, 250, 1000, array("H", (i % 256 for i in range(1440))))
    return tg.PoseData(1, 0, 1, 2, (1, -2, 359999), tg.PoseInfo(1, 2, -3, 4, 5, 3),
                       tg.LandmarkData(1, marks), (dist,), rssi)


@pytest.mark.parametrize("dialect", [BINARY, ASCII])
def test_full_reply_round_trips(dialect: str) -> None:
    data = full_reply()
    raw = tg.Telegram("sAN", "mNPOSGetData", data).encode(dialect)
    if dialect == BINARY:
        assert len(raw) == 8896
    back = tg.decode_frame(parse_frame(raw))
    assert back.value == data and back.dialect == dialect


def test_every_fixed_layout_round_trips_in_both_dialects() -> None:
    rng = random.Random(3)
    ranges = {"u8": (0, 255), "u16": (0, 65535), "u32": (0, 2**32 - 1),
              "i16": (-32768, 32767), "i32": (-2**31, 2**31 - 1)}
    for (kind, name), layout in tg.LAYOUTS.items():
        values = tuple("V2.1" if c == "flex" else rng.randint(*ranges[c]) for c in layout)
        t = tg.Telegram(kind, name, values)
        for dialect in (BINARY, ASCII):
            back = tg.decode_frame(parse_frame(t.encode(dialect)))
            assert (back.kind, back.name, back.value) == (kind, name, values), (kind, name)
    add = tg.add_landmarks((tg.LayoutLandmark(-5, 7, 1, 2, 80, (0, 3)),))
    reply = tg.Telegram("sAN", "mNLAYAddLandmark", tg.AddedLandmarks(0, (1, 2, 3)))
    for t in (add, reply):
        for dialect in (BINARY, ASCII):
            assert tg.decode_frame(parse_frame(t.encode(dialect))).value == t.value


def test_sfa_and_ack_telegrams() -> None:
    raw = tg.error_reply(2).encode()
    assert raw[8:12] == b"sFA " and raw[12:14] == b"\x00\x02"
    t = tg.decode_frame(parse_frame(raw))
    assert t.is_error and t.describe() == "sFA 2 (unknown method index)"
    ack = tg.decode_frame(parse_frame(tg.reply("sMA", "mNEVAChangeState").encode()))
    assert ack.kind == "sMA" and ack.name == "mNEVAChangeState" and ack.value == ()


def test_parse_errors_are_typed() -> None:
    raw = bytearray(tg.get_pose_data().encode())
    raw[-1] ^= 1
    with pytest.raises(ChecksumError):
        parse_frame(bytes(raw))
    too_short = tg.Telegram("sMN", "mNPOSGetData", (1,))
    with pytest.raises(BadLengthError):
        too_short.encode()


def test_xor_checksum_matches_a_plain_fold() -> None:
    rng = random.Random(5)
    for n in (0, 1, 2, 3, 7, 8, 9, 100, 8887):
        data = bytes(rng.randrange(256) for _ in range(n))
        expect = 0
        for b in data:
            expect ^= b
        assert xor_checksum(data) == expect


def stream_of(*telegrams: tg.Telegram, dialect: str = BINARY) -> bytes:
    return b"".join(t.encode(dialect) for t in telegrams)


def test_stream_resynchronises_after_garbage_bad_checksums_and_cut_frames() -> None:
    good = [tg.Telegram("sAN", "mNPOSGetData", full_reply()), tg.reply("sAN", "SetAccessMode", 1),
            tg.error_reply(13), tg.reply("sWA", "NEVACurrLayer")]
    bad = bytearray(good[0].encode())
    bad[-1] ^= 0xFF
    cut = good[0].encode()[:500]
    rng = random.Random(1)
    junk = bytes(rng.randrange(256) for _ in range(300)).replace(b"\x02", b"\x01")
    ascii_reply = tg.reply("sAN", "mNPOSSetSpeed", 0).encode(ASCII)
    stream = (junk + good[0].encode() + bytes(bad) + good[1].encode() + cut + good[2].encode()
              + b"\x02\x02\x02\x02\xff\xff\xff\xff" + good[3].encode() + ascii_reply)
    dec = Nav350StreamDecoder()
    out = []
    for i in range(0, len(stream), 97):  # arbitrary chunking
        out += dec.feed(stream[i:i + 97])
    out += dec.flush()
    names = [(t.kind, t.name) for t in out]
    assert names == [("sAN", "mNPOSGetData"), ("sAN", "SetAccessMode"), ("sFA", ""),
                     ("sWA", "NEVACurrLayer"), ("sAN", "mNPOSSetSpeed")]
    assert out[0].value == full_reply()
    s = dec.stats
    assert s.bad_checksum >= 1 and s.bad_length >= 1 and s.error_replies == 1
    assert s.bytes_received == s.bytes_decoded + s.bytes_skipped + dec.pending_bytes
    kinds = {e.kind for e in dec.pop_events()}
    assert {"bad_checksum", "bad_length", "device_error", "bytes_skipped"} <= kinds


def test_stream_counts_unknown_commands_and_truncation() -> None:
    unknown = b"\x02\x02\x02\x02" + (5).to_bytes(4, "big") + b"sAN X" + bytes([xor_checksum(b"sAN X")])
    dec = Nav350StreamDecoder()
    assert dec.feed(unknown) == []
    assert dec.stats.unknown_command == 1
    device_side = Nav350StreamDecoder(deliver_unknown=True)
    got = device_side.feed(b"\x02sMN mNFooBar 1\x03")
    assert got[0].name == "mNFooBar" and got[0].value is None
    assert device_side.stats.unknown_command == 1
    dec.feed(tg.get_pose_data().encode()[:-3])
    assert dec.flush() == [] and dec.stats.truncated == 1
    # arguments that do not fit the layout: the whole intact frame is skipped
    wrong = encode_frame(BINARY, "sAN", "SetAccessMode", b"\x01\x01")
    d2 = Nav350StreamDecoder()
    assert d2.feed(wrong) == [] and d2.stats.bad_length == 1
