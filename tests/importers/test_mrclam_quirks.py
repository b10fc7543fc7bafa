"""Cleaning and quirk detection: every planted quirk found once, real quirks found where the
dataset has them."""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.importers.mrclam import MrclamDataset
from lgvtool.importers.mrclam_quirks import ImportSettings, prepare_run
from lgvtool.timestamps import seconds_to_ns_array

NS = 1_000_000_000


def prepared(root: Path, robot: int = 1, settings: ImportSettings | None = None) -> Any:
    ds = MrclamDataset.open(root)
    return prepare_run(ds, ds.load_robot(robot), settings)


def test_seconds_to_ns_is_exact_to_the_microsecond() -> None:
    t = np.array([1248444187.156, 1248444946.976, 1248445075.103, 1248444175.000001])
    assert seconds_to_ns_array(t, 1000).tolist() == [1248444187156000000, 1248444946976000000,
                                         1248445075103000000, 1248444175000001000]


def test_every_planted_quirk_is_counted(synthetic: Any) -> None:
    run = prepared(synthetic.root)
    for key, value in synthetic.expected.items():
        assert run.counts[key] == value, key
    assert {q.kind for q in run.quirks} == synthetic.kinds
    assert len(run.quirks) == len(synthetic.kinds)  # one per kind
    times = [q.time_ns for q in run.quirks]
    assert times == sorted(times)
    by = {q.kind: q for q in run.quirks}
    assert by["robot_sighting"].level == 2 and by["robot_sighting"].count == 2
    assert by["repeated_stamp"].details["rows"] == {"odometry": {"identical": 1, "differing": 1}}
    assert by["broken_rows"].details["rows"] == {"Robot1_Odometry.dat": 2}
    assert by["unknown_barcode"].details["by_barcode"] == {"99": 1}
    assert by["odometry_gap"].details["max_gap_s"] == pytest.approx(1.05)
    assert by["truth_ends_early"].details["uncovered_s"] == pytest.approx(2.0)
    assert by["range_outlier"].time_ns == round((synthetic.t0 + 4.0) * 1e3) * 1_000_000
    assert by["bearing_outlier"].details["landmarks"] == [7]


def test_cleaned_streams_are_in_time_order_and_keep_the_last_repeat(synthetic: Any) -> None:
    run = prepared(synthetic.root)
    for df in (run.odometry, run.truth):
        assert (np.diff(df["t_ns"].to_numpy()) > 0).all()
    assert (np.diff(run.observations["t_ns"].to_numpy()) >= 0).all()
    t20 = round((synthetic.t0 + 0.5 + 0.05 * 20) * 1e3) * 1_000_000
    assert run.odometry.loc[run.odometry["t_ns"] == t20, "v"].tolist() == [0.2]
    obs = run.observations
    assert set(obs["landmark"]) <= set(synthetic.landmarks)
    assert obs["range_outlier"].sum() == 1 and obs["bearing_outlier"].sum() == 1
    assert (obs["range"] > 0).all()
    assert run.start_ns == round(synthetic.t0 * 1e3) * 1_000_000
    assert run.end_ns == round((synthetic.t0 + 12.0) * 1e3) * 1_000_000


def test_camera_geometry_and_area(synthetic: Any) -> None:
    run = prepared(synthetic.root)
    b = run.observations["bearing"]
    cam = run.camera
    assert (cam["x_m"], cam["y_m"]) == (0.0, 0.0)
    assert cam["bearing_min_rad"] == pytest.approx(b.min())
    assert cam["fov_rad"] == pytest.approx(b.max() - b.min())
    assert cam["half_fov_rad"] == pytest.approx(b.abs().max())
    assert cam["range_min_m"] == pytest.approx(run.observations["range"].min())
    m = run.settings.area_margin_m
    assert (run.area.x_min, run.area.x_max) == (pytest.approx(0.0 - m), pytest.approx(5.0 + m))
    assert (run.area.y_min, run.area.y_max) == (pytest.approx(-1.5 - m), pytest.approx(3.0 + m))


def test_settings_change_what_counts_as_a_quirk(synthetic: Any) -> None:
    loose = replace(ImportSettings(), gap_threshold_s=2.0, truth_tolerance_s=5.0,
                    outlier_range_fraction=1.5, outlier_bearing_rad=2.0)
    run = prepared(synthetic.root, settings=loose)
    kinds = {q.kind for q in run.quirks}
    assert not kinds & {"odometry_gap", "truth_ends_early", "range_outlier", "bearing_outlier"}
    assert run.counts["odometry_gaps"] == 0


def _oracle(root: Path, robot: int) -> dict[str, int]:
    """Counts computed with plain Python from the excerpt's text."""

    def rows(name: str) -> list[list[str]]:
        return [ln.split() for ln in (root / name).read_text().splitlines()
                if ln.strip() and not ln.lstrip().startswith("#")]

    subject = {int(b): int(s) for s, b in rows("Barcodes.dat")}
    odo = rows(f"Robot{robot}_Odometry.dat")
    meas = rows(f"Robot{robot}_Measurement.dat")
    kinds: Counter[str] = Counter()
    stamps = set()
    for t, code, _r, _b in meas:
        s = subject.get(int(code), 0)
        kind = "robot" if 1 <= s <= 5 else "landmark" if 6 <= s <= 20 else "unknown"
        kinds[kind] += 1
        if kind == "landmark":
            stamps.add(t)
    return {"odometry_rows": len(odo), "odometry": len({r[0] for r in odo}),
            "measurement_rows": len(meas), "landmark_observations": kinds["landmark"],
            "robot_sightings": kinds["robot"], "unknown_barcodes": kinds["unknown"],
            "scans": len(stamps), "truth": len(rows(f"Robot{robot}_Groundtruth.dat"))}


@pytest.mark.mrclam
def test_excerpt_counts_match_the_text(excerpt: Callable[..., Path]) -> None:
    root = excerpt(4, odometry=3000, measurement=300, truth=2000)
    run = prepared(root, robot=4)
    oracle = _oracle(root, 4)
    for key, value in oracle.items():
        assert run.counts[key] == value, key
    kinds = {q.kind for q in run.quirks}
    # the first 3000 odometry rows of Robot4 hold a repeated stamp and gaps; the first 300
    # measurements sightings of robots and of barcode 50; its truth excerpt ends early
    assert {"repeated_stamp", "odometry_gap", "robot_sighting", "unknown_barcode",
            "truth_ends_early"} <= kinds
    assert run.counts["repeated_stamps"] == oracle["odometry_rows"] - oracle["odometry"]


@pytest.mark.mrclam
def test_robot1_ground_truth_ends_early(mrclam_data: Path) -> None:
    run = prepared(mrclam_data, robot=1)
    by = {q.kind: q for q in run.quirks}
    assert by["truth_ends_early"].details["uncovered_s"] == pytest.approx(128.1, abs=0.2)
    assert run.counts["robot_sightings"] == 407
    assert by["unknown_barcode"].details["by_barcode"] == {"43": 1}
    assert run.counts["odometry"] == run.counts["odometry_rows"] == 61785
    assert by["odometry_gap"].details["max_gap_s"] < 1.5
    assert 0.9 < run.camera["fov_rad"] < 1.2
