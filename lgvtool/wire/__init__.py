"""The generic wire-codec base shared by every device family: pure functions, no I/O, no clocks.

A device family's own codec lives in its folder (``lgvtool/devices/<family>/``); what every
codec uses is here:

- :mod:`~lgvtool.wire.checksum`: CRC-16/CCITT-FALSE and the XOR block check;
- :mod:`~lgvtool.wire.units`: unit conversions at the wire edge and counter wrap-around;
- :mod:`~lgvtool.wire.resync_stream`: the resynchronising stream-decoder base;
- :mod:`~lgvtool.wire.decode_events`: the decoders' error counters and events;
- :mod:`~lgvtool.wire.wire_errors`: typed decode/encode errors.

Every name has one import path: its module (this package re-exports nothing). Byte layouts and
worked examples: ``docs/protocol.md``.
"""
