"""Importing datasets into the log format (``lgvtool import``): UTIAS MRCLAM and ROS 2 bags."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.importers.mrclam_log import ImportSummary
    from lgvtool.interop.ros2_import import Ros2ImportSummary


@dataclass(frozen=True, slots=True)
class MrclamImportOptions:
    """What :func:`import_mrclam` imports, and how (``lgvtool import mrclam``)."""

    dataset_dir: str
    """The UTIAS MRCLAM dataset folder (e.g. MRCLAM_Dataset6)."""
    output: str
    """With :attr:`robot`: the log (.mcap) to write; with :attr:`all_robots`: the folder that
    receives robotN.mcap."""
    robot: int | None = None
    """The robot to import (1-5 in the published datasets); None: with :attr:`all_robots`."""
    all_robots: bool = False
    """Import every robot (exactly one of this and :attr:`robot`)."""
    gap_threshold: float = 0.5
    """Steps between odometry or ground-truth stamps longer than this are reported as gaps, s
    (above 0)."""
    landmark_radius: float = 0.05
    """Radius given to every landmark in the map, m (at least 0)."""
    area_margin: float = 1.5
    """Margin around the landmarks' bounding box that forms the work area, m (at least 0)."""
    odometry_delay: float | None = None
    """The odometry is written this many s (0 to 5) after its stamps; None: measured per
    robot from the camera data."""
    compression: str = "zstd"
    """Chunk compression of the logs: zstd, lz4 or none."""
    force: bool = False
    """Replace existing output files."""
    show_progress: bool = True
    """Progress on stderr once the import takes over a second."""


def import_mrclam(options: MrclamImportOptions) -> list[ImportSummary]:
    """Import one robot, or every robot, of the UTIAS MRCLAM dataset in the ``options``'
    folder (see :class:`MrclamImportOptions`). Returns one summary per robot imported (counts
    and quirks).

    :raises InputError: (exit 2) not exactly one of ``robot`` and ``all_robots``, a bad
        setting, a dataset that cannot be read, or a refused output.
    """
    from pathlib import Path

    from lgvtool.errors import InputError
    from lgvtool.importers.mrclam import ROBOT_SUBJECTS
    from lgvtool.importers.mrclam_log import import_all, import_robot
    from lgvtool.importers.mrclam_quirks import ImportSettings
    from lgvtool.outdir import guard_directory
    from lgvtool.outputs import guard_output
    from lgvtool.progress import Progress

    o = options
    dataset_dir, output, robot = o.dataset_dir, o.output, o.robot
    if (robot is None) == (not o.all_robots):
        raise InputError("lgvtool import mrclam: give exactly one of --robot N and --all")
    if not o.gap_threshold > 0:
        raise InputError(f"--gap-threshold must be positive, got {o.gap_threshold}")
    if not o.landmark_radius >= 0:
        raise InputError(f"--landmark-radius must not be negative, got {o.landmark_radius}")
    if not o.area_margin >= 0:
        raise InputError(f"--area-margin must not be negative, got {o.area_margin}")
    inputs: list[str | Path] = [dataset_dir, *(Path(dataset_dir).glob("*.dat")
                                                if Path(dataset_dir).is_dir() else [])]
    if robot is not None:
        guard_output(output, inputs, force=o.force)
    else:
        guard_directory(output, [f"robot{r}.mcap" for r in ROBOT_SUBJECTS], inputs,
                        force=o.force)
    settings = ImportSettings(gap_threshold_s=o.gap_threshold,
                              landmark_radius_m=o.landmark_radius,
                              area_margin_m=o.area_margin, odometry_delay_s=o.odometry_delay)
    with Progress(0, "import", enabled=o.show_progress, delay_s=1.0) as bar:
        if robot is not None:
            return [import_robot(dataset_dir, robot, output, settings=settings,
                                 compression=o.compression, progress=bar)]
        return import_all(dataset_dir, output, settings=settings, compression=o.compression,
                          progress=bar)


@dataclass(frozen=True, slots=True)
class Ros2ImportOptions:
    """What :func:`import_ros2` imports, and how (``lgvtool import ros2``)."""

    bag: str
    """The rosbag2 bag: a bag folder, or one .mcap or .db3 file."""
    output: str
    """The log (.mcap) to write (replaced atomically; an existing one only with
    :attr:`force`)."""
    topics: Mapping[str, str] = field(default_factory=dict)
    """Topic of a role instead of the automatic choice: role (odom, gyro, nav, reflectors,
    truth, tf) -> topic name, or ``none`` to leave the role out."""
    config_path: str | None = None
    """Vehicle geometry and reflector map (TOML) stored in the log."""
    sensor_frame: str | None = None
    """Frame of the navigation sensor in /tf; None: found as ``import ros2 --help`` says."""
    nav_frame: str | None = None
    """Frame whose pose a generic NAV pose topic gives; None: as the messages say, else the
    vehicle frame (REP 105)."""
    circle_from: str = "auto"
    """What evaluate fits the reference circle to: auto, truth, none, a pose /topic of the
    bag or an estimator's name."""
    compression: str = "zstd"
    """Chunk compression of the log: zstd, lz4 or none."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def import_ros2(options: Ros2ImportOptions) -> Ros2ImportSummary:
    """Import the ``options``' rosbag2 bag into its log (see :class:`Ros2ImportOptions`).
    Returns the import summary.

    :raises InputError: (exit 2) a bag that cannot be read, a bad topic choice, a refused
        output.
    """
    from lgvtool.interop.ros2_import import import_bag

    o = options
    # import_bag takes the choices as --topic gives them (ROLE=/name), and reads them back
    return import_bag(o.bag, o.output,
                      topic_options=[f"{role}={name}" for role, name in o.topics.items()],
                      config=o.config_path, sensor_frame=o.sensor_frame,
                      nav_frame=o.nav_frame, circle_from=o.circle_from,
                      compression=o.compression, force=o.force)
