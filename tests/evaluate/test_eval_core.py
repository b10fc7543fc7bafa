"""evaluate_trajectories: reference options and the bad-input paths."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from evaluate_synth import CENTRE, DELTA, T0, H, R, circle_drive

from lgvtool.errors import InputError
from lgvtool.evaluate.evaluation import evaluate_trajectories


def drives() -> dict[str, pd.DataFrame]:
    return {
        "laser": circle_drive(rotations=3.3, dt=0.45, bias=0.05, sd=0.02, seed=1),
        "pf": circle_drive(rotations=3.3, dt=0.1, sd=0.01, seed=2),
    }


def test_paper_like_drive_without_truth() -> None:
    res = evaluate_trajectories(drives(), steering_angle=DELTA, h=H, name="x")
    assert res.laps.complete == 3 and res.laps.partial == 1
    assert res.laps.source == "pf"                 # closest to its circle
    laser, pf = res.estimators["laser"], res.estimators["pf"]
    assert laser.average.mean == pytest.approx(0.05, abs=0.01)
    assert pf.average.rmse == pytest.approx(0.01, abs=0.002)
    assert pf.improvement == pytest.approx(100 * (1 - pf.average.rmse / laser.average.rmse))
    assert laser.circle.r == pytest.approx(R)
    assert laser.fitted.r == pytest.approx(R + 0.05, abs=0.01)   # fitted vs kinematic
    assert (laser.circle.cx, laser.circle.cy) == (pytest.approx(CENTRE[0], abs=0.01),
                                                  pytest.approx(CENTRE[1], abs=0.01))
    assert res.reference.steering_source == "config"
    assert not res.warnings


def test_shared_centre_and_free_radius() -> None:
    d = drives()
    d["pf"] = d["pf"].assign(x=d["pf"]["x"] + 0.02)            # a 20 mm offset estimator
    shared = evaluate_trajectories(d, steering_angle=DELTA, h=H, shared_centre=True)
    c1, c2 = shared.estimators["laser"].circle, shared.estimators["pf"].circle
    assert c1 == c2
    own = evaluate_trajectories(d, steering_angle=DELTA, h=H)
    assert own.estimators["pf"].average.rmse < shared.estimators["pf"].average.rmse
    free = evaluate_trajectories(d, steering_angle=DELTA, h=H, free_radius=True)
    assert free.estimators["laser"].circle.r == pytest.approx(R + 0.05, abs=0.01)
    assert free.estimators["laser"].average.mean == pytest.approx(0.0, abs=0.005)
    assert free.reference.kinematic_radius == pytest.approx(R)


def test_truth_drives_the_rotations_and_sits_beside_the_circle() -> None:
    d = drives()
    truth = circle_drive(rotations=3.3, dt=0.02)
    res = evaluate_trajectories(d, truth=truth, steering_angle=DELTA, h=H)
    assert res.laps.source == "truth"
    assert res.truth_path.rmse < 1e-9
    for ev in res.estimators.values():
        assert ev.truth.position_rmse == pytest.approx(ev.pooled.rmse, rel=0.05)
        assert all(r.truth_rmse is not None for r in ev.rotations)


def test_no_steering_with_truth_gives_truth_metrics_only() -> None:
    rng = np.random.default_rng(0)
    t = T0 + np.arange(0, 60, 0.1)
    walk = pd.DataFrame({"t": t, "x": np.cumsum(rng.normal(0, 0.05, t.size)),
                         "y": np.cumsum(rng.normal(0, 0.05, t.size)), "heading": 0.0 * t})
    est = walk.assign(x=walk["x"] + 0.03)
    res = evaluate_trajectories({"ekf": est}, truth=walk, steering_angle=None, h=H)
    assert not res.reference.circle_drive
    assert res.estimators["ekf"].average is None
    assert res.estimators["ekf"].truth.position_rmse == pytest.approx(0.03)
    assert any("no steering angle" in w for w in res.warnings)
    # With a configured angle the wandering drive is recognised as not a circle.
    res2 = evaluate_trajectories({"ekf": est}, truth=walk, steering_angle=DELTA, h=H)
    assert res2.estimators["ekf"].average is None
    assert any("does not follow a circle" in w for w in res2.warnings)
    with pytest.raises(InputError, match="no steering angle"):
        evaluate_trajectories({"ekf": est}, steering_angle=None, h=H)


def test_fewer_than_one_rotation_warns() -> None:
    d = {"pf": circle_drive(rotations=0.6), "laser": circle_drive(rotations=0.6, bias=0.05)}
    res = evaluate_trajectories(d, truth=circle_drive(rotations=0.6), steering_angle=DELTA, h=H)
    assert res.laps.complete == 0
    assert any("fewer than one full rotation" in w for w in res.warnings)
    assert res.estimators["pf"].average is None
    assert res.estimators["laser"].truth.position_rmse == pytest.approx(0.05, abs=1e-3)


def test_no_usable_trajectory() -> None:
    empty = pd.DataFrame({"t": [], "x": [], "y": [], "heading": []})
    with pytest.raises(InputError, match="no usable trajectory"):
        evaluate_trajectories({"pf": empty}, steering_angle=DELTA, h=H)
    with pytest.raises(InputError, match="lacks column"):
        evaluate_trajectories({"pf": pd.DataFrame({"t": [1.0]})}, steering_angle=DELTA, h=H)


def test_straight_drive_has_no_circle() -> None:
    d = drives()
    res = evaluate_trajectories(d, truth=circle_drive(), steering_angle=0.0, h=H)
    assert not res.reference.circle_drive
    assert math.isfinite(res.estimators["pf"].truth.position_rmse)


def test_steering_median_over_the_drive() -> None:
    from lgvtool.evaluate.reference import steering_from_frames

    frames = pd.DataFrame({"steering_angle": [0.0, 0.0, 1.04, 1.05, 1.06, 0.0],
                           "drive_speed": [0.0, 0.0, 0.36, 0.36, 0.36, 0.0]})
    assert steering_from_frames(frames) == pytest.approx(1.05)
    assert steering_from_frames(frames.assign(drive_speed=0.0)) == pytest.approx(0.52)  # all
    assert steering_from_frames(pd.DataFrame()) is None
    assert steering_from_frames(frames.drop(columns="drive_speed")) == pytest.approx(0.52)


def _steering_read(reader):
    """The steering columns as the evaluation reads them (in a pass over the chunks)."""
    from lgvtool.evaluate.log_inputs import EvaluationInputs

    read = EvaluationInputs(reader)
    reader.dataframes([], tap=read)
    return read.steering_columns()


def test_logged_steering_read_as_two_columns_is_the_frames_table_median() -> None:
    from lgvtool.circle import median_steering
    from lgvtool.evaluate.reference import steering_from_frames
    from lgvtool.log import LogReader, topics

    reader = LogReader(Path(__file__).resolve().parents[2] / "sample_logs" / "degraded.mcap")
    angle, speed = _steering_read(reader)
    frames = reader.dataframe(topics.MCU_FRAME)
    assert len(angle) == len(frames) > 100
    np.testing.assert_array_equal(angle, frames["steering_angle"].to_numpy(dtype=float))
    np.testing.assert_array_equal(speed, np.abs(frames["drive_speed"].to_numpy(dtype=float)))
    assert median_steering(angle, speed) == steering_from_frames(frames)
    assert median_steering(np.array([np.nan, 0.5]), None) == 0.5
    assert median_steering(np.array([np.nan]), np.array([1.0])) is None


def test_a_steering_angle_that_is_not_a_number_is_one_clear_error(tmp_path: Path) -> None:
    from simlogs import write_topic_log

    from lgvtool.errors import LogFormatError
    from lgvtool.log import LogReader, topics
    from lgvtool.log.reader import LogWarning

    log = write_topic_log(tmp_path / "steer.mcap", topics.MCU_FRAME, "lgvtool.McuFrame",
                          [b'{"steering_angle": %b, "drive_speed": 0.3}' % angle
                           for angle in (b"0.5", b'"left"')])
    with pytest.warns(LogWarning, match="no lgvtool metadata"):
        reader = LogReader(log)
    with pytest.raises(LogFormatError, match="/mcu/frame"):
        _steering_read(reader)


def test_truth_or_steering_that_do_not_match_their_schema_stop_the_evaluations_read() -> None:
    """Read with the estimators (:class:`EvaluationInputs`), a truth pose or an MCU frame
    that does not match its schema is one LogFormatError naming its topic and schema."""
    from lgvtool.errors import LogFormatError
    from lgvtool.evaluate.log_inputs import EvaluationInputs
    from lgvtool.log import LogReader, topics

    reader = LogReader(Path(__file__).resolve().parents[2] / "sample_logs" / "degraded.mcap")
    inputs = EvaluationInputs(reader)
    assert {topics.TRUTH, topics.MCU_FRAME, topics.DIAGNOSTICS} <= set(inputs.topics)
    ns = np.array([1_704_067_200_000_000_000], dtype=np.int64)
    with pytest.raises(LogFormatError, match=r"/truth/pose.*foxglove\.PoseInFrame"):
        inputs.add({topics.TRUTH: (ns, [b'{"pose": 3}'])})
    with pytest.raises(LogFormatError, match=r"/mcu/frame.*lgvtool\.McuFrame"):
        inputs.add({topics.MCU_FRAME: (ns, [b'{"steering_angle": "left"}'])})
    inputs.add({topics.DIAGNOSTICS: (ns, [b'[1, 2]'])})  # the quality is left out, no error
    assert inputs.quality(0.0) is None
