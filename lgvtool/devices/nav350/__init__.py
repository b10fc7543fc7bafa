"""The SICK NAV350 (SOPAS CoLa-B/CoLa-A over TCP) as one device family.

- codec (pure): :mod:`~lgvtool.devices.nav350.nav350_cola`, ``nav350_telegrams``,
  ``nav350_stream``;
- host session (pure, time passed in): ``nav350_session`` with ``nav350_clock`` (device clock);
- device model (shared by the simulator and the emulator): ``nav350_device``;
- log: ``nav350_logdecode``; recorder: ``nav350_worker``;
- :mod:`~lgvtool.devices.nav350.nav350_registration`: topics, decoders, record options
  (declared), recorder settings and worker.

Its simulator link (``sim/nav350_simlink.py``), the virtual NAV350 of ``simulate
serve`` and the recorder-against-emulator loopback (``sim/emulate/nav350/``) are the
simulator's, which sits above the device families.
"""
