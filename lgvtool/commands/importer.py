"""``lgvtool import``: datasets into the log format, one subcommand per dataset."""

from __future__ import annotations

import click

from lgvtool.options import Number, compression_option, force_option, progress_option


@click.group(name="import")
def import_() -> None:
    """Import a dataset into the log format (one subcommand per dataset; see docs/mrclam.md)."""


@import_.command(short_help="UTIAS MRCLAM: one robot (--robot N) or all (--all) into logs.")
@click.argument("dataset_dir", metavar="DIR", type=click.Path(path_type=str))
@click.option("--robot", "-r", type=Number(int, 1, 1000), default=None,
              help="Robot number to import (1-5 in the published datasets).")
@click.option("--all", "all_robots", is_flag=True,
              help="Import every robot; -o is then a folder that receives robot1.mcap ...")
@click.option("-o", "--output", required=True, type=click.Path(path_type=str),
              metavar="FILE|DIR", help="Output .mcap file (with --robot) or folder (with --all).")
@click.option("--json", "as_json", is_flag=True,
              help="Print the summary as JSON (one object; a list with --all).")
@click.option("--gap-threshold", type=Number(float, 0.0, 1e6, min_open=True), default=0.5, show_default=True,
              help="Steps between odometry or ground-truth stamps longer than this are "
                   "reported as gaps, s.")
@click.option("--landmark-radius", type=Number(float, 0.0, 1e3), default=0.05, show_default=True,
              help="Radius given to every landmark in the map, m.")
@click.option("--area-margin", type=Number(float, 0.0, 1e6), default=1.5, show_default=True,
              help="Margin around the landmarks' bounding box that forms the work area, m.")
@click.option("--odometry-delay", default="auto", show_default=True, metavar="S|auto",
              help="Write the odometry this many s after its stamps (the robots carry out a "
                   "command about 0.2 s late); auto measures the delay per robot from the "
                   "camera data, 0 keeps the file's stamps.")
@compression_option()
@force_option
@progress_option("Progress on stderr once the import takes over a second.")
def mrclam(dataset_dir: str, robot: int | None, all_robots: bool, output: str, as_json: bool,
           gap_threshold: float, landmark_radius: float, area_margin: float,
           odometry_delay: str, compression: str, force: bool, show_progress: bool = True) -> None:
    """Import the UTIAS MRCLAM dataset in DIR (e.g. MRCLAM_Dataset6) into a log.

    Writes odometry (commanded v m/s, omega rad/s) to /odom/twist, each measurement time's
    landmark sightings (range m, bearing rad, id = landmark subject number) as one scan on
    /nav/reflectors, the surveyed landmark map to /map/reflectors, the Vicon ground truth to
    /truth/pose and one /diagnostics event per quirk kind (repeated stamps, gaps, ground truth
    ending early, dropped robot sightings and unknown barcodes, flagged outliers). Log times are
    the dataset's Unix stamps. Prints a short summary of counts and quirks.

    Cite: K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, "The UTIAS multi-robot
    cooperative localization and mapping dataset", IJRR 30(8):969-974, 2011.
    """
    import json

    from lgvtool.app.import_job import MrclamImportOptions, import_mrclam
    from lgvtool.app.option_values import parse_odometry_delay

    summaries = import_mrclam(MrclamImportOptions(
        dataset_dir, output, robot=robot, all_robots=all_robots, gap_threshold=gap_threshold,
        landmark_radius=landmark_radius, area_margin=area_margin,
        odometry_delay=parse_odometry_delay(odometry_delay), compression=compression,
        force=force, show_progress=show_progress))
    if robot is not None:
        (summary,) = summaries
        click.echo(json.dumps(summary.to_dict(), indent=2) if as_json else summary.format_text())
    elif as_json:
        click.echo(json.dumps([s.to_dict() for s in summaries], indent=2))
    else:
        click.echo("\n".join(s.format_text() for s in summaries))


@import_.command(short_help="A ROS 2 bag (rosbag2 MCAP or SQLite) into a log.")
@click.argument("bag", type=click.Path(path_type=str))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False, path_type=str),
              help="Output .mcap log.")
@click.option("--topic", "topic_options", multiple=True, metavar="ROLE=/name",
              help="Topic of a role instead of the automatic choice (repeatable): odom, gyro, "
                   "nav, reflectors, truth, tf; ROLE=none leaves a role out.")
@click.option("--config", "config_path", type=click.Path(dir_okay=False, path_type=str),
              help="Vehicle geometry and reflector map (TOML) stored in the log.")
@click.option("--sensor-frame", default=None, metavar="FRAME",
              help="Frame of the navigation sensor in /tf (default: the frame of a head pose, "
                   "else the NAV350 messages' frame, else nav); the transform from the vehicle "
                   "frame gives the mounting.")
@click.option("--nav-frame", default=None, metavar="FRAME",
              help="Frame whose pose a generic NAV pose topic gives (default: the messages' "
                   "child frame, else their frame_id if it is the vehicle's or a sensor frame "
                   "in /tf, else base_link as REP 105 has it). A vehicle frame's pose is "
                   "converted to the head with the mounting; a sensor frame's is the head's.")
@click.option("--circle-from", default="auto", show_default=True,
              metavar="auto|truth|none|/TOPIC|ESTIMATOR",
              help="What evaluate fits the reference circle to (the bag has no steering "
                   "angle): auto = the --config steering angle, else the ground truth; a pose "
                   "/TOPIC of the bag (fitted now); an ESTIMATOR (fitted by evaluate, not "
                   "scored against it); none. Never the NAV pose being scored.")
@compression_option()
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
def ros2(bag: str, output: str, topic_options: tuple[str, ...], config_path: str | None,
         sensor_frame: str | None, nav_frame: str | None, circle_from: str, compression: str,
         force: bool, as_json: bool) -> None:
    """Import the rosbag2 BAG (a bag folder, or one .mcap or .db3 file) into a log.

    Odometry (nav_msgs/Odometry, geometry_msgs/TwistStamped) and the gyro (sensor_msgs/Imu)
    go to /odom/twist, the NAV pose to /nav/pose as the head's pose, NAV350 reflectors
    (sick_scan_xd/NAVLandmarkData) to /nav/reflectors, a ground-truth pose of O to
    /truth/pose; /tf gives the sensor mounting. sick_scan_xd/NAVPoseData is the head's pose; a
    generic pose (geometry_msgs PoseStamped, PoseWithCovarianceStamped) is by default the
    vehicle's (REP 105: base_link in map) and is converted to the head with the mounting. The
    summary says whose pose it took, where the mounting and the reference circle come from.
    Topics are chosen by type (docs/interop.md). The imported log replays and evaluates like
    any lgvtool log.
    """
    import json

    from lgvtool.app.import_job import Ros2ImportOptions, import_ros2
    from lgvtool.app.option_values import parse_topics

    summary = import_ros2(Ros2ImportOptions(
        bag, output, topics=parse_topics(topic_options), config_path=config_path,
        sensor_frame=sensor_frame, nav_frame=nav_frame, circle_from=circle_from,
        compression=compression, force=force))
    click.echo(json.dumps(summary.to_dict(), indent=2) if as_json else summary.format_text())
