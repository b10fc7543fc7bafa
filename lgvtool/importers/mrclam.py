"""Parse the UTIAS MRCLAM dataset (multi-robot cooperative localization and mapping).

K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot cooperative
localization and mapping dataset", International Journal of Robotics Research 30(8):969-974,
2011.

A dataset folder holds ``Barcodes.dat`` (subject, barcode), ``Landmark_Groundtruth.dat``
(subject, x m, y m, sd_x m, sd_y m) and, per robot N, ``RobotN_Odometry.dat`` (t s, v m/s,
omega rad/s), ``RobotN_Measurement.dat`` (t s, barcode, range m, bearing rad) and
``RobotN_Groundtruth.dat`` (t s, x m, y m, theta rad). Subjects 1-5 are the robots, 6-20 the
landmarks. Times are Unix time in s.

This module only reads: every table comes back as a pandas DataFrame in file order with the
units of the file (SI), broken rows skipped and counted. Cleaning and quirk detection live in
:mod:`lgvtool.importers.mrclam_quirks`, the log conversion in :mod:`lgvtool.importers.mrclam_log`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from lgvtool.config import Reflector
from lgvtool.errors import InputError
from lgvtool.importers.textdata import TextTable, read_table

CITATION = (
    'K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot cooperative '
    'localization and mapping dataset", International Journal of Robotics Research '
    "30(8):969-974, 2011"
)
"""How to cite the dataset wherever results on it are shown."""

DATASET_URL = "http://asrl.utias.utoronto.ca/datasets/mrclam/"
"""Where the dataset is published."""

BARCODES_FILE = "Barcodes.dat"
LANDMARKS_FILE = "Landmark_Groundtruth.dat"
ROBOT_SUBJECTS = range(1, 6)
"""Subject numbers of the robots."""
LANDMARK_SUBJECTS = range(6, 21)
"""Subject numbers of the landmarks."""

ODOMETRY_COLUMNS = ("t", "v", "omega")
MEASUREMENT_COLUMNS = ("t", "barcode", "range", "bearing")
TRUTH_COLUMNS = ("t", "x", "y", "theta")
_ROBOT_FILE = re.compile(r"^Robot(\d+)_(Odometry|Measurement|Groundtruth)\.dat$")


def robot_files(robot: int) -> dict[str, str]:
    """File names of robot ``robot``'s odometry, measurement and ground-truth files."""
    return {
        "odometry": f"Robot{robot}_Odometry.dat",
        "measurement": f"Robot{robot}_Measurement.dat",
        "truth": f"Robot{robot}_Groundtruth.dat",
    }


@dataclass(frozen=True)
class FileInfo:
    """Provenance and parse outcome of one dataset file."""

    name: str
    """File name in the dataset folder."""
    sha256: str
    """SHA-256 of its bytes, hex."""
    size_bytes: int
    """Size, bytes."""
    rows: int
    """Rows kept."""
    broken_lines: tuple[int, ...]
    """1-based line numbers of the rows skipped as broken."""

    @property
    def broken(self) -> int:
        """Number of broken rows skipped."""
        return len(self.broken_lines)

    @classmethod
    def of(cls, table: TextTable) -> FileInfo:
        """The provenance of a parsed table."""
        return cls(table.name, table.sha256, table.size_bytes, len(table.frame),
                   table.broken_lines)


@dataclass(frozen=True)
class RobotRecording:
    """One robot's three files as read, in file order, units as in the files (SI)."""

    robot: int
    """Robot (subject) number, 1-5 in the published datasets."""
    odometry: pd.DataFrame
    """Columns t (s, Unix), v (m/s, commanded forward velocity), omega (rad/s, commanded)."""
    measurements: pd.DataFrame
    """Columns t (s), barcode (int), range (m), bearing (rad, counter-clockwise from ahead)."""
    truth: pd.DataFrame
    """Columns t (s), x (m), y (m), theta (rad): Vicon ground truth of the robot centre."""
    files: tuple[FileInfo, ...]
    """Odometry, measurement and ground-truth file, in that order."""


