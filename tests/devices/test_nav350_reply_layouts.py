"""NAV350 reply layouts, checked against bytes built here field by field.

Every frame below is assembled with ``struct.pack`` from the published layout (protocol note
sections 3, 6 and 7; docs/protocol.md section 5), framed by hand (``02 02 02 02``, u32 payload
length, payload, XOR of the payload), without using the codec. The codec must decode each to
the expected typed value and encode that value back to exactly those bytes.
"""

from __future__ import annotations

import itertools
import re
import struct
from array import array
from pathlib import Path

import pytest

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_cola import ASCII, BINARY, parse_frame
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.wire.wire_errors import BadLengthError

DOCS = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"


# ------------------------------------------------------------------ independent builder
def xor(data: bytes) -> int:
    out = 0
    for b in data:
        out ^= b
    return out


def cola_b(kind: str, name: str, args: bytes = b"") -> bytes:
    """A CoLa-B frame by hand: command text, one space and the arguments (none: no space)."""
    payload = f"{kind} {name}".encode("ascii") + (b" " + args if args else b"")
    return b"\x02\x02\x02\x02" + struct.pack(">I", len(payload)) + payload + bytes([xor(payload)])


def cola_a(text: str) -> bytes:
    return b"\x02" + text.encode("ascii") + b"\x03"


def flag(on: bool) -> bytes:
    return struct.pack(">H", 1 if on else 0)


def pose_block(pose: tuple[int, int, int] | None, opt: tuple[int, ...] | None) -> bytes:
    """pose flag [x i32, y i32, phi u32, opt flag [outputMode u8, ts u32, meanDev i32,
    navMode u8, infoState u32, used u8]]: the opt flag only after a pose."""
    if pose is None:
        assert opt is None
        return flag(False)
    out = flag(True) + struct.pack(">iiI", *pose)
    if opt is None:
        return out + flag(False)
    return out + flag(True) + struct.pack(">BIiBIB", *opt)


def reflector(cart: tuple[int, int] | None, polar: tuple[int, int] | None,
              opt: tuple[int, ...] | None) -> bytes:
    out = flag(cart is not None) + (struct.pack(">ii", *cart) if cart else b"")
    out += flag(polar is not None) + (struct.pack(">II", *polar) if polar else b"")
    # localID u16, globalID u16, type u8, subType u16, quality u16, ts u32, size u16,
    # hitCount u16, meanEcho u16, startIndex u16, endIndex u16
    out += flag(opt is not None) + (struct.pack(">HHBHHIHHHHH", *opt) if opt else b"")
    return out


def landmark_block(filt: int, reflectors: list[bytes]) -> bytes:
    return struct.pack(">BH", filt, len(reflectors)) + b"".join(reflectors)


def pose_reply_args(version: int, err: int, wait: int, mask: int, pose_part: bytes,
                    landmarks: bytes | None, scan_channels: int = 0,
                    remission: bool = False) -> bytes:
    out = struct.pack(">HBBB", version, err, wait, mask) + pose_part
    out += flag(landmarks is not None) + (landmarks or b"")
    out += struct.pack(">H", scan_channels)
    assert scan_channels == 0 and not remission  # scan blocks are covered by the codec tests
    return out + flag(remission)


# ------------------------------------------------------------------ expected values
OPT = (1, 1_000_000, 15, 4, 0, 5)
POSE = (12345, -6789, 90000)
R1_OPT = (3, 17, 1, 2, 90, 999_000, 80, 6, 310, 100, 104)
LMS = tg.LandmarkData(1, (
    tg.Landmark((1000, -2000), (2236, 296565), tg.LandmarkInfo(*R1_OPT)),
    tg.Landmark((-4000, 500), None, None),
))
LMS_BYTES = landmark_block(1, [reflector((1000, -2000), (2236, 296565), R1_OPT),
                               reflector((-4000, 500), None, None)])
