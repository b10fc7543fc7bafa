"""Decoded frames as schema-valid JSON message dicts."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import jsonschema
import pytest

from lgvtool.devices.mcu.mcu_frame import McuFrame, decode_mcu_frame
from lgvtool.devices.nav200.nav200_commands import Reply, decode_reply
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.devices.nav200.nav200_replies import build_pose_reply
from lgvtool.log.messages import mcu_frame_message, nav_pose_message
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import DecodeEvent

SCHEMAS = Path(__file__).resolve().parents[2] / "schemas"


def schema(name: str) -> dict[str, Any]:
    loaded: dict[str, Any] = json.loads((SCHEMAS / f"{name}.json").read_text())
    return loaded


STAMP = {"sec": 1_700_000_000, "nsec": 123_456_789}


def test_stamp() -> None:
    assert stamp(1_700_000_000_123_456_789) == STAMP


def test_mcu_frame_message() -> None:
    raw = bytes.fromhex(
        "A5 5A 19 01 D2 04 08 E2 01 00 40 E2 01 00 47 94 03 00 4B 05 EA 2A 70 17 68 01 01 00 3C A6"
    )
    msg = mcu_frame_message(decode_mcu_frame(raw), STAMP)
    jsonschema.validate(msg, schema("lgvtool.McuFrame"))
    assert msg["seq"] == 1234
    assert msg["gyro_scale"] == pytest.approx(0.010986)
    assert msg["steering_angle"] == pytest.approx(math.radians(60))
    assert msg["drive_speed"] == pytest.approx(0.36)
    assert msg["timestamp"] == STAMP
    extreme = McuFrame(
        seq=65535,
        mcu_time_ms=2**32 - 1,
        enc_left=-(2**31),
        enc_right=2**31 - 1,
        gyro_raw=-32768,
        gyro_scale_udeg_s=65535,
        status=0xFFFF,
    )
    jsonschema.validate(mcu_frame_message(extreme, STAMP), schema("lgvtool.McuFrame"))


def test_nav_pose_message() -> None:
    reply = decode_reply(build_pose_reply(1.0, -2.0, math.pi / 2, 100, 4))
    assert isinstance(reply, Reply)
    msg = nav_pose_message(reply, STAMP)
    jsonschema.validate(msg, schema("lgvtool.NavPose"))
    assert (msg["x"], msg["y"], msg["quality"], msg["reflectors_used"]) == (1.0, -2.0, 100, 4)
    assert msg["heading"] == pytest.approx(math.pi / 2)
    assert msg["valid"] is True
    half_turn = nav_pose_message(Pose(0, 0, -32768, 0xFF, 0), STAMP)
    assert half_turn["heading"] == math.pi
    assert half_turn["valid"] is False
    with pytest.raises(TypeError):
        nav_pose_message(Reply("PA"), STAMP)


def test_event_as_diagnostic() -> None:
    event = DecodeEvent("mcu", "seq_gap", "3 MCU frames missing", 3, 3, {"first_missing_seq": 17})
    diag = event.diagnostic(STAMP)
    jsonschema.validate(diag, schema("lgvtool.Diagnostic"))
    assert diag["details"] == {"first_missing_seq": 17}
