"""The pure MRCLAM parser: tables, units, robots, the landmark map, and bad input."""

from __future__ import annotations

import hashlib
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.errors import InputError
from lgvtool.importers.mrclam import (
    LANDMARK_SUBJECTS,
    ROBOT_SUBJECTS,
    MrclamDataset,
    robot_files,
)


def test_synthetic_dataset_tables(synthetic: Any) -> None:
    ds = MrclamDataset.open(synthetic.root)
    assert ds.robots == (1,)
    assert ds.number is None and ds.name == "UTIAS MRCLAM"
    assert ds.subject_of_barcode()[63] == 6
    refl = ds.landmark_map(0.05)
    assert [r.id for r in refl] == [6, 7, 8]
    assert (refl[0].x, refl[0].y, refl[0].radius) == (*synthetic.landmarks[6], 0.05)
    rec = ds.load_robot(1)
    assert list(rec.odometry.columns) == ["t", "v", "omega"]
    assert list(rec.measurements.columns) == ["t", "barcode", "range", "bearing"]
    assert list(rec.truth.columns) == ["t", "x", "y", "theta"]
    assert rec.measurements["barcode"].dtype == np.int64
    odo_file = rec.files[0]
    assert odo_file.name == "Robot1_Odometry.dat" and odo_file.broken == 2
    assert odo_file.rows == len(rec.odometry) == 213
    raw = (synthetic.root / "Robot1_Odometry.dat").read_bytes()
    assert odo_file.sha256 == hashlib.sha256(raw).hexdigest()


@pytest.mark.mrclam
def test_excerpt_rows_and_units(excerpt: Callable[..., Path]) -> None:
    root = excerpt(4, odometry=1500, measurement=200, truth=1000)
    ds = MrclamDataset.open(root)
    assert ds.number == 6 and ds.name == "UTIAS MRCLAM Dataset 6"
    assert ds.robots == (4,)
    assert sorted(ds.barcodes["subject"]) == [*ROBOT_SUBJECTS, *LANDMARK_SUBJECTS]
    assert sorted(ds.landmarks["subject"]) == list(LANDMARK_SUBJECTS)
    rec = ds.load_robot(4)
    assert (len(rec.odometry), len(rec.measurements), len(rec.truth)) == (1500, 200, 1000)
    assert all(f.broken == 0 for f in rec.files)
    # Unix seconds in 2009, velocities of a small robot, a camera looking ahead, a 15 m room
    for df in (rec.odometry, rec.measurements, rec.truth):
        assert df["t"].between(1.2484e9, 1.2485e9).all()
    assert rec.odometry["v"].abs().max() < 1.0 and rec.odometry["omega"].abs().max() < 3.0
    assert rec.measurements["range"].between(0.1, 15.0).all()
    assert rec.measurements["bearing"].abs().max() < np.pi / 2
    assert rec.truth["theta"].abs().max() <= np.pi + 1e-6
    lm = ds.landmarks
    assert lm["x"].between(-10, 10).all() and lm["sd_x"].max() < 0.01


def test_not_a_dataset(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("hello\n")
    with pytest.raises(InputError, match="not an MRCLAM dataset"):
        MrclamDataset.open(tmp_path)
    with pytest.raises(InputError, match="no such folder"):
        MrclamDataset.open(tmp_path / "absent")
    with pytest.raises(InputError, match="not a folder"):
        MrclamDataset.open(tmp_path / "notes.txt")


def test_tables_present_but_no_robot_files(synthetic: Any) -> None:
    for name in robot_files(1).values():
        (synthetic.root / name).unlink()
    with pytest.raises(InputError, match="no RobotN_"):
        MrclamDataset.open(synthetic.root)


def test_missing_robot_and_missing_file(synthetic: Any) -> None:
    ds = MrclamDataset.open(synthetic.root)
    with pytest.raises(InputError, match=r"robot 7: not in .* \(robots there: 1\)"):
        ds.load_robot(7)
    shutil.copyfile(synthetic.root / "Robot1_Odometry.dat", synthetic.root / "Robot2_Odometry.dat")
    ds = MrclamDataset.open(synthetic.root)
    with pytest.raises(InputError, match=r"robot 2: missing Robot2_Measurement\.dat, "
                                         r"Robot2_Groundtruth\.dat"):
        ds.load_robot(2)


def test_duplicate_barcode_is_refused(synthetic: Any) -> None:
    p = synthetic.root / "Barcodes.dat"
    p.write_text(p.read_text() + "9 63\n")
    with pytest.raises(InputError, match="barcode 63 appears more than once"):
        MrclamDataset.open(synthetic.root)


def test_file_of_garbage_is_refused(synthetic: Any) -> None:
    (synthetic.root / "Robot1_Groundtruth.dat").write_text("this is not\na dataset file\n")
    ds = MrclamDataset.open(synthetic.root)
    with pytest.raises(InputError, match=r"Robot1_Groundtruth\.dat: none of its 2 rows"):
        ds.load_robot(1)