MAP_OPT = (0, 7, 1, 1, 95, 4242, 80, 40, 500, 12, 15)
MAP_LMS = tg.LandmarkData(1, (tg.Landmark((10000, -5000), None, tg.LandmarkInfo(*MAP_OPT)),))
MAP_LMS_BYTES = landmark_block(1, [reflector((10000, -5000), None, MAP_OPT)])
STORED = (tg.StoredLandmark(1, 10000, -5000, 1, 1, 80, (0,)),
          tg.StoredLandmark(2, -2500, 12000, 1, 2, 100, (0, 1)))


def stored_bytes(err: int, marks: tuple[tg.StoredLandmark, ...]) -> bytes:
    out = struct.pack(">BH", err, len(marks))
    for m in marks:
        out += struct.pack(">HiiBBHH", m.global_id, m.x_mm, m.y_mm, m.type, m.subtype,
                           m.size_mm, len(m.layers))
        out += b"".join(struct.pack(">H", layer) for layer in m.layers)
    return out


CASES: list[tuple[str, tg.Telegram, bytes]] = [
    ("pose + optional pose + landmarks",
     tg.Telegram("sAN", "mNPOSGetData", tg.PoseData(1, 0, 1, 1, POSE, tg.PoseInfo(*OPT), LMS)),
     cola_b("sAN", "mNPOSGetData",
            pose_reply_args(1, 0, 1, 1, pose_block(POSE, OPT), LMS_BYTES))),
    ("no pose (errorCode 4) + landmarks",
     tg.Telegram("sAN", "mNPOSGetData", tg.PoseData(1, 4, 1, 1, None, None, LMS)),
     cola_b("sAN", "mNPOSGetData", pose_reply_args(1, 4, 1, 1, pose_block(None, None),
                                                   LMS_BYTES))),
    ("no pose + nothing",
     tg.Telegram("sAN", "mNPOSGetData", tg.PoseData(1, 4, 1, 2)),
     cola_b("sAN", "mNPOSGetData", pose_reply_args(1, 4, 1, 2, pose_block(None, None), None))),
    ("pose without optional pose",
     tg.Telegram("sAN", "mNPOSGetData", tg.PoseData(1, 0, 1, 0, POSE)),
     cola_b("sAN", "mNPOSGetData", pose_reply_args(1, 0, 1, 0, pose_block(POSE, None), None))),
    ("mapping reply with landmarks",
     tg.Telegram("sAN", "mNMAPDoMapping", tg.MappingResult(0, MAP_LMS)),
     cola_b("sAN", "mNMAPDoMapping", struct.pack(">B", 0) + flag(True) + MAP_LMS_BYTES)),
    ("mapping reply without landmarks",
     tg.Telegram("sAN", "mNMAPDoMapping", tg.MappingResult(7, None)),
     cola_b("sAN", "mNMAPDoMapping", struct.pack(">B", 7) + flag(False))),
    ("mNMAPDoMapping request",
     tg.do_mapping(), cola_b("sMN", "mNMAPDoMapping")),
    ("NMAPMapCfg request",
     tg.map_config(50, 0, 1000, -2000, 90000),
     cola_b("sWN", "NMAPMapCfg", struct.pack(">BBiii", 50, 0, 1000, -2000, 90000))),
    ("mNLAYGetLayer request",
     tg.get_layer(0), cola_b("sMN", "mNLAYGetLayer", struct.pack(">H", 0))),
    ("mNLAYGetLayer reply",
     tg.Telegram("sAN", "mNLAYGetLayer", tg.LayerIds(0, (1, 2, 3, 7))),
     cola_b("sAN", "mNLAYGetLayer", struct.pack(">BH4H", 0, 4, 1, 2, 3, 7))),
    ("mNLAYGetLandmark request",
     tg.get_landmarks([1, 2]), cola_b("sMN", "mNLAYGetLandmark", struct.pack(">HHH", 2, 1, 2))),
    ("mNLAYGetLandmark reply",
     tg.Telegram("sAN", "mNLAYGetLandmark", tg.StoredLandmarks(0, STORED)),
     cola_b("sAN", "mNLAYGetLandmark", stored_bytes(0, STORED))),
]


