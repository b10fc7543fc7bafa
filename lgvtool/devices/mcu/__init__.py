"""The MCU (encoders, gyro, drive unit; one frame every 100 ms, unasked) as one device family.

- codec (pure): :mod:`~lgvtool.devices.mcu.mcu_frame` (the frame), :mod:`~lgvtool.devices.mcu.mcu_stream`
  (its resynchronising stream decoder with sequence-gap events);
- host session (pure): :mod:`~lgvtool.devices.mcu.mcu_session` (decoding plus the vehicle's motion);
- device model: the simulator's :mod:`lgvtool.sim.mcu_model` makes the frames, which the
  emulator (:mod:`~lgvtool.devices.mcu.mcu_emulator`) plays; simulator link:
  :mod:`~lgvtool.devices.mcu.mcu_simlink`;
- log: :mod:`~lgvtool.devices.mcu.mcu_logdecode`; recorder: :mod:`~lgvtool.devices.mcu.mcu_worker`;
- :mod:`~lgvtool.devices.mcu.mcu_registration`: topics, decoder, emulator, recorder worker.
"""
