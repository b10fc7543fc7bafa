"""Importing datasets into the log format (``lgvtool import``): UTIAS MRCLAM and ROS 2 bags."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.importers.mrclam_log import ImportSummary
    from lgvtool.interop.ros2_import import Ros2ImportSummary


def import_mrclam(dataset_dir: str, output: str, *, robot: int | None = None,
                  all_robots: bool = False, gap_threshold: float = 0.5,
                  landmark_radius: float = 0.05, area_margin: float = 1.5,
                  odometry_delay: str | float | None = "auto", compression: str = "zstd",
                  force: bool = False, show_progress: bool = True) -> list[ImportSummary]:
    """Import robot ``robot`` (``output``: an .mcap file), or with ``all_robots`` every robot
    (``output``: a folder receiving robotN.mcap), of the UTIAS MRCLAM dataset in
    ``dataset_dir``. ``gap_threshold`` (s): steps between stamps longer than this are
    reported as gaps; ``landmark_radius`` (m) of every landmark in the map; ``area_margin``
    (m) around the landmarks' bounding box forms the work area; ``odometry_delay``: the
    odometry is written this many s (0 to 5) after its stamps, ``"auto"`` or None measures it
    per robot. Returns one summary per robot imported (counts and quirks).

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

    if (robot is None) == (not all_robots):
        raise InputError("lgvtool import mrclam: give exactly one of --robot N and --all")
    if not gap_threshold > 0:
        raise InputError(f"--gap-threshold must be positive, got {gap_threshold}")
    if not landmark_radius >= 0:
        raise InputError(f"--landmark-radius must not be negative, got {landmark_radius}")
    if not area_margin >= 0:
        raise InputError(f"--area-margin must not be negative, got {area_margin}")
    inputs: list[str | Path] = [dataset_dir, *(Path(dataset_dir).glob("*.dat")
                                                if Path(dataset_dir).is_dir() else [])]
    if robot is not None:
        guard_output(output, inputs, force=force)
    else:
        guard_directory(output, [f"robot{r}.mcap" for r in ROBOT_SUBJECTS], inputs, force=force)
    delay = _delay(odometry_delay) if isinstance(odometry_delay, str) else odometry_delay
    settings = ImportSettings(gap_threshold_s=gap_threshold, landmark_radius_m=landmark_radius,
                              area_margin_m=area_margin, odometry_delay_s=delay)
    with Progress(0, "import", enabled=show_progress, delay_s=1.0) as bar:
        if robot is not None:
            return [import_robot(dataset_dir, robot, output, settings=settings,
                                 compression=compression, progress=bar)]
        return import_all(dataset_dir, output, settings=settings, compression=compression,
                          progress=bar)


def _delay(text: str) -> float | None:
    """``--odometry-delay``: None for auto, else seconds in [0, 5]."""
    from lgvtool.errors import InputError

    if text.strip().lower() == "auto":
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"--odometry-delay expects seconds or auto, got '{text}'") from None
    if not 0.0 <= value <= 5.0:
        raise InputError(f"--odometry-delay must be within 0 to 5 s, got '{text}'")
    return value


def import_ros2(bag: str, output: str, *, topic_options: Sequence[str] = (),
                config_path: str | None = None, sensor_frame: str | None = None,
                nav_frame: str | None = None, circle_from: str = "auto",
                compression: str = "zstd", force: bool = False) -> Ros2ImportSummary:
    """Import the rosbag2 ``bag`` (a bag folder, or one .mcap or .db3 file) into the log
    ``output`` (replaced atomically; an existing one only with ``force``). ``topic_options``
    are ``ROLE=/name`` choices (odom, gyro, nav, reflectors, truth, tf; ``ROLE=none`` leaves a
    role out), ``config_path`` the vehicle geometry and reflector map (TOML) stored in the
    log, ``sensor_frame`` the navigation sensor's frame in /tf, ``nav_frame`` the frame whose
    pose a generic NAV pose topic gives, ``circle_from`` what evaluate fits the reference
    circle to (auto, truth, none, a /topic or an estimator). Returns the import summary.

    :raises InputError: (exit 2) a bag that cannot be read, a bad topic choice, a refused
        output.
    """
    from lgvtool.interop.ros2_import import import_bag

    return import_bag(bag, output, topic_options=topic_options, config=config_path,
                      sensor_frame=sensor_frame, nav_frame=nav_frame, circle_from=circle_from,
                      compression=compression, force=force)
