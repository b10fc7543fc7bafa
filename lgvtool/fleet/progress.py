"""The progress bar of sweeps: :class:`lgvtool.progress.Progress`, the one every long command
uses."""

from __future__ import annotations

from lgvtool.progress import Progress

__all__ = ["Progress"]
