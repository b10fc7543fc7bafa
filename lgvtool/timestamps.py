"""Time stamps: integer ns since the Unix epoch, and the ``{sec, nsec}`` form of the log's
messages (Foxglove's time layout). The one place lgvtool converts between them."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

__all__ = ["from_stamp", "seconds_to_ns", "stamp"]


def stamp(ns: int) -> dict[str, int]:
    """``{sec, nsec}`` of a time in integer ns since the Unix epoch."""
    sec, nsec = divmod(int(ns), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def from_stamp(t: Mapping[str, Any]) -> int:
    """Integer ns since the Unix epoch of a ``{sec, nsec}`` dict."""
    return int(t["sec"]) * 1_000_000_000 + int(t["nsec"])


def seconds_to_ns(t: float) -> int:
    """Integer ns of a time in s (rounded to the nearest ns)."""
    return round(t * 1e9)
