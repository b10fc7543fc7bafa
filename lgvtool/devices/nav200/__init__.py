"""The SICK NAV200 (RS-232 request/reply telegrams) as one device family.

- codec (pure): :mod:`~lgvtool.devices.nav200.nav200_framing`, ``nav200_payloads``,
  ``nav200_commands``, ``nav200_errorcodes``, ``nav200_requests``, ``nav200_replies``,
  ``nav200_stream`` and ``nav200_matcher`` (replies paired with their requests);
- host session (pure, time passed in): :mod:`~lgvtool.devices.nav200.nav200_session`;
- device model (shared by the simulator and the emulator): :mod:`~lgvtool.devices.nav200.nav200_device`;
- log: ``nav200_logdecode``; recorder: ``nav200_worker``;
- :mod:`~lgvtool.devices.nav200.nav200_registration`: topics, decoder, record options
  (declared), recorder settings and worker.

Its simulator link (``sim/nav200_simlink.py``) and the virtual NAV200 of ``simulate
serve`` (``sim/emulate/nav200/``) are the simulator's, which sits above the device
families.
"""
