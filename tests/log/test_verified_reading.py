"""Verified reading: corrupt chunks are skipped and counted, foreign schemas refused by name,
decoded values range-checked. Every corrupt file is built here from a short simulated run."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from simlogs import simulate_log

from lgvtool.errors import LogFormatError
from lgvtool.localize.logdata import load_log
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.log.mcap_records import read_summary
from lgvtool.timestamps import stamp

pytestmark = pytest.mark.filterwarnings("ignore::lgvtool.log.reader.LogWarning")


@pytest.fixture(scope="module")
def simulated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return simulate_log(tmp_path_factory.mktemp("sim") / "run.mcap", 40, 3)


def rewrite(src: Path, dst: Path, compression: str) -> None:
    """``src`` message by message into ``dst`` with ``compression`` and 5 s chunks."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(src)
    with LogWriter(dst, compression=compression, chunk_seconds=5.0, source="test") as w:
        for name, record in reader.metadata.items():
            if name != "lgvtool":
                w.add_metadata(name, record)
        for m in reader.raw_messages():
            w.channel_id(m.topic, m.schema)
            w.write_encoded(m.topic, m.data, m.log_time_ns, m.publish_time_ns)


def flip(path: Path, chunk: int, at: float, n: int = 2) -> int:
    """Flip ``n`` bytes of chunk number ``chunk``'s data at fraction ``at`` of it; returns the
    chunk's file offset."""
    with open(path, "rb") as f:
        summary = read_summary(f)
    assert summary is not None
    ci = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)[chunk]
    data_end = ci.chunk_start_offset + ci.chunk_length
    pos = data_end - ci.compressed_size + int(ci.compressed_size * at)
    raw = bytearray(path.read_bytes())
    for k in range(n):
        raw[pos + 7 * k] ^= 0x01 << k
    path.write_bytes(bytes(raw))
    return ci.chunk_start_offset


def count(path: Path) -> tuple[int, LogReader]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = LogReader(path)
        return sum(1 for _ in r.messages()), r


@pytest.mark.parametrize("compression", ["none", "zstd", "lz4"])
def test_flipped_bytes_skip_one_chunk_and_are_counted(simulated: Path, tmp_path: Path,
                                                      run_cli, compression: str) -> None:
    good = tmp_path / "good.mcap"
    rewrite(simulated, good, compression)
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(good.read_bytes())
    offset = flip(bad, 2, 0.5)
    n_good, _ = count(good)
    n_bad, reader = count(bad)
    assert reader.complete
    assert list(reader.corrupt_chunks) == [offset]
    assert 0 < n_bad < n_good
    # the arrays the estimators read skip the same chunk
    data = load_log(reader)
    assert data.mcu is not None and len(data.mcu["t"]) > 0
    res = run_cli("info", bad)
    assert res.returncode == 0, res.stderr
    assert "complete, 1 corrupt chunks skipped" in res.stdout
    assert f"chunk at byte {offset} is corrupt" in res.stderr
    assert "Traceback" not in res.stderr
    assert "corrupt" not in run_cli("info", good).stdout


def test_corrupt_chunk_is_not_copied_by_replay_decode_recover(simulated: Path, tmp_path: Path,
                                                              run_cli) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(simulated.read_bytes())
    flip(bad, 1, 0.3, n=4)
    for args in (["replay", bad, "-o", tmp_path / "rep.mcap", "-e", "laser"],
                 ["decode", bad, "-o", tmp_path / "dec.mcap"],
                 ["recover", bad, "-o", tmp_path / "rec.mcap"]):
        res = run_cli(*args)
        assert res.returncode == 0, (args[0], res.stderr)
        said = res.stderr + (res.stdout if args[0] == "recover" else "")
        assert ("is corrupt" in said or "1 corrupt chunk skipped" in said), said
        assert "Traceback" not in res.stderr
        out = Path(str(args[3]))
        # what was written is sound for an independent reader that checks every CRC
        with open(out, "rb") as f:
            list(make_reader(f, validate_crcs=True).iter_messages())
        assert LogReader(out).verify_chunks()


def test_evaluate_on_a_corrupt_zstd_chunk_warns_not_crashes(simulated: Path, tmp_path: Path,
                                                            run_cli) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(simulated.read_bytes())
    flip(bad, 2, 0.5)
    res = run_cli("evaluate", bad, "-e", "laser", "--json")
    assert "Traceback" not in res.stderr and "internal error" not in res.stderr
    assert "is corrupt" in res.stderr + res.stdout
    assert res.returncode in (0, 2), res.stderr


def foreign(path: Path, *, encoding: str, schema: str | None, schema_encoding: str,
            data: bytes) -> None:
    """An MCAP written with the ``mcap`` package that reuses /mcu/frame, /nav/pose and
    /mcu/rx, with ``schema`` (None: each topic's own schema name from the log contract)."""
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        for topic in (topics.MCU_FRAME, topics.NAV_POSE, topics.MCU_RX):
            name = schema if schema is not None else topics.schema_for_topic(topic)
            assert name is not None
            sid = w.register_schema(name, schema_encoding, b"{}")
            cid = w.register_channel(topic, encoding, sid)
            for i in range(20):
                t = 1_704_067_200_000_000_000 + i * 100_000_000
                w.add_message(cid, t, data, t)
        w.finish()


def command(cmd: str, log: Path, out: Path) -> list[object]:
    """The command line of ``cmd`` reading ``log`` (writing ``out``)."""
    return {"replay": ["replay", log, "-o", out], "decode": ["decode", log, "-o", out],
            "recover": ["recover", log, "-o", out], "evaluate": ["evaluate", log],
            "serve": ["simulate", "serve", log, "--exit-after", "1"]}[cmd]


