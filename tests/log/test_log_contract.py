"""The log contract: schemas, write/read round trip, salvage, info, bad input."""

from __future__ import annotations

import base64
import json
import warnings
from pathlib import Path

import jsonschema
import pytest
from mcap.writer import Writer

from lgvtool.config import default_config
from lgvtool.errors import LogFormatError
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.inspect import describe
from lgvtool.log.messages import pose_in_frame, poses_in_frame, stamp
from lgvtool.log.salvage import recover
from lgvtool.log.schemas import schema_dir, schema_json, schema_names

T0 = 1_700_000_000_000_000_000
MS = 1_000_000


def mcu_msg(ns: int, seq: int) -> dict:
    return {"timestamp": stamp(ns), "version": 1, "seq": seq % 65536, "mcu_time_ms": seq * 100,
            "enc_left": seq * 37, "enc_right": seq * 41, "gyro_raw": -12, "gyro_scale": 0.010986,
            "gyro_rate": -0.0023, "steering_angle": 1.0472, "drive_speed": 0.36, "status": 1}


def build_log(path: Path, seconds: float = 10.0) -> dict[str, list]:
    """A log with every lgvtool message type; returns what was written per topic."""
    cfg = default_config()
    written: dict[str, list] = {}

    def put(w: LogWriter, topic: str, msg: dict, ns: int) -> None:
        w.write(topic, msg, ns)
        written.setdefault(topic, []).append((ns, msg))

    with LogWriter(path, source="test") as w:
        w.write_config(cfg)
        w.add_metadata("run", {"operator": "test", "laps": 8, "ok": True})
        w.write_map(cfg.reflectors, T0)
        n = int(seconds * 10)
        for i in range(n):
            ns = T0 + i * 100 * MS
            raw = bytes([0xA5, 0x5A, i % 256]) * 10
            w.write_raw("mcu", "rx", raw, ns)
            written.setdefault(topics.MCU_RX, []).append((ns, raw))
            put(w, topics.MCU_FRAME, mcu_msg(ns + 1, i), ns + 1)
            put(w, topics.ODOM, {"timestamp": stamp(ns), "v": 0.18, "omega": 0.26}, ns + 2)
            put(w, topics.TRUTH, pose_in_frame(ns, 1.0 + i * 0.01, 2.0, 0.1 * i), ns + 3)
            if i % 4 == 0:
                put(w, topics.NAV_POSE, {"timestamp": stamp(ns), "x": 1.5, "y": 2.5, "heading": 0.3,
                                         "quality": 90, "reflectors_used": 5, "valid": True}, ns + 4)
                put(w, topics.NAV_REFLECTORS, {"timestamp": stamp(ns), "scan_period": 0.125,
                                               "observations": [{"range": 3.2, "bearing": -0.4,
                                                                 "time_in_scan": 0.01, "id": 3}]},
                    ns + 5)
                put(w, topics.estimate_pose("pf"), pose_in_frame(ns, 1.0, 2.0, 0.3), ns + 6)
                put(w, topics.estimate_state("pf"), {
                    "timestamp": stamp(ns), "estimator": "pf", "x": 1.0, "y": 2.0, "heading": 0.3,
                    "covariance": [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-3], "particles": 150,
                    "ess": 120.5}, ns + 7)
                put(w, topics.estimate_particles("pf"),
                    poses_in_frame(ns, [(1.0, 2.0, 0.3), (1.1, 2.1, 0.2)]), ns + 8)
        w.write_diagnostic("mcu", "seq_gap", "2 frames missing", T0 + 5 * MS, count=2,
                           details={"first_missing_seq": 7})
    return written


def test_schemas_are_draft_2020_12_with_titles_and_units() -> None:
    names = schema_names()
    for required in ("lgvtool.McuFrame", "lgvtool.Odometry", "lgvtool.NavPose",
                     "lgvtool.ReflectorScan", "lgvtool.ReflectorMap", "lgvtool.Diagnostic",
                     "lgvtool.RawBytes", "lgvtool.PoseEstimate", "foxglove.PoseInFrame",
                     "foxglove.PosesInFrame", "foxglove.SceneUpdate", "foxglove.Log"):
        assert required in names
    for name in names:
        s = schema_json(name)
        jsonschema.Draft202012Validator.check_schema(s)
        assert s["title"] == name

        _check_units(s, name)


