"""Devices on the vehicle: one folder per device family, and the pieces the families share.

A family folder (:mod:`~lgvtool.devices.mcu`, :mod:`~lgvtool.devices.nav200`,
:mod:`~lgvtool.devices.nav350`) holds the family's codec (pure), its host session (pure, time
passed in), its device model (shared by the simulator and the emulator), its recorder worker,
its log decoder and its registration (topics, decoders, declared ``record`` options, recorder
settings and worker: a :class:`~lgvtool.devices.device_registry.DeviceFamily`).
:mod:`~lgvtool.devices.device_registry` lists the families; ``lgvtool decode``, ``record``, the
recorder, the simulator's log writer and ``simulate serve`` find a family's parts through it.

The device families know neither the simulator nor the command line: their emulators,
simulator links and loopback are the simulator's (``sim/``, above this package), their click
options are made by ``lgvtool record`` from their declarations.

Shared by the families (the generic codec base is :mod:`lgvtool.wire`):

- :mod:`~lgvtool.devices.device_links`: ``serial://`` and ``tcp://`` URLs to :class:`Link` objects;
- :mod:`~lgvtool.devices.link_worker`: the recorder's per-link thread base (open, backoff, read)
  and the polled devices' request/read cycle;
- :mod:`~lgvtool.devices.log_decoding`: the one path from raw device bytes to log messages;
- :mod:`~lgvtool.devices.logsink`: the single writer thread, file splitting, disk-full handling;
- :mod:`~lgvtool.devices.recorder`: the recording loop behind ``lgvtool record``;
- :mod:`~lgvtool.devices.status`: the recorder's status line;
- :mod:`~lgvtool.devices.session_events`: the events every host session reports;
- :mod:`~lgvtool.devices.head_speed`: the head velocity a session sends as speed input.

This package re-exports nothing: every name has one import path, its module.
"""