@pytest.mark.parametrize(("case", "telegram", "raw"), CASES, ids=[c[0] for c in CASES])
def test_hand_built_bytes_decode_and_re_encode_exactly(case: str, telegram: tg.Telegram,
                                                       raw: bytes) -> None:
    back = tg.decode_frame(parse_frame(raw), len(raw))
    assert (back.kind, back.name, back.value) == (telegram.kind, telegram.name, telegram.value)
    assert back.size == len(raw)
    assert telegram.encode(BINARY) == raw
    assert back.encode() == raw


def test_hand_built_framing_of_the_notes_examples() -> None:
    # the builder reproduces the protocol note's own worked frames (sections 1 and 7)
    assert cola_b("sMN", "mNPOSGetData", b"\x01\x02").hex(" ").upper() == (
        "02 02 02 02 00 00 00 13 73 4D 4E 20 6D 4E 50 4F 53 47 65 74 44 61 74 61 20 01 02 7A")
    wrong_mode = cola_b("sAN", "mNPOSGetData",
                        pose_reply_args(1, 1, 1, 2, pose_block(None, None), None))
    assert wrong_mode.hex(" ").upper() == (
        "02 02 02 02 00 00 00 1E 73 41 4E 20 6D 4E 50 4F 53 47 65 74 44 61 74 61 20 "
        "00 01 01 01 02 00 00 00 00 00 00 00 00 76")


def test_no_pose_reply_round_trips_in_cola_a() -> None:
    text = ("sAN mNPOSGetData 1 4 1 1 0 "                 # version, errorCode 4, wait, mask, pose 0
            "1 1 2 "                                        # landmarks present, filter, count
            "1 +1000 -2000 1 8BC 48675 "                    # cartesian, polar
            "1 3 11 1 2 5A F3E58 50 6 136 64 68 "           # optional data
            "1 -4000 +500 0 0 "                             # second: cartesian only
            "0 0")                                          # no scan, no remission
    raw = cola_a(text)
    data = tg.PoseData(1, 4, 1, 1, None, None, LMS)
    back = tg.decode_frame(parse_frame(raw))
    assert back.value == data and back.dialect == ASCII
    assert tg.Telegram("sAN", "mNPOSGetData", data).encode(ASCII) == raw
    assert back.encode() == raw
    # and the same value in CoLa-B is the hand-built four-flag frame
    assert back.encode(BINARY) == CASES[1][2]


def test_the_old_five_flag_layout_is_not_what_the_encoder_writes() -> None:
    data = tg.PoseData(1, 4, 1, 1, None, None, LMS)
    # five flags: an optional-pose flag although the pose flag is 0
    five = cola_b("sAN", "mNPOSGetData", struct.pack(">HBBB", 1, 4, 1, 1) + flag(False)
                  + flag(False) + flag(True) + LMS_BYTES + struct.pack(">H", 0) + flag(False))
    four = CASES[1][2]
    assert tg.Telegram("sAN", "mNPOSGetData", data).encode() == four
    assert four != five and len(five) == len(four) + 2
    # read by the vendor parser's rules the extra flag shifts every later field
    with pytest.raises(BadLengthError):
        tg.decode_frame(parse_frame(five))
    nothing_five = cola_b("sAN", "mNPOSGetData", struct.pack(">HBBB", 1, 4, 1, 2) + bytes(10))
    with pytest.raises(BadLengthError):
        tg.decode_frame(parse_frame(nothing_five))


def test_optional_pose_without_a_pose_cannot_be_encoded() -> None:
    bad = tg.Telegram("sAN", "mNPOSGetData", tg.PoseData(1, 4, 1, 2, None, tg.PoseInfo(*OPT)))
    for dialect in (BINARY, ASCII):
        with pytest.raises(BadLengthError, match="optional pose data without a pose"):
            bad.encode(dialect)


