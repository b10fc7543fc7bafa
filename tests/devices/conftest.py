"""Fixtures of the device tests: every subprocess started is killed when its test ends."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from devices_helpers import Procs


@pytest.fixture
def procs() -> Iterator[Procs]:
    """Start subprocesses through this; whatever still runs at the end is killed."""
    p = Procs()
    try:
        yield p
    finally:
        p.cleanup()
