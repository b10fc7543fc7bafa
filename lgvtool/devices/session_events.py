"""Events that every device family's host session reports, so that the recorder's workers
handle them alike (each family adds its own, e.g. a pose reply, in its session module)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["DeviceSilent", "PositioningEntered"]


@dataclass(frozen=True)
class PositioningEntered:
    """The device confirmed positioning (NAV350: navigation); ``settings`` lists what was
    applied."""

    settings: dict[str, Any]


@dataclass(frozen=True)
class DeviceSilent:
    """The device stopped answering (``timeouts`` reply timeouts in a row); the link may be
    dead."""

    timeouts: int
