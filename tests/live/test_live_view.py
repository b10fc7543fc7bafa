"""The live view: a log played to the Foxglove WebSocket server, seen by a protocol client."""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("foxglove")
pytest.importorskip("websockets")

from foxglove_client import collect

from lgvtool.errors import InputError
from lgvtool.live.drawing import drawing_of
from lgvtool.live.live_playback import play, prepare_channels
from lgvtool.live.live_server import LiveAddress, LiveServer, parse_address
from lgvtool.live.online import OnlineEstimator
from lgvtool.live.tap import LiveFeed, TappedLogWriter
from lgvtool.localize.replay_driver import run_replay
from lgvtool.log import LogReader, topics
from lgvtool.log.schemas import schema_bytes


def test_address_parsing() -> None:
    assert parse_address("8765") == LiveAddress("127.0.0.1", 8765)
    assert parse_address("0.0.0.0:9000") == LiveAddress("0.0.0.0", 9000)
    assert parse_address("[::1]:9001") == LiveAddress("::1", 9001)
    assert parse_address("localhost:0") == LiveAddress("localhost", 0)
    for bad in ("", "host:", ":80", "x:99999", "[::1]9", "abc"):
        with pytest.raises(InputError):
            parse_address(bad)


def _busy_port() -> tuple[socket.socket, int]:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    return s, s.getsockname()[1]


def test_port_in_use_and_unknown_host_are_bad_input() -> None:
    s, port = _busy_port()
    try:
        with pytest.raises(InputError, match="cannot listen"):
            LiveServer(LiveAddress("127.0.0.1", port))
    finally:
        s.close()
    with pytest.raises(InputError, match="does not resolve"):
        LiveServer(LiveAddress("no-such-host.invalid", 0))


@pytest.mark.parametrize("how", ["port", "host"])
def test_record_live_fails_before_recording(tmp_path: Path, how: str) -> None:
    """One line, exit 2, and no log file: the recording never started."""
    s, port = _busy_port()
    live = f"127.0.0.1:{port}" if how == "port" else "no-such-host.invalid:8765"
    out = tmp_path / "run.mcap"
    try:
        p = subprocess.run([sys.executable, "-m", "lgvtool", "record", "--mcu",
                            "tcp://127.0.0.1:9", "-o", str(out), "--duration", "1",
                            "--no-status", "--live", live, "--live-estimator", "pf"],
                           capture_output=True, text=True, timeout=60)
    finally:
        s.close()
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("lgvtool: error: --live"), p.stderr
    assert "Traceback" not in p.stderr
    assert not out.exists()


def test_view_live_port_in_use(circle_log: Path) -> None:
    s, port = _busy_port()
    try:
        p = subprocess.run([sys.executable, "-m", "lgvtool", "view", str(circle_log), "--live",
                            str(port)], capture_output=True, text=True, timeout=60)
    finally:
        s.close()
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr


def test_a_log_played_live_mirrors_its_channels_and_the_online_estimate(circle_log: Path
                                                                         ) -> None:
    reader = LogReader(circle_log)
    # the filter's compiled kernels made (or loaded) before the clock starts: on a cold cache
    # they take seconds, during which the live feed rightly skips the stale observations
    run_replay(reader, ["pf"], settings={"pf.particles": 500})
    server = LiveServer(LiveAddress("127.0.0.1", 0))
    prepare_channels(server, reader)
    feed = LiveFeed(server,
                    [OnlineEstimator("pf", reader.config(), settings={"pf.particles": 500})],
                    drawing=drawing_of(reader.config()))
    done: dict[str, object] = {}
    player = threading.Thread(target=lambda: done.update(r=play(reader, feed, speed=6.0)))
    player.start()
    try:
        wanted = {topics.NAV_POSE, topics.MCU_FRAME, topics.NAV_REFLECTORS,
                  topics.estimate_pose("pf"), topics.estimate_state("pf"),
                  topics.estimate_tf("pf"), topics.estimate_covariance("pf"), topics.MAP,
                  topics.NAV_HEAD, topics.NAV_TF, topics.NAV_SCAN, topics.TRUTH_TF,
                  topics.REFERENCE}
        got = collect(feed.server.url, None, timeout=8.0)  # the 30 s log plays in 5 s
    finally:
        player.join(60)
        feed.close()
    assert got.subprotocol in ("foxglove.websocket.v1", "foxglove.sdk.v1")
    assert got.server_info["op"] == "serverInfo" and "time" in got.server_info["capabilities"]
    # the same topics, schemas and encoding as the log, plus the online estimate
    log_topics = reader.topics()
    assert set(log_topics) <= set(got.channels)
    for topic, info in log_topics.items():
        ch = got.channels[topic]
        assert ch["encoding"] == "json" and ch["schemaEncoding"] == "jsonschema"
        assert ch["schemaName"] == info.schema
        assert json.loads(ch["schema"]) == json.loads(schema_bytes(info.schema))
    assert got.channels[topics.estimate_pose("pf")]["schemaName"] == "foxglove.PoseInFrame"
    # the NAV drawn live (a raw log), and the online estimate's view channels, as replay
    # writes them
    assert got.channels[topics.NAV_SCAN]["schemaName"] == "foxglove.PointCloud"
    assert all(m["frame_id"] == "nav/head" and m["point_stride"] == 20
               for _, m in got.messages[topics.NAV_SCAN])
    assert got.channels[topics.estimate_tf("pf")]["schemaName"] == "foxglove.FrameTransforms"
    # the reference circle, once the drive has gone 3/4 of the way round (after 25 s)
    assert got.channels[topics.REFERENCE]["schemaName"] == "foxglove.SceneUpdate"
    assert all(m["entities"][0]["id"] == "reference-circle"
               for _, m in got.messages[topics.REFERENCE])
    assert got.channels[topics.estimate_covariance("pf")]["schemaName"] == "foxglove.SceneUpdate"
    # every subscribed topic received; the map (published once) reached the late subscriber
    assert wanted <= set(got.messages)
    (refl,) = {json.dumps(m) for _, m in got.messages[topics.MAP]}
    assert len(json.loads(refl)["reflectors"]) == len(reader.reflector_map())
    # the messages are the log's bytes, decoded
    poses = [m for _, m in got.messages[topics.NAV_POSE]]
    logged = {json.dumps(m.data, sort_keys=True) for m in reader.messages([topics.NAV_POSE])}
    assert all(json.dumps(p, sort_keys=True) in logged for p in poses)
    # the online pf follows the ground truth
    truth = reader.dataframe(topics.TRUTH)
    est = got.messages[topics.estimate_state("pf")]
    t = np.array([ts for ts, _ in est]) * 1e-9
    err = np.hypot(np.array([m["x"] for _, m in est]) - np.interp(t, truth.t, truth.x),
                   np.array([m["y"] for _, m in est]) - np.interp(t, truth.t, truth.y))
    assert len(est) > 50 and float(np.median(err[len(err) // 4:])) < 0.15
    assert all(len(m["covariance"]) == 9 and math.isfinite(m["heading"]) for _, m in est)
    # the frame pf/O sits at each estimate's position (map -> pf/O, then pf/O -> pf/head)
    state_at = {ts: (m["x"], m["y"]) for ts, m in est}
    frames = got.messages[topics.estimate_tf("pf")]
    assert len(frames) > 50
    for ts, m in frames:
        o, head = m["transforms"]
        assert (o["parent_frame_id"], o["child_frame_id"], head["child_frame_id"]) == (
            "map", "pf/O", "pf/head")
        if ts in state_at:
            x, y = state_at[ts]
            assert (o["translation"]["x"], o["translation"]["y"]) == pytest.approx((x, y), abs=1e-9)
    ellipses = got.messages[topics.estimate_covariance("pf")]
    assert len(ellipses) > 50 and all(e["entities"][0]["frame_id"] == "map" for _, e in ellipses)
    assert got.times, "the playback broadcasts the data's time"
    assert done["r"].messages == sum(i.count for i in log_topics.values())  # type: ignore[attr-defined]
    stats = feed.stats()
    assert stats["failures"] == 0 and stats["latency"]["count"] > 50


class _Recorder:
    def __init__(self) -> None:
        self.seen: list[tuple[str, str, bytes, int]] = []

    def message(self, topic: str, schema: str, data: bytes, log_time_ns: int) -> None:
        self.seen.append((topic, schema, data, log_time_ns))


@pytest.mark.parametrize("chunk_seconds", [1.0, None])
def test_tapped_writer_hands_on_exactly_what_it_writes(tmp_path: Path, circle_log: Path,
                                                       chunk_seconds: float | None) -> None:
    tap = _Recorder()
    out = tmp_path / "copy.mcap"
    src = LogReader(circle_log)
    msgs = list(src.raw_messages())
    with TappedLogWriter(out, tap=tap, chunk_seconds=chunk_seconds) as w:
        w.write_map(src.reflector_map(), msgs[0].log_time_ns)
        w.write_diagnostic("test", "gap", "a gap", msgs[0].log_time_ns)
        w.write_encoded_many([m.topic for m in msgs if m.topic.startswith("/nav")],
                             [m.data for m in msgs if m.topic.startswith("/nav")],
                             [m.log_time_ns for m in msgs if m.topic.startswith("/nav")])
    back = [(m.topic, m.schema, m.data, m.log_time_ns) for m in LogReader(out).raw_messages()]
    assert sorted(tap.seen) == sorted(back)
    assert {t for t, *_ in tap.seen} >= {topics.MAP, topics.MAP_SCENE, topics.DIAGNOSTICS,
                                          topics.DIAGNOSTICS_LOG, topics.NAV_POSE}


class _StubServer:
    url = "ws://stub"

    def __init__(self) -> None:
        self.counts: dict[str, int] = {}
        self.published: list[str] = []

    def prepare(self, channels: dict[str, str]) -> None:
        pass

    def publish(self, topic: str, schema: str, data: bytes, t_ns: int) -> None:
        self.published.append(topic)
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def close(self) -> None:
        pass


class _SlowEstimator:
    name = "slow"
    output_topics = ("/estimate/slow/pose",)
    def __init__(self) -> None:
        self.seen: list[str] = []
        self.update_seconds: list[float] = []

    def feed(self, topic: str, data: bytes, t_ns: int) -> list:
        import time

        from lgvtool.live.online import Output

        self.seen.append(topic)
        if topic != topics.NAV_REFLECTORS:
            return []
        time.sleep(0.3)
        return [Output("/estimate/slow/pose", "foxglove.PoseInFrame", b"{}", t_ns)]


def test_a_lagging_estimator_skips_stale_observations_but_never_motion() -> None:
    est = _SlowEstimator()
    feed = LiveFeed(_StubServer(), [est])  # type: ignore[arg-type,list-item]
    for i in range(8):
        feed.message(topics.NAV_REFLECTORS, "lgvtool.ReflectorScan", b"{}", i)
        feed.message(topics.MCU_FRAME, "lgvtool.McuFrame", b"{}", i)
    feed.close(timeout=30.0)
    assert feed.shed >= 1
    assert est.seen.count(topics.MCU_FRAME) == 8            # motion is never skipped
    assert est.seen.count(topics.NAV_REFLECTORS) == 8 - feed.shed
    assert est.seen[-2:] == [topics.NAV_REFLECTORS, topics.MCU_FRAME]   # the newest is used
    assert feed.stats()["shed"] == feed.shed


def test_view_as_fast_as_possible_says_so(circle_log: Path) -> None:
    from lgvtool.app.view_job import ViewOptions, view_log
    from lgvtool.live.live_server import LiveAddress

    said: list[str] = []
    out = view_log(ViewOptions(str(circle_log), LiveAddress("127.0.0.1", 0), speed=0.0,
                               show_progress=False), notify=said.append)
    assert len(said) == 1 and said[0].endswith("as fast as possible"), said
    assert out.document["messages"] > 0


def test_a_channel_under_a_schema_lgvtool_lacks_is_left_out_and_said(circle_log: Path,
                                                                       tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap.writer import Writer

    from lgvtool.app.view_job import ViewOptions, view_log
    from lgvtool.live.live_server import LiveAddress

    log = tmp_path / "with-foreign.mcap"
    with circle_log.open("rb") as f, log.open("wb") as g:
        reader, w = make_reader(f), Writer(g)
        w.start(profile="", library="test")
        ids: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages():
            if channel.id not in ids:
                sid = w.register_schema(schema.name, schema.encoding, schema.data)
                ids[channel.id] = w.register_channel(channel.topic, channel.message_encoding,
                                                     sid, channel.metadata)
            w.add_message(ids[channel.id], message.log_time, message.data,
                          message.publish_time)
        sid = w.register_schema("acme.Thing", "jsonschema", b'{"type": "object"}')
        cid = w.register_channel("/acme/thing", "json", sid)
        w.add_message(cid, message.log_time, b"{}", message.log_time)
        for record in reader.iter_metadata():
            w.add_metadata(record.name, record.metadata)
        w.finish()
    warned: list[str] = []
    out = view_log(ViewOptions(str(log), LiveAddress("127.0.0.1", 0), speed=0.0,
                               show_progress=False), warn=warned.append)
    assert warned == ["/acme/thing is not played: lgvtool has no schema named 'acme.Thing'"]
    assert out.document["messages"] > 0