def _check_units(node: dict, where: str) -> None:
    """Every numeric field has a description that states its unit (after a comma)."""
    if node.get("type") in ("number", "integer"):
        desc = node.get("description", "")
        assert "," in desc, f"{where}: description gives no unit: {desc!r}"
    for key, sub in node.get("properties", {}).items():
        _check_units(sub, f"{where}.{key}")
    if isinstance(node.get("items"), dict):
        _check_units(node["items"], f"{where}[]")


def test_every_written_message_validates(tmp_path: Path) -> None:
    path = tmp_path / "all.mcap"
    build_log(path)
    r = LogReader(path)
    validators = {n: jsonschema.Draft202012Validator(schema_json(n)) for n in schema_names()}
    seen = set()
    for m in r.raw_messages():
        validators[m.schema].validate(json.loads(m.data))
        seen.add(m.schema)
    assert len(seen) >= 11


def test_round_trip_messages_and_metadata(tmp_path: Path) -> None:
    path = tmp_path / "rt.mcap"
    written = build_log(path)
    r = LogReader(path)
    assert r.complete and not r.warnings
    got: dict[str, list] = {}
    times = []
    for m in r.messages():
        times.append(m.log_time_ns)
        data = base64.b64decode(m.data["data"]) if m.topic == topics.MCU_RX else m.data
        got.setdefault(m.topic, []).append((m.log_time_ns, data))
    assert times == sorted(times)
    for topic, items in written.items():
        assert got[topic] == items, topic
    assert r.metadata["run"] == {"operator": "test", "laps": 8, "ok": True}
    assert r.metadata["lgvtool"]["format_version"] == "1.0"
    assert r.metadata["lgvtool"]["source"] == "test"
    assert r.config() == default_config()
    assert r.reflector_map() == default_config().reflectors


def test_dataframes_have_si_columns(tmp_path: Path) -> None:
    path = tmp_path / "df.mcap"
    build_log(path, seconds=2)
    r = LogReader(path)
    mcu = r.dataframe(topics.MCU_FRAME)
    assert len(mcu) == 20
    assert mcu["mcu_time"].iloc[1] == pytest.approx(0.1)
    assert mcu["gyro_scale"].iloc[0] == pytest.approx(0.010986 * 3.141592653589793 / 180)
    truth = r.dataframe(topics.TRUTH)
    assert list(truth.columns[:6]) == ["t", "stamp", "x", "y", "z", "heading"]
    assert truth["heading"].iloc[3] == pytest.approx(0.3)
    assert truth["t"].iloc[0] == pytest.approx(T0 / 1e9 + 3e-9)
    scans = r.dataframe(topics.NAV_REFLECTORS)
    assert list(scans["id"]) == [3] * 5
    empty = r.dataframe("/not/there")
    assert empty.empty


@pytest.mark.parametrize("fraction", [0.6, 0.3, 0.95])
def test_truncated_log_salvages_every_complete_message(tmp_path: Path, fraction: float) -> None:
    path = tmp_path / "full.mcap"
    written = build_log(path, seconds=30)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * fraction)])
    with pytest.warns(UserWarning, match="incomplete log"):
        r = LogReader(cut)
    assert not r.complete
    got = list(r.messages([topics.TRUTH]))
    truth = written[topics.TRUTH]
    assert len(got) > 0
    # every salvaged message is exactly one that was written, in order, with none skipped
    assert [(m.log_time_ns, m.data) for m in got] == truth[: len(got)]
    # chunks close every second of log time: at most about 1 s before the cut is lost
    whole = LogReader(path)
    # the last message whose chunk is fully inside the cut
    assert r.metadata["lgvtool"]["format_version"] == "1.0"
    assert whole.complete


def test_crash_loses_at_most_about_one_second(tmp_path: Path) -> None:
    """Stop writing without finishing (as kill -9 would): what is on disk is at most ~1 s old."""
    path = tmp_path / "crash.mcap"
    w = LogWriter(path, chunk_seconds=1.0)
    last = 0
    for i in range(600):  # 60 s at 10 Hz
        last = T0 + i * 100 * MS
        w.write(topics.ODOM, {"timestamp": stamp(last), "v": 0.1, "omega": 0.0}, last)
    w._stream.flush()  # what the OS has; the writer is never closed
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = LogReader(path)
    got = [m.log_time_ns for m in r.messages()]
    assert not r.complete
    assert (last - got[-1]) / 1e9 <= 1.05
    w._stream.close()


