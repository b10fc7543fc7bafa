"""The device families lgvtool knows, and how to find a family's parts.

Each family is a folder ``lgvtool/devices/<family>/`` with a registration module
``<family>_registration.py``, the same interface for every family:

- names: ``DEVICE``, ``TITLE`` (in messages), ``RAW_TOPICS``, ``TOPICS``, ``ODOMETRY`` (the
  recorder's odometry source: the other families' speed input);
- decoding: ``log_decoder(metadata)``, ``ABSENT_REPORT``, ``ABSENT_METADATA``;
- ``lgvtool record``: ``record_options`` (click decorators), ``RECORD_URL_OPTION`` /
  ``RECORD_URL_PARAM`` (the option naming its link), ``recorder_settings(options, *, layout,
  speed_input, reply_timeout, config)`` (takes its options out of ``options``; ``layout``: the
  shared :class:`~lgvtool.devices.layout_plan.LayoutPlan`, which a family refuses in one line
  where it cannot do it; a :class:`~lgvtool.devices.recorder.RecordedDevice` or None),
  ``recorder_link(url)``,
  ``recorder_worker(...)`` and ``recorder_metadata(device)``;
- ``lgvtool simulate serve``: ``serve_options`` (click decorators), ``SERVE_PARAM`` /
  ``SERVE_DEFAULT`` (its port parameter), ``serve_emulator(playback, spec, *, loop)`` (the
  port and the emulator: an object with ``serve(ep, now, t, log, silent)``,
  ``apply_fault(kind, t, arg, code)`` and optionally ``finished`` / ``next_time()`` when it
  paces the run) and ``emulator_class()`` (whose ``FAULT_KINDS`` are the faults it takes).

``lgvtool decode``, ``record``, ``simulate serve``, the recorder and the simulator's log writer
go through :func:`registration` and :func:`registrations`; adding a family means its folder and
a line in :data:`FAMILIES`. Registrations are imported on first use (``lgvtool --help`` stays
light).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["FAMILIES", "SERVE_PORT_HELP", "family_of_topic", "listed", "registration",
           "registrations"]

#: The device families, in the order their decoders run and their reports are listed.
FAMILIES = ("mcu", "nav200", "nav350")

#: The help of a ``simulate serve`` port option, after "Where the virtual DEVICE listens: ".
SERVE_PORT_HELP = "'pty' (a pseudo-terminal), tcp://HOST:PORT (port 0: any free one) or 'none'."


def registration(family: str) -> ModuleType:
    """The registration module of ``family`` (one of :data:`FAMILIES`)."""
    if family not in FAMILIES:
        raise KeyError(f"no device family {family!r} (known: {', '.join(FAMILIES)})")
    return importlib.import_module(f"lgvtool.devices.{family}.{family}_registration")


def registrations() -> list[ModuleType]:
    """The registration modules of every family, in :data:`FAMILIES` order."""
    return [registration(f) for f in FAMILIES]


def listed() -> list[ModuleType]:
    """The registrations in the order devices are named to people (usage lines, served
    ports): the sensors in :data:`FAMILIES` order, then the odometry sources."""
    regs = registrations()
    return [r for r in regs if not r.ODOMETRY] + [r for r in regs if r.ODOMETRY]


def family_of_topic(topic: str) -> str | None:
    """The family whose raw traffic is logged on ``topic`` (None: no family's)."""
    for reg in registrations():
        if topic in reg.RAW_TOPICS:
            return str(reg.DEVICE)
    return None
