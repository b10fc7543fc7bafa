"""Fixtures of the importer tests: the real MRCLAM Dataset 6 (or a skip), excerpts of it cut into
tmp_path, and a small synthetic dataset with every quirk planted at a known place."""

from __future__ import annotations

import math
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HEADER = [
    "# UTIAS Multi-Robot Cooperative Localization and Mapping Dataset",
    "# synthetic test data",
    "# Data Format:",
    "# columns",
]


def mrclam_location() -> Path:
    """``$LGVTOOL_MRCLAM``, else ``<repo>/../shared/data/mrclam/MRCLAM_Dataset6``."""
    env = os.environ.get("LGVTOOL_MRCLAM")
    if env:
        return Path(env)
    return REPO.parent / "shared" / "data" / "mrclam" / "MRCLAM_Dataset6"


@pytest.fixture(scope="session")
def mrclam_data() -> Path:
    """The real dataset folder; the test is skipped when it is absent."""
    path = mrclam_location()
    if not (path / "Barcodes.dat").is_file() or not (path / "Robot1_Odometry.dat").is_file():
        pytest.skip(f"MRCLAM Dataset 6 not found at {path} (set LGVTOOL_MRCLAM to its folder)")
    return path


def copy_head(src: Path, dst: Path, rows: int | None) -> list[str]:
    """Copy the comment lines and the first ``rows`` data rows (all if None); the data rows."""
    lines = src.read_text().splitlines()
    comments = [ln for ln in lines if ln.lstrip().startswith("#")]
    data = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    kept = data if rows is None else data[:rows]
    dst.write_text("\n".join(comments + kept) + "\n")
    return kept


@pytest.fixture
def excerpt(mrclam_data: Path, tmp_path: Path) -> Callable[..., Path]:
    """``excerpt(robot, odometry=N, measurement=N, truth=N)`` -> a dataset folder in tmp_path
    holding the shared tables whole and the first rows of that robot's files."""

    def make(robot: int = 4, *, odometry: int = 3000, measurement: int = 300,
             truth: int = 2000) -> Path:
        out = tmp_path / "MRCLAM_Dataset6"
        out.mkdir(exist_ok=True)
        for name in ("Barcodes.dat", "Landmark_Groundtruth.dat"):
            shutil.copyfile(mrclam_data / name, out / name)
        for kind, rows in (("Odometry", odometry), ("Measurement", measurement),
                           ("Groundtruth", truth)):
            name = f"Robot{robot}_{kind}.dat"
            copy_head(mrclam_data / name, out / name, rows)
        return out

    return make


# ------------------------------------------------------------------ synthetic dataset

T0 = 1248444000.0
"""Start of the synthetic run, s (Unix)."""
LANDMARKS = {6: (5.0, 2.5), 7: (5.0, -1.5), 8: (0.0, 3.0)}
"""Synthetic landmark centres, m."""
BARCODES = {1: 5, 2: 14, 3: 41, 4: 32, 5: 23, 6: 63, 7: 81, 8: 7}
"""Synthetic subject -> barcode."""


def truth_at(t: float) -> tuple[float, float, float]:
    """Synthetic ground truth: 0.1 m/s along x from (1, 0.5), heading 0."""
    return 1.0 + 0.1 * (t - T0), 0.5, 0.0


def range_bearing(t: float, subject: int) -> tuple[float, float]:
    """Exact range (m) and bearing (rad) of a landmark from the synthetic robot at ``t``."""
    x, y, th = truth_at(t)
    lx, ly = LANDMARKS[subject]
    return math.hypot(lx - x, ly - y), math.atan2(ly - y, lx - x) - th


@dataclass(frozen=True)
class Synthetic:
    """A synthetic dataset folder and what the importer must find in it."""

    root: Path
    """The dataset folder (robot 1 only)."""
    expected: dict[str, int]
    """Counts the importer must report."""
    kinds: frozenset[str]
    """Quirk kinds the importer must report."""
    landmarks: dict[int, tuple[float, float]]
    """Landmark subject -> centre (x, y), m."""
    t0: float
    """First ground-truth stamp, s."""


