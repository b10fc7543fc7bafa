"""Trajectories and logs to and from other tools (docs/interop.md).

- :mod:`lgvtool.interop.trajfile`: TUM, KITTI, CSV and Parquet trajectory files (write; TUM and
  CSV also read);
- :mod:`lgvtool.interop.trajectory_export`: ``lgvtool export``, every trajectory of a log into files;
- :mod:`lgvtool.interop.foreign_trajectories`: ``evaluate --trajectory``, trajectories made by other tools;
- :mod:`lgvtool.interop.ros2_types` (message types), :mod:`lgvtool.interop.ros2_messages`
  (the fields read of each, typed), :mod:`lgvtool.interop.ros2_roles` (which topic plays which
  role), :mod:`lgvtool.interop.ros2_bag` (reading a bag),
  :mod:`lgvtool.interop.ros2_import` (writing the log): ``lgvtool import ros2``.
"""
