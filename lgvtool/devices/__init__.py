"""Devices on the vehicle: links, the NAV200 host session, the MCU stream, the recorder.

- :mod:`~lgvtool.devices.links`: ``serial://`` and ``tcp://`` URLs to :class:`Link` objects;
- :mod:`~lgvtool.devices.nav200_session`: the NAV200 host state machine (pure: bytes and
  times in, requests and events out);
- :mod:`~lgvtool.devices.mcu_link`: MCU stream decoding and the vehicle's motion;
- :mod:`~lgvtool.devices.workers`: one thread per device link;
- :mod:`~lgvtool.devices.logsink`: the single writer thread, file splitting, disk-full handling;
- :mod:`~lgvtool.devices.recorder`: the recording loop behind ``lgvtool record``.
"""

from lgvtool.devices.links import Link, LinkDown, LinkSpec, open_link, parse_link_url
from lgvtool.devices.mcu_link import McuLink, Motion, head_velocity
from lgvtool.devices.nav200_session import Nav200Session, Nav200Settings
from lgvtool.devices.recorder import (
    Recorder,
    RecordError,
    RecorderSettings,
    RecordResult,
    record,
)

__all__ = [
    "Link",
    "LinkDown",
    "LinkSpec",
    "McuLink",
    "Motion",
    "Nav200Session",
    "Nav200Settings",
    "RecordError",
    "RecordResult",
    "Recorder",
    "RecorderSettings",
    "head_velocity",
    "open_link",
    "parse_link_url",
    "record",
]
