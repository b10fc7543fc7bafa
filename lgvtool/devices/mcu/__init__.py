"""The MCU (encoders, gyro, drive unit; one frame every 100 ms, unasked) as one device family.

- codec (pure): :mod:`~lgvtool.devices.mcu.mcu_frame` (the frame), :mod:`~lgvtool.devices.mcu.mcu_stream`
  (its resynchronising stream decoder with sequence-gap events);
- host session (pure): :mod:`~lgvtool.devices.mcu.mcu_session` (decoding plus the vehicle's motion);
- log: :mod:`~lgvtool.devices.mcu.mcu_logdecode`; recorder: :mod:`~lgvtool.devices.mcu.mcu_worker`;
- :mod:`~lgvtool.devices.mcu.mcu_registration`: topics, decoder, record options (declared),
  recorder settings and worker.

Its simulation is the simulator's, which sits above the device families: the frames come from
the simulator's MCU model, its serial link is ``sim/mcu_simlink.py`` and the virtual
MCU of ``simulate serve`` is in ``sim/emulate/mcu/``.
"""
