"""The data-quality section: counts by source and kind, dropped and corrupt frames, NAV
replies without a position, gaps; built from a log written in the test."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from evaluate_synth import DELTA, T0, H, circle_drive

from lgvtool.evaluate.evaluation import evaluate_trajectories
from lgvtool.evaluate.html_report import render_report
from lgvtool.evaluate.quality import find_gaps, read_quality, summarise
from lgvtool.json_types import JSONObject, as_list, as_number
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.timestamps import stamp

SAMPLE = Path(__file__).resolve().parents[2] / "sample_logs" / "degraded.mcap"


def _ns(t: float) -> int:
    return round((T0 + t) * 1e9)


def _write_log(path: Path, *, faults: bool) -> None:
    with LogWriter(path) as w:
        for i in range(600):                       # 60 s of MCU frames at 10 Hz ...
            t = 0.1 * i
            if faults and 20.0 <= t < 22.0:        # ... but for a 2 s silence
                continue
            w.write(topics.MCU_FRAME, {"timestamp": stamp(_ns(t)), "seq": i,
                                       "mcu_time_ms": 100 * i, "enc_left": 0, "enc_right": 0,
                                       "gyro_rate": 0.0}, _ns(t))
        for k in range(130):                        # NAV polls every 0.45 s
            t = 0.45 * k
            valid = not (faults and k in (10, 11, 50))
            w.write(topics.NAV_POSE, {"timestamp": stamp(_ns(t)), "x": 1.0, "y": 2.0,
                                      "heading": 0.0, "quality": 90 if valid else 255,
                                      "reflectors_used": 8 if valid else 0, "valid": valid},
                    _ns(t))
        if faults:
            w.write_diagnostic("mcu", "seq_gap", "3 MCU frames missing", _ns(5.0),
                               details={"missing_frames": 3})
            w.write_diagnostic("mcu", "seq_gap", "20 MCU frames missing", _ns(22.0),
                               details={"missing_frames": 20})
            w.write_diagnostic("mcu", "bad_checksum", "bad CRC", _ns(7.0), count=2)
            w.write_diagnostic("mcu", "bytes_skipped", "30 bytes skipped", _ns(7.0),
                               details={"skipped_bytes": 30})
            w.write_diagnostic("nav200", "bad_length", "LEN 0", _ns(9.0))
            w.write_diagnostic("nav200", "unanswered", "PP got no reply", _ns(30.0), count=4)


def test_summarise_counts_kinds_frames_replies_and_gaps() -> None:
    diags: list[JSONObject] = [
        {"source": "mcu", "kind": "seq_gap", "level": 3, "count": 1,
         "timestamp": {"sec": 100, "nsec": 0}, "details": {"missing_frames": 5}},
        {"source": "nav200", "kind": "bad_checksum", "level": 3, "count": 3,
         "timestamp": {"sec": 101, "nsec": 500_000_000}, "details": {}},
        {"source": "recorder", "kind": "stopped", "level": 2, "count": 1,
         "timestamp": {"sec": 110, "nsec": 0}, "details": {}}]
    t = np.concatenate([np.arange(0.0, 5.0, 0.1), np.arange(7.0, 10.0, 0.1)]) + 100.0
    q = summarise(diags, t0=100.0, duration=10.0, nav_valid=[True, False, True, False],
                  topic_times={"/mcu/frame": t})
    assert q.by_kind == {("mcu", "seq_gap"): 1, ("nav200", "bad_checksum"): 3,
                         ("recorder", "stopped"): 1}
    assert q.by_level == {3: 4, 2: 1} and q.diagnostics == 5
    assert q.dropped_frames == 5 and q.corrupt_frames == {"nav200": 3}
    assert (q.nav_replies, q.nav_no_position) == (4, 2)
    (gap,) = q.gaps
    assert gap.topic == "/mcu/frame"
    assert gap.start == pytest.approx(4.9, abs=1e-9) and gap.length == pytest.approx(2.1, abs=1e-9)
    assert [e[0] for e in q.events] == pytest.approx([0.0, 1.5, 10.0], abs=1e-9)
    assert q.any


def test_regular_streams_have_no_gaps() -> None:
    t = np.arange(0.0, 100.0, 0.125)
    assert find_gaps("/nav/reflectors", t) == []
    jitter = t + np.random.default_rng(1).uniform(0.0, 0.02, t.size)
    assert find_gaps("/nav/reflectors", np.sort(jitter)) == []


def test_read_quality_of_a_written_log(tmp_path: Path) -> None:
    log = tmp_path / "faults.mcap"
    _write_log(log, faults=True)
    q = read_quality(LogReader(log), T0)
    assert q.by_kind == {("mcu", "seq_gap"): 2, ("mcu", "bad_checksum"): 2,
                         ("mcu", "bytes_skipped"): 1, ("nav200", "bad_length"): 1,
                         ("nav200", "unanswered"): 4}
    assert q.dropped_frames == 23 and q.corrupt_frames == {"mcu": 2, "nav200": 1}
    assert q.skipped_bytes == 30 and q.nav_unanswered == 4
    assert (q.nav_replies, q.nav_no_position) == (130, 3)
    gaps = [g for g in q.gaps if g.topic == topics.MCU_FRAME]
    assert len(gaps) == 1 and gaps[0].start == pytest.approx(19.9, abs=1e-6)
    assert gaps[0].length == pytest.approx(2.1, abs=1e-6)
    clean = tmp_path / "clean.mcap"
    _write_log(clean, faults=False)
    assert not read_quality(LogReader(clean), T0).any


def _evaluated(path: Path):
    d = {"laser": circle_drive(rotations=2.4, dt=0.45, bias=0.05, sd=0.02, seed=1)}
    res = evaluate_trajectories(d, steering_angle=DELTA, h=H, name=path.stem)
    res.path = str(path)
    return res


def test_report_has_a_data_quality_section_when_there_is_something_to_tell(tmp_path: Path
                                                                           ) -> None:
    log = tmp_path / "faults.mcap"
    _write_log(log, faults=True)
    page = render_report([_evaluated(log)])
    assert 'data-section="data-quality"' in page
    assert 'data-table="quality"' in page and 'data-table="diagnostics"' in page
    assert 'data-table="gaps"' in page and 'data-figure="data-quality"' in page
    assert "3 of 130" in page                      # NAV replies without a position
    assert "<td>23</td>" in page                   # MCU frames dropped
    clean = tmp_path / "clean.mcap"
    _write_log(clean, faults=False)
    page = render_report([_evaluated(clean)])
    assert "No diagnostics" in page and 'data-figure="data-quality"' not in page


def test_degraded_sample_counts_match_its_diagnostics() -> None:
    reader = LogReader(SAMPLE)
    q = read_quality(reader)
    counted: Counter[tuple[str, str]] = Counter()
    for m in reader.messages([topics.DIAGNOSTICS]):
        counted[(m.data["source"], m.data["kind"])] += max(int(m.data.get("count", 1)), 1)
    assert q.by_kind == dict(counted) and q.any
    invalid = sum(not m.data["valid"] for m in reader.messages([topics.NAV_POSE]))
    assert q.nav_no_position == invalid > 0
    assert q.dropped_frames > 0 and sum(q.corrupt_frames.values()) > 0


def test_json_document_carries_the_figures_and_they_can_be_bounded(tmp_path: Path) -> None:
    from lgvtool.evaluate.document import build_document
    from lgvtool.evaluate.regress import check_bounds

    log = tmp_path / "faults.mcap"
    _write_log(log, faults=True)
    doc = build_document([_evaluated(log)])
    dq = doc["data_quality"]
    assert isinstance(dq, dict)
    assert dq["dropped_frames"] == 23 and dq["corrupt_frames"] == 3
    assert dq["nav_no_position"] == 3 and dq["nav_replies"] == 130
    assert as_number(dq["gaps"]) >= 1 and dq["longest_gap_s"] == pytest.approx(2.1, abs=1e-6)
    assert {"source": "nav200", "kind": "unanswered", "count": 4} in as_list(dq["by_kind"])
    assert check_bounds(doc, [("data_quality.nav_no_position", 5.0)]) == []
    (fail,) = check_bounds(doc, [("data_quality.dropped_frames", 0.0)])
    assert "dropped_frames" in fail
    res = _evaluated(tmp_path / "not-there.mcap")
    assert build_document([res])["data_quality"] is None


def test_evaluating_a_raw_log_reads_its_chunks_once(chunk_passes: list[list[str]]) -> None:
    """The estimators' reading of a raw log also gives the evaluation its ground truth, its
    steering and its data quality: one pass over the chunks, and the same figures as reading
    each of them on its own."""
    from lgvtool.app import evaluate_job

    result = evaluate_job.evaluate_log(SAMPLE, estimators=["laser"])
    assert len(chunk_passes) == 1
    assert topics.TRUTH in chunk_passes[0] and topics.DIAGNOSTICS in chunk_passes[0]
    _same_as_read_alone(result, LogReader(SAMPLE))


def _same_as_read_alone(result, reader: LogReader) -> None:
    """The truth, steering angle and data quality of an evaluation are those of the log's
    topics read one at a time, each in log-time order."""
    from lgvtool.evaluate.reference import steering_from_frames

    assert result.quality == read_quality(reader, result.t0) and result.quality.any
    truth = reader.messages([topics.TRUTH])
    want = np.array([[m.log_time_ns * 1e-9, m.data["pose"]["position"]["x"],
                      m.data["pose"]["position"]["y"]] for m in truth])
    assert result.truth is not None and len(want) > 100
    got = result.truth
    np.testing.assert_allclose(np.column_stack([got.t, got.x, got.y]), want, rtol=0,
                               atol=1e-12)
    assert result.reference.steering_angle == steering_from_frames(
        reader.dataframe(topics.MCU_FRAME))


def test_evaluating_a_replayed_log_reads_its_chunks_once(tmp_path: Path,
                                                          chunk_passes: list[list[str]]) -> None:
    """A log written by ``replay`` holds every topic in every chunk: its estimates, truth,
    steering and data quality are read in one pass (not one per topic), with the same tables
    as each topic read on its own."""
    from lgvtool.app import evaluate_job
    from lgvtool.app.replay_job import ReplayOptions, replay_log
    from lgvtool.log.frames import to_dataframe
    from lgvtool.trajectory import Trajectory

    out = tmp_path / "replayed.mcap"
    replay_log(ReplayOptions(str(SAMPLE), str(out), estimators=("laser", "deadreckoning"),
                             show_progress=False))
    chunk_passes.clear()
    result = evaluate_job.evaluate_log(out)
    assert len(chunk_passes) == 1, chunk_passes
    assert {topics.estimate_pose("laser"), topics.estimate_pose("deadreckoning"), topics.TRUTH,
            topics.MCU_FRAME, topics.DIAGNOSTICS} <= set(chunk_passes[0])
    assert result.source == "log"
    reader = LogReader(out)
    _same_as_read_alone(result, reader)
    for name in ("laser", "deadreckoning"):
        alone = to_dataframe("foxglove.PoseInFrame",
                             reader.messages([topics.estimate_pose(name)]))
        want = Trajectory.from_frame(alone, name=name)
        assert len(want) > 100
        got = result.estimators[name].trajectory
        for col in ("t", "x", "y", "heading"):
            np.testing.assert_array_equal(getattr(got, col), getattr(want, col))


def test_diagnostics_that_are_not_objects_leave_the_quality_out(tmp_path: Path) -> None:
    """A /diagnostics message that is JSON but not an object gives no data quality (the
    report leaves its section out), not a traceback."""
    from simlogs import write_topic_log

    from lgvtool.evaluate.quality import quality_of_log

    log = write_topic_log(tmp_path / "diag.mcap", topics.DIAGNOSTICS, "lgvtool.Diagnostic",
                          [b"[1, 2]"])
    with pytest.warns(Warning):
        assert LogReader(log).has_topic(topics.DIAGNOSTICS)
    assert quality_of_log(str(log)) is None
