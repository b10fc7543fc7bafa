"""record --live: the recording served as it happens; clients that come and go do not
disturb it."""

from __future__ import annotations

import sys
import threading
from pathlib import Path

import pytest

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "devices"))

from devices_helpers import start_emulator, wait_for
from foxglove_client import collect

from lgvtool.devices.recorder import RecordedDevice, Recorder, RecorderSettings
from lgvtool.live.live_server import LiveAddress
from lgvtool.log import LogReader, topics


def test_record_live_serves_the_recording_and_survives_a_vanishing_client(tmp_path: Path
                                                                          ) -> None:
    server = start_emulator(tmp_path, "tcp", duration=20.0, speed=4.0)
    out = tmp_path / "run.mcap"
    urls = server.urls
    rec = Recorder(RecorderSettings(output=out, devices={"nav200": RecordedDevice(urls["nav200"]),
                                                         "mcu": RecordedDevice(urls["mcu"])},
                                    duration=6.0, status=False, fsync=False,
                                    live=LiveAddress("127.0.0.1", 0),
                                    live_estimators=("ekf",)))
    assert rec.live is not None
    url = rec.live.server.url
    result: dict[str, object] = {}
    worker = threading.Thread(target=lambda: result.update(r=rec.run()))
    try:
        worker.start()
        assert wait_for(lambda: rec.live.server.channel_id(topics.MCU_FRAME) is not None, 10.0)
        # a client that drops the connection mid-stream, offering only the protocol's older
        # name (foxglove.websocket.v1: @foxglove/ws-protocol, Lichtblick)
        dropped = collect(url, {topics.MCU_FRAME, topics.MCU_RX}, disconnect_after=5, wanted=99,
                          timeout=10.0, subprotocols=["foxglove.websocket.v1"])
        assert dropped.subprotocol == "foxglove.websocket.v1"
        assert sum(len(v) for v in dropped.messages.values()) == 5
        # another one that stays: it sees the raw bytes, the decoded frames and poses, the
        # uploaded map and the online estimate
        wanted = {topics.MCU_FRAME, topics.NAV_POSE, topics.MAP, topics.estimate_pose("ekf"),
                  topics.estimate_state("ekf")}
        got = collect(url, wanted, wanted=2, timeout=10.0)
    finally:
        worker.join(20)
        server.stop()
    assert wanted <= set(got.messages), sorted(got.messages)
    assert got.channels[topics.NAV_POSE]["schemaName"] == "lgvtool.NavPose"
    rr = result["r"]
    assert rr.stop_reason == "duration reached"  # type: ignore[attr-defined]
    log = LogReader(out)
    assert log.complete
    # the live server published every message the log holds, on the same topics
    live_counts = rr.live["published"]  # type: ignore[attr-defined]
    held = {t: i.count for t, i in log.topics().items()}
    for topic, n in held.items():
        assert rec.live.server.counts.get(topic, 0) == n, topic
    assert live_counts >= sum(held.values())
    assert rr.live["failures"] == 0  # type: ignore[attr-defined]
    assert rr.live["latency"]["count"] > 0  # type: ignore[attr-defined]
    # the frames recorded are all the MCU sent while recording (no gap from the clients)
    seqs = [m.data["seq"] for m in log.messages([topics.MCU_FRAME])]
    assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))
