"""The device families lgvtool knows, and how to find a family's parts.

Each family is a folder ``lgvtool/devices/<family>/`` with a registration module
``<family>_registration.py`` that names its topics (``DEVICE``, ``RAW_TOPICS``, ``TOPICS``) and
makes its parts on demand (``log_decoder``, ``emulator``, ``recorder_worker``; the NAV350 also
its ``record`` options). ``lgvtool decode``, the recorder, the simulator's log writer and
``simulate serve`` go through :func:`registration`; adding a family means its folder and a line
in :data:`FAMILIES`. Registrations are imported on first use (``lgvtool --help`` stays light).
"""

from __future__ import annotations

import importlib
from types import ModuleType

__all__ = ["FAMILIES", "family_of_topic", "registration", "registrations"]

#: The device families, in the order their decoders run and their reports are listed.
FAMILIES = ("mcu", "nav200", "nav350")


def registration(family: str) -> ModuleType:
    """The registration module of ``family`` (one of :data:`FAMILIES`)."""
    if family not in FAMILIES:
        raise KeyError(f"no device family {family!r} (known: {', '.join(FAMILIES)})")
    return importlib.import_module(f"lgvtool.devices.{family}.{family}_registration")


def registrations() -> list[ModuleType]:
    """The registration modules of every family, in :data:`FAMILIES` order."""
    return [registration(f) for f in FAMILIES]


def family_of_topic(topic: str) -> str | None:
    """The family whose raw traffic is logged on ``topic`` (None: no family's)."""
    for reg in registrations():
        if topic in reg.RAW_TOPICS:
            return str(reg.DEVICE)
    return None
