"""Trajectories and logs to and from other tools (docs/interop.md).

- :mod:`lgvtool.interop.trajfile`: TUM, KITTI, CSV and Parquet trajectory files (write; TUM and
  CSV also read);
- :mod:`lgvtool.interop.export`: ``lgvtool export``, every trajectory of a log into files;
- :mod:`lgvtool.interop.ros2_types`, :mod:`lgvtool.interop.ros2_roles`,
  :mod:`lgvtool.interop.ros2_import`: ``lgvtool import ros2``, rosbag2 bags into a log.
"""