def test_recover_writes_complete_indexed_log(tmp_path: Path) -> None:
    path = tmp_path / "full.mcap"
    build_log(path, seconds=20)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: int(path.stat().st_size * 0.6)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        salvaged = [(m.topic, m.log_time_ns, m.data) for m in LogReader(cut).messages()]
    report = recover(cut, tmp_path / "fixed.mcap")
    fixed = LogReader(tmp_path / "fixed.mcap")
    assert fixed.complete
    assert [(m.topic, m.log_time_ns, m.data) for m in fixed.messages()] == salvaged
    assert report.messages == len(salvaged) and not report.was_complete
    assert fixed.metadata["config"] == LogReader(path).metadata["config"]


def test_info_figures(tmp_path: Path) -> None:
    path = tmp_path / "info.mcap"
    build_log(path, seconds=10)
    d = describe(LogReader(path))
    assert d["complete"] is True
    mcu = d["topics"][topics.MCU_FRAME]
    assert mcu["schema"] == "lgvtool.McuFrame"
    assert mcu["count"] == 100
    assert mcu["rate_hz"] == pytest.approx(10.0)
    assert mcu["max_gap_s"] == pytest.approx(0.1)
    assert d["topics"][topics.NAV_POSE]["rate_hz"] == pytest.approx(2.5)
    assert d["topics"][topics.NAV_POSE]["max_gap_s"] == pytest.approx(0.4)
    assert d["duration_s"] == pytest.approx(9.9 + 8e-9, abs=1e-6)


def test_info_cli_json_keys(tmp_path: Path, run_cli) -> None:
    path = tmp_path / "info.mcap"
    build_log(path, seconds=3)
    out = run_cli("info", path, "--json")
    assert out.returncode == 0, out.stderr
    d = json.loads(out.stdout)
    assert {"file", "size_bytes", "complete", "salvaged", "format_version", "start_time_s",
            "end_time_s", "duration_s", "message_count", "topics", "metadata"} <= set(d)
    assert d["topics"]["/odom/twist"]["count"] == 30
    text = run_cli("info", path)
    assert text.returncode == 0 and "/mcu/frame" in text.stdout and "lgvtool.McuFrame" in text.stdout


def _foreign(path: Path) -> None:
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("x.Thing", "jsonschema", b"{}")
        cid = w.register_channel("/camera/thing", "json", sid)
        w.add_message(cid, 1, b"{}", 1)
        w.finish()


def _newer(path: Path) -> None:
    with LogWriter(path) as w:
        w.add_metadata("lgvtool", {"format_version": "2.0"})
    # the writer's own record says 1.0 first; the later one wins as the reader keeps the last
    # record of a name


@pytest.mark.parametrize("case,expect", [
    ("missing", "no such file"),
    ("directory", "directory"),
    ("empty", "empty file"),
    ("text", "not an MCAP file"),
    ("foreign", "not an lgvtool log"),
    ("newer", "newer than this lgvtool reads"),
])
def test_bad_input_one_line_exit_2(tmp_path: Path, run_cli, case: str, expect: str) -> None:
    path = tmp_path / f"{case}.mcap"
    if case == "directory":
        path.mkdir()
    elif case == "empty":
        path.write_bytes(b"")
    elif case == "text":
        path.write_text("hello\n")
    elif case == "foreign":
        _foreign(path)
    elif case == "newer":
        _newer(path)
    if case == "foreign":  # info describes any MCAP file; a command that needs lgvtool topics refuses
        described = run_cli("info", path)
        assert described.returncode == 0 and expect in described.stdout
        out = run_cli("replay", path, "-o", tmp_path / "out.mcap")
    else:
        out = run_cli("info", path)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert expect in lines[0] and "Traceback" not in out.stderr
    if case in ("foreign", "newer"):
        with pytest.raises(LogFormatError):
            LogReader(path)


def test_schema_dir_is_found() -> None:
    assert (schema_dir() / "lgvtool.McuFrame.json").is_file()