@dataclass(frozen=True)
class MrclamDataset:
    """An MRCLAM dataset folder: the shared tables, and which robots have files.

    Open it with :meth:`open`; read a robot with :meth:`load_robot`.
    """

    root: Path
    """The dataset folder."""
    barcodes: pd.DataFrame
    """Columns subject (int), barcode (int)."""
    landmarks: pd.DataFrame
    """Columns subject (int), x (m), y (m), sd_x (m), sd_y (m): surveyed landmark centres."""
    robots: tuple[int, ...]
    """Robot numbers that have at least one file in the folder, ascending."""
    files: tuple[FileInfo, ...]
    """The barcode and landmark files."""

    @property
    def number(self) -> int | None:
        """The dataset number from a folder named like ``MRCLAM_Dataset6``, else None."""
        m = re.search(r"Dataset(\d+)$", self.root.name)
        return int(m.group(1)) if m else None

    @property
    def name(self) -> str:
        """A human-readable name, e.g. 'UTIAS MRCLAM Dataset 6'."""
        n = self.number
        return "UTIAS MRCLAM" + (f" Dataset {n}" if n is not None else "")

    @classmethod
    def open(cls, root: str | Path) -> MrclamDataset:
        """Read the barcode and landmark tables of the dataset in ``root``.

        :raises InputError: ``root`` is not a folder, lacks the MRCLAM files, or its barcode or
            landmark table is unusable.
        """
        path = Path(root)
        if not path.exists():
            raise InputError(f"{path}: no such folder")
        if not path.is_dir():
            raise InputError(f"{path}: not a folder (expected an MRCLAM dataset folder)")
        missing = [f for f in (BARCODES_FILE, LANDMARKS_FILE) if not (path / f).is_file()]
        robots = _robots_in(path)
        if missing or not robots:
            what = ", ".join(missing) if missing else "no RobotN_*.dat files"
            raise InputError(f"{path}: not an MRCLAM dataset (missing {what})")
        bar = read_table(path / BARCODES_FILE, ("subject", "barcode"),
                         integer=("subject", "barcode"), layout="subject, barcode")
        lm = read_table(path / LANDMARKS_FILE, ("subject", "x", "y", "sd_x", "sd_y"),
                        integer=("subject",), layout="subject, x [m], y [m], sd_x [m], sd_y [m]")
        _check_unique(bar, ("subject", "barcode"))
        _check_unique(lm, ("subject",))
        return cls(root=path, barcodes=bar.frame, landmarks=lm.frame, robots=robots,
                   files=(FileInfo.of(bar), FileInfo.of(lm)))

    def subject_of_barcode(self) -> dict[int, int]:
        """Barcode -> subject number."""
        return dict(zip(self.barcodes["barcode"].tolist(), self.barcodes["subject"].tolist(),
                        strict=True))

    def landmark_map(self, radius: float) -> tuple[Reflector, ...]:
        """The landmarks as reflectors: id = subject number, centre in m, ``radius`` in m."""
        lm = self.landmarks.sort_values("subject")
        return tuple(
            Reflector(id=int(s), x=float(x), y=float(y), radius=float(radius), layer=0)
            for s, x, y in zip(lm["subject"], lm["x"], lm["y"], strict=True)
        )

    def load_robot(self, robot: int) -> RobotRecording:
        """Read robot ``robot``'s odometry, measurement and ground-truth files.

        :raises InputError: no such robot in the folder, a file missing, or a file unusable.
        """
        if robot not in self.robots:
            have = ", ".join(str(r) for r in self.robots)
            raise InputError(f"robot {robot}: not in {self.root} (robots there: {have})")
        names = robot_files(robot)
        missing = [n for n in names.values() if not (self.root / n).is_file()]
        if missing:
            raise InputError(f"robot {robot}: missing {', '.join(missing)} in {self.root}")
        odo = read_table(self.root / names["odometry"], ODOMETRY_COLUMNS,
                         layout="t [s], v [m/s], omega [rad/s]")
        meas = read_table(self.root / names["measurement"], MEASUREMENT_COLUMNS,
                          integer=("barcode",),
                          layout="t [s], barcode, range [m], bearing [rad]")
        truth = read_table(self.root / names["truth"], TRUTH_COLUMNS,
                           layout="t [s], x [m], y [m], theta [rad]")
        return RobotRecording(
            robot=robot, odometry=odo.frame, measurements=meas.frame, truth=truth.frame,
            files=(FileInfo.of(odo), FileInfo.of(meas), FileInfo.of(truth)),
        )


def _robots_in(path: Path) -> tuple[int, ...]:
    found = set()
    for p in path.iterdir():
        m = _ROBOT_FILE.match(p.name)
        if m:
            found.add(int(m.group(1)))
    return tuple(sorted(found))


def _check_unique(table: TextTable, columns: tuple[str, ...]) -> None:
    for c in columns:
        dup = table.frame[c][table.frame[c].duplicated()]
        if len(dup):
            raise InputError(f"{table.name}: {c} {int(dup.iloc[0])} appears more than once")