def _combinations() -> list[tg.PoseData]:
    dist = tg.ScanChannel("DIST1", 1.0, 0.0, 0, 250, 77, array("I", range(8)))
    angl = tg.ScanChannel("ANGL1", 1.0, 0.0, 0, 250, 77, array("I", range(0, 16, 2)))
    rssi = tg.ScanChannel("RSSI1", 1.0, 0.0, 0, 250, 77, array("H", range(8)))
    out = []
    for err, (pose, info), lms, scans, rem in itertools.product(
            (0, 4), ((None, None), (POSE, None), (POSE, tg.PoseInfo(*OPT))),
            (None, LMS, tg.LandmarkData(0, ())), ((), (dist,), (dist, angl)), (None, rssi)):
        out.append(tg.PoseData(1, err, 1, 2, pose, info, lms, scans, rem))
    return out


@pytest.mark.parametrize("dialect", [BINARY, ASCII])
def test_every_combination_of_present_blocks_round_trips(dialect: str) -> None:
    for data in _combinations():
        raw = tg.Telegram("sAN", "mNPOSGetData", data).encode(dialect)
        back = tg.decode_frame(parse_frame(raw))
        assert back.value == data
        assert back.encode() == raw
    for value in (tg.MappingResult(0, MAP_LMS), tg.MappingResult(1, None),
                  tg.MappingResult(0, tg.LandmarkData(1, ()))):
        t = tg.Telegram("sAN", "mNMAPDoMapping", value)
        assert tg.decode_frame(parse_frame(t.encode(dialect))).value == value
    for t in (tg.get_layer(3), tg.get_landmarks(range(50)), tg.get_landmarks([]),
              tg.Telegram("sAN", "mNLAYGetLayer", tg.LayerIds(0, ())),
              tg.Telegram("sAN", "mNLAYGetLandmark", tg.StoredLandmarks(0, STORED)),
              tg.Telegram("sAN", "mNLAYGetLandmark", tg.StoredLandmarks(1, ())),
              tg.map_config(127, 1, -10_000_000, 10_000_000, -360_000), tg.do_mapping()):
        back = tg.decode_frame(parse_frame(t.encode(dialect)))
        assert (back.kind, back.name, back.value) == (t.kind, t.name, t.value)


def test_builders_and_tables() -> None:
    assert tg.get_landmarks((5, 6)).value == (5, 6)
    with pytest.raises(ValueError, match="at most 50"):
        tg.get_landmarks(range(51))
    for name in ("mNMAPDoMapping", "mNLAYGetLayer", "mNLAYGetLandmark"):
        assert name in tg.METHODS
        assert tg.is_known("sMN", name) and tg.is_known("sAN", name)
    assert "NMAPMapCfg" in tg.WRITABLE and tg.is_known("sWA", "NMAPMapCfg")
    assert tg.LAYOUTS[("sWN", "NMAPMapCfg")] == ("u8", "u8", "i32", "i32", "i32")
    for name in ("MappingResult", "LayerIds", "StoredLandmark", "StoredLandmarks",
                 "map_config", "do_mapping", "get_layer", "get_landmarks",
                 "MAX_LANDMARKS_PER_REQUEST"):
        assert name in tg.__all__


