"""The odometry delay: measured from the camera alone (no ground truth) and applied to the
odometry stamps by the import.

Dataset: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
cooperative localization and mapping dataset", IJRR 30(8):969-974, 2011.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.importers.mrclam import MrclamDataset
from lgvtool.importers.mrclam_log import import_robot
from lgvtool.importers.mrclam_quirks import ImportSettings, prepare_run
from lgvtool.importers.mrclam_timing import delay_ns, odometry_delay
from lgvtool.log import LogReader, topics

LANDMARKS = {6: (6.0, 1.0), 7: (6.0, -1.0), 8: (-6.0, 0.5), 9: (0.5, 6.0), 10: (-0.5, -6.0)}


def delayed_drive(delay_s: float, seconds: float = 300.0, seed: int = 1
                  ) -> tuple[np.ndarray, ...]:
    """Commands at 50 Hz (a slowly varying yaw rate, 0.08 m/s), a robot that follows each
    command ``delay_s`` s after its stamp, and camera sightings (4 Hz, 3 mrad bearing noise) of
    the landmarks within +-0.6 rad from where the robot really is."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, seconds, 0.02)
    omega = 0.4 * np.sin(0.3 * t) * np.sign(np.sin(0.05 * t))
    v = np.full(len(t), 0.08)
    # the true pose: the commands shifted by the delay, integrated on a fine grid
    fine = np.arange(0.0, seconds, 0.002)
    k = np.clip(np.searchsorted(t, fine - delay_s, side="right") - 1, 0, len(t) - 1)
    w_true = np.where(fine - delay_s >= 0, omega[k], 0.0)
    v_true = np.where(fine - delay_s >= 0, v[k], 0.0)
    th = np.concatenate([[0.0], np.cumsum(w_true[:-1] * 0.002)])
    x = np.concatenate([[0.0], np.cumsum(v_true[:-1] * np.cos(th[:-1]) * 0.002)])
    y = np.concatenate([[0.0], np.cumsum(v_true[:-1] * np.sin(th[:-1]) * 0.002)])
    obs_t, ids, ranges, bearings = [], [], [], []
    for tc in np.arange(1.0, seconds - 1.0, 0.25):
        i = round(tc / 0.002)
        for lid, (lx, ly) in LANDMARKS.items():
            b = math.remainder(math.atan2(ly - y[i], lx - x[i]) - th[i], 2 * math.pi)
            if abs(b) < 0.6:
                obs_t.append(tc)
                ids.append(lid)
                ranges.append(math.hypot(lx - x[i], ly - y[i]))
                bearings.append(b + 0.003 * rng.standard_normal())
    return (t, v, omega, np.array(obs_t), np.array(ids), np.array(ranges), np.array(bearings))


@pytest.mark.parametrize("delay", [0.0, 0.12, 0.25])
def test_the_delay_is_measured_from_the_camera(delay: float) -> None:
    est = odometry_delay(*delayed_drive(delay))
    assert est.pairs > 500
    assert isinstance(est.delay_s, float)
    assert est.delay_s == pytest.approx(delay, abs=0.015)
    assert est.rms_rad is not None and est.rms_at_zero_rad is not None
    assert est.rms_rad <= est.rms_at_zero_rad
    if delay > 0.0:
        assert est.rms_rad < 0.9 * est.rms_at_zero_rad


def test_too_few_sightings_measure_nothing() -> None:
    t, v, omega, obs_t, ids, ranges, bearings = delayed_drive(0.2, seconds=20.0)
    est = odometry_delay(t, v, omega, obs_t, ids, ranges, bearings)
    assert 0 < est.pairs < 100
    assert est.delay_s == 0.0 and est.rms_rad is None and est.rms_at_zero_rad is not None
    none = odometry_delay(t, v, omega, obs_t[:1], ids[:1], ranges[:1], bearings[:1])
    assert (none.delay_s, none.pairs, none.rms_rad, none.rms_at_zero_rad) == (0.0, 0, None, None)


def test_delay_ns_rounds_to_the_microsecond() -> None:
    assert delay_ns(0.2164) == 216_400_000
    assert delay_ns(0.12345678) == 123_457_000
    assert delay_ns(0.0) == 0


def test_a_given_delay_moves_the_odometry(synthetic: Any, tmp_path: Path) -> None:
    auto = tmp_path / "auto.mcap"
    given = tmp_path / "given.mcap"
    import_robot(synthetic.root, 1, auto)
    summary = import_robot(synthetic.root, 1, given,
                           settings=ImportSettings(odometry_delay_s=0.25))
    # the synthetic run has too few landmark sightings to measure a delay: none is applied
    rec = LogReader(auto).metadata["importer"]
    assert rec["timing"]["method"] == "measured from the camera"
    assert rec["timing"]["odometry_delay_s"] == 0.0 and rec["timing"]["measured_delay_s"] is None
    assert rec["settings"]["odometry_delay_s"] is None
    a = LogReader(auto).dataframe(topics.ODOM)
    g = LogReader(given).dataframe(topics.ODOM)
    assert g["t"].iloc[0] == pytest.approx(synthetic.t0 + 0.5 + 0.25, abs=1e-6)
    np.testing.assert_allclose(g["t"] - a["t"], 0.25, atol=1e-6)
    assert g["v"].tolist() == a["v"].tolist()
    assert summary.timing["odometry_delay_s"] == 0.25 and summary.timing["method"] == "given"
    assert "odometry written 0.250 s after its stamps (given; too few" in summary.format_text()
    rec = LogReader(given).metadata["importer"]
    assert rec["timing"]["odometry_delay_s"] == 0.25
    assert rec["settings"]["odometry_delay_s"] == 0.25
    # ground truth and camera keep the file's stamps
    assert LogReader(given).dataframe(topics.TRUTH)["t"].tolist() == \
        LogReader(auto).dataframe(topics.TRUTH)["t"].tolist()
    assert LogReader(given).dataframe(topics.NAV_REFLECTORS)["t"].tolist() == \
        LogReader(auto).dataframe(topics.NAV_REFLECTORS)["t"].tolist()


@pytest.mark.mrclam
def test_the_robots_of_dataset_6_carry_out_commands_about_0_2_s_late(mrclam_data: Path) -> None:
    ds = MrclamDataset.open(mrclam_data)
    for robot in (1, 3):
        rec = ds.load_robot(robot)
        run = prepare_run(ds, rec)
        tm = run.timing
        assert 0.15 <= tm["measured_delay_s"] <= 0.3, robot
        assert tm["odometry_delay_s"] == tm["measured_delay_s"]
        assert tm["bearing_rms_with_delay_rad"] < 0.8 * tm["bearing_rms_without_delay_rad"]
        assert tm["pairs"] > 500
        first = round(float(rec.odometry["t"].min()) * 1e6) * 1000
        assert int(run.odometry["t_ns"].iloc[0]) == first + delay_ns(tm["odometry_delay_s"])
        # nothing of this came from the ground truth: the same run without it measures alike
        blind = prepare_run(ds, type(rec)(**{**rec.__dict__,
                                             "truth": rec.truth.iloc[:0]}))
        assert blind.timing == tm