def _write(path: Path, rows: list[str]) -> None:
    path.write_text("\n".join([*HEADER, *rows]) + "\n")


@pytest.fixture
def synthetic(tmp_path: Path) -> Synthetic:
    """Robot 1 of a tiny dataset with each quirk planted once (see the expected counts)."""
    root = tmp_path / "synthetic"
    root.mkdir()
    _write(root / "Barcodes.dat", [f"{s} {b}" for s, b in BARCODES.items()])
    _write(root / "Landmark_Groundtruth.dat",
           [f"{s} {x:.8f} {y:.8f} 0.0001 0.0001" for s, (x, y) in LANDMARKS.items()])
    # ground truth: 10 Hz over 10 s (ends 2 s before the odometry)
    truth = []
    for k in range(101):
        t = T0 + 0.1 * k
        x, y, th = truth_at(t)
        truth.append(f"{t:.3f} {x:.8f} {y:.8f} {th:.5f}")
    _write(root / "Robot1_Groundtruth.dat", truth)
    # odometry: 20 Hz from T0 + 0.5 to T0 + 12.0, one gap, repeats, a swap, two broken rows
    odo = []
    for k in range(231):
        if 100 <= k < 120:
            continue                                   # gap of 1.05 s
        t = T0 + 0.5 + 0.05 * k
        odo.append(f"{t:.3f} 0.100 0.000")
        if k == 10:
            odo.append(f"{t:.3f} 0.100 0.000")        # identical repeat
        if k == 20:
            odo.append(f"{t:.3f} 0.200 0.000")        # differing repeat (kept: last)
        if k == 40:
            odo += ["garbage here", "1248444002.550 0.1"]   # two broken rows
    i = next(i for i, r in enumerate(odo) if r.startswith(f"{T0 + 0.5 + 0.05 * 30:.3f}"))
    odo[i], odo[i + 1] = odo[i + 1], odo[i]           # one row out of order
    _write(root / "Robot1_Odometry.dat", odo)

    def meas(t_off: float, subject_or_barcode: int, *, barcode: bool = False,
             range_scale: float = 1.0, bearing_add: float = 0.0,
             rng: float | None = None) -> str:
        t = T0 + t_off
        if barcode:
            return f"{t:.3f} {subject_or_barcode} 3.000 0.100"
        r, b = range_bearing(t, subject_or_barcode)
        r = r * range_scale if rng is None else rng
        return f"{t:.3f} {BARCODES[subject_or_barcode]} {r:.3f} {b + bearing_add:.3f}"

    _write(root / "Robot1_Measurement.dat", [
        meas(1.0, 6), meas(1.0, 7),                          # scan with two landmarks
        meas(2.0, 8), meas(2.0, 14, barcode=True),           # landmark + robot 2
        meas(3.0, 41, barcode=True),                         # only robot 3: no scan
        meas(4.0, 99, barcode=True), meas(4.0, 6, range_scale=2.0),   # unknown + range outlier
        meas(5.0, 7, bearing_add=1.0),                       # bearing outlier
        meas(6.0, 8, rng=0.0), meas(6.0, 6),                 # invalid range + landmark
        meas(11.0, 6),                                       # after the ground truth ends
    ])
    expected = {
        "odometry": 211, "odometry_rows": 213, "broken_rows": 2, "repeated_stamps": 2,
        "out_of_order_rows": 1, "odometry_gaps": 1, "truth": 101, "truth_rows": 101,
        "truth_gaps": 0, "measurement_rows": 11, "landmark_observations": 7, "scans": 6,
        "robot_sightings": 2, "unknown_barcodes": 1, "invalid_ranges": 1,
        "stamps_without_landmarks": 1, "range_outliers": 1, "bearing_outliers": 1,
        "outliers_checked": 6, "outliers_unchecked": 1, "truth_outside_area": 0,
    }
    kinds = frozenset({
        "broken_rows", "out_of_order_rows", "repeated_stamp", "odometry_gap", "robot_sighting",
        "unknown_barcode", "invalid_range", "range_outlier", "bearing_outlier",
        "truth_ends_early",
    })
    return Synthetic(root, expected, kinds, dict(LANDMARKS), T0)
