"""The SICK NAV350 (SOPAS CoLa-B/CoLa-A over TCP) as one device family.

- codec (pure): :mod:`~lgvtool.devices.nav350.nav350_cola`, ``nav350_telegrams``,
  ``nav350_stream``;
- host session (pure, time passed in): ``nav350_session`` with ``nav350_clock`` (device clock);
- device model (shared by the simulator and the emulator): ``nav350_device``; emulator:
  ``nav350_emulator``; simulator link: ``nav350_simlink``; ``nav350_loopback``: recorder against
  emulator, end to end;
- log: ``nav350_logdecode``; recorder: ``nav350_worker``;
- :mod:`~lgvtool.devices.nav350.nav350_registration`: topics, decoders, emulator, record options.
"""