@pytest.mark.parametrize("cmd", ["replay", "decode", "recover", "evaluate", "serve"])
def test_foreign_encoding_on_an_lgvtool_topic_is_refused_by_name(tmp_path: Path, run_cli,
                                                                 cmd: str) -> None:
    log = tmp_path / "foreign.mcap"
    foreign(log, encoding="protobuf", schema="acme.Frame", schema_encoding="protobuf",
            data=b"\x08\x96\x01")
    res = run_cli(*command(cmd, log, tmp_path / "out.mcap"), timeout=60)
    assert res.returncode == 2, res.stderr
    line = res.stderr.strip().splitlines()[-1]
    assert "acme.Frame" in line and "protobuf" in line, line
    assert any(t in line for t in (topics.MCU_FRAME, topics.NAV_POSE, topics.MCU_RX)), line
    assert "Traceback" not in res.stderr


@pytest.mark.parametrize("cmd", ["replay", "evaluate", "serve"])
def test_other_json_fields_under_the_lgvtool_schema_are_refused(tmp_path: Path, run_cli,
                                                                cmd: str) -> None:
    log = tmp_path / "fields.mcap"
    foreign(log, encoding="json", schema=None, schema_encoding="jsonschema",
            data=b'{"speed": 1.5, "label": "x"}')
    res = run_cli(*command(cmd, log, tmp_path / "out.mcap"), timeout=60)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr
    assert "do not match" in res.stderr.strip().splitlines()[-1], res.stderr


def test_implausible_time_and_non_finite_values_are_refused(tmp_path: Path) -> None:
    log = tmp_path / "times.mcap"
    t0 = 1_704_067_200_000_000_000
    with LogWriter(log, source="test") as w:
        for i in range(30):
            t = t0 + i * 100_000_000
            ts = t + (5_000_000_000 * 10**9 if i == 20 else 0)  # 1704067220 -> 6704067220
            w.write(topics.ODOM, {"timestamp": stamp(ts), "v": 0.1, "omega": 0.0}, t)
            w.write(topics.NAV_POSE, {"timestamp": stamp(t), "x": 1.0, "y": 2.0,
                                      "heading": 0.0, "quality": 90, "reflectors_used": 5,
                                      "valid": True}, t)
    with pytest.raises(LogFormatError, match=r"/odom/twist.*outside 1990\.\.2100"):
        load_log(LogReader(log))
    log2 = tmp_path / "inf.mcap"
    with LogWriter(log2, source="test") as w:
        for i in range(30):
            t = t0 + i * 100_000_000
            w.write_encoded(topics.ODOM, b'{"timestamp":{"sec":%d,"nsec":%d},"v":1e999,'
                            b'"omega":0.0}' % (t // 10**9, t % 10**9), t, t)
    with pytest.raises(LogFormatError, match=r"/odom/twist.*(infinity|'v')"):
        load_log(LogReader(log2))


def test_summary_that_fails_its_crc_is_not_trusted(simulated: Path, tmp_path: Path) -> None:
    import struct

    bad = tmp_path / "summary.mcap"
    raw = bytearray(simulated.read_bytes())
    (summary_start,) = struct.unpack_from("<Q", raw, len(raw) - 8 - 20 - 9 + 9)
    raw[summary_start + 40] ^= 0x10  # inside the summary's first record
    bad.write_bytes(bytes(raw))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(bad)
        n_bad = sum(1 for _ in reader.messages())
    assert any("summary section does not match its CRC-32" in w for w in reader.warnings)
    assert not reader.complete
    n_good, _ = count(simulated)
    assert n_bad == n_good  # every message is still read, record by record


def test_the_recovery_summary_reads_as_a_sentence() -> None:
    from lgvtool.log.salvage import RecoveryReport

    def said(complete: bool, corrupt: int) -> str:
        return RecoveryReport(1000, 900, 12, {"/a": 12}, 0.0, 2.5, complete, corrupt).summary()

    assert said(False, 0) == ("recovered 12 messages on 1 topic, 2.5 s of data from 900 of "
                              "1000 bytes (the input was cut off)")
    assert said(True, 1).endswith("(the input was complete already; 1 corrupt chunk skipped)")
    assert said(True, 3).endswith("; 3 corrupt chunks skipped)")


def test_a_badly_damaged_log_warns_of_a_few_chunks_and_counts_them_all(
        simulated: Path, tmp_path: Path, run_cli) -> None:
    from lgvtool.log.reader import CORRUPT_CHUNKS_SAID

    bad = tmp_path / "bad.mcap"
    rewrite(simulated, bad, "zstd")  # 5 s chunks: 8 of them
    with open(bad, "rb") as f:
        summary = read_summary(f)
    assert summary is not None
    n = len(summary.chunk_indexes)
    assert n > CORRUPT_CHUNKS_SAID + 1
    for k in range(n):
        flip(bad, k, 0.5)
    res = run_cli("replay", bad, "-o", tmp_path / "r.mcap", "-e", "laser", "--no-view")
    said = [line for line in res.stderr.splitlines() if line.startswith("lgvtool: warning: ")]
    assert len(said) == CORRUPT_CHUNKS_SAID + 1, res.stderr
    assert "more chunks are corrupt" in said[-1]
    info = run_cli("info", bad, "--json")
    assert json.loads(info.stdout)["corrupt_chunks"] == n, info.stdout