OVERLONG: list[tuple[str, bytes]] = [
    # count 3 but one reflector's bytes
    ("mapping", cola_b("sAN", "mNMAPDoMapping", struct.pack(">BHBH", 0, 1, 1, 3)
                       + reflector((1, 2), None, None))),
    ("layer ids", cola_b("sAN", "mNLAYGetLayer", struct.pack(">BHHH", 0, 9, 1, 2))),
    ("id list", cola_b("sMN", "mNLAYGetLandmark", struct.pack(">HH", 4, 1))),
    ("stored", cola_b("sAN", "mNLAYGetLandmark",
                      struct.pack(">BH", 0, 2) + stored_bytes(0, STORED[:1])[3:])),
    ("stored layers", cola_b("sAN", "mNLAYGetLandmark",
                             struct.pack(">BHHiiBBHHH", 0, 1, 1, 0, 0, 1, 1, 80, 3, 0))),
    ("pose landmarks", cola_b("sAN", "mNPOSGetData",
                              struct.pack(">HBBB", 1, 4, 1, 1) + flag(False) + flag(True)
                              + struct.pack(">BH", 1, 40) + reflector(None, None, None))),
]


@pytest.mark.parametrize(("case", "raw"), OVERLONG, ids=[c[0] for c in OVERLONG])
def test_a_count_beyond_the_bytes_is_a_bad_length(case: str, raw: bytes) -> None:
    with pytest.raises(BadLengthError):
        tg.decode_frame(parse_frame(raw))


def test_ascii_count_beyond_the_tokens_is_a_bad_length() -> None:
    for text in ("sAN mNMAPDoMapping 0 1 1 3 1 +1 +2 0 0", "sAN mNLAYGetLayer 0 9 1 2",
                 "sAN mNLAYGetLandmark 0 2 1 +0 +0 1 1 50 1 0"):
        with pytest.raises(BadLengthError):
            tg.decode_frame(parse_frame(cola_a(text)))


def test_stream_decoder_skips_an_overlong_mapping_reply_and_decodes_the_next() -> None:
    bad = OVERLONG[0][1]
    good = CASES[4][2]
    dec = Nav350StreamDecoder()
    out = dec.feed(bad + good)
    out += dec.flush()
    assert [(t.kind, t.name, t.value) for t in out] == [
        ("sAN", "mNMAPDoMapping", tg.MappingResult(0, MAP_LMS))]
    assert dec.stats.bad_length == 1 and dec.stats.frames == 1
    assert dec.stats.bad_checksum == dec.stats.unknown_command == dec.stats.truncated == 0
    events = dec.pop_events()
    assert [e.kind for e in events if e.kind != "bytes_skipped"] == ["bad_length"]
    assert "mNMAPDoMapping" in events[0].message
    assert dec.stats.bytes_skipped == len(bad)


# ------------------------------------------------------------------ docs/protocol.md examples
_HEX_SPAN = re.compile(r"`([0-9A-F]{2}(?: [0-9A-F]{2})*)`")


def doc_frames() -> list[tuple[str, bytes]]:
    """Every CoLa-B frame of a table row of docs/protocol.md section 5 (the NAV350): the row's
    first cell and the concatenated hex spans of the row."""
    text = DOCS.read_text(encoding="utf-8")
    section = text[text.index("## 5. NAV350"):]
    out = []
    for line in section.splitlines():
        if not line.startswith("|"):
            continue
        spans = _HEX_SPAN.findall(line)
        raw = bytes.fromhex(" ".join(spans)) if spans else b""
        if raw[:4] == b"\x02\x02\x02\x02" and len(raw) >= 9:
            out.append((line.split("|")[1].strip(), raw))
    return out


def test_docs_nav350_examples_decode_and_re_encode() -> None:
    frames = doc_frames()
    assert len(frames) >= 16
    for label, raw in frames:
        t = tg.decode_frame(parse_frame(raw))
        assert t.encode(BINARY) == raw, label
    # the new sections' examples are the hand-built frames of this file
    docs = {raw for _, raw in frames}
    for case in ("mapping reply with landmarks", "NMAPMapCfg request", "mNLAYGetLayer reply",
                 "mNLAYGetLandmark request", "mNLAYGetLandmark reply",
                 "no pose (errorCode 4) + landmarks", "no pose + nothing"):
        raw = next(r for c, _, r in CASES if c == case)
        assert raw in docs, case
