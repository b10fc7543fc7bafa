"""The cyclic garbage collector held off while a job allocates millions of acyclic objects.

Reading a log, running the estimators and writing their output allocate millions of
containers (decoded messages, observation lists, per-message rows) that form no reference
cycles; the collector's full passes over them and over the modules' own objects (numba's
compiler holds hundreds of thousands) cost tens of milliseconds each and free nothing: 0.3 to
0.8 s of an hour's ``evaluate`` (docs/performance.md, "The collector held off"). Memory freed
by reference counting is unaffected; only cycles wait until the collector is back on.
"""

from __future__ import annotations

import gc
import threading
from collections.abc import Iterator
from contextlib import contextmanager

_lock = threading.Lock()
_holders = 0
_was_enabled = False


@contextmanager
def collector_paused() -> Iterator[None]:
    """Run the block with :mod:`gc`'s automatic collection off, restored once the last of the
    blocks running at once (nested, or on other threads) has left; left off if it was off."""
    global _holders, _was_enabled
    with _lock:
        if _holders == 0:
            _was_enabled = gc.isenabled()
            gc.disable()
        _holders += 1
    try:
        yield
    finally:
        with _lock:
            _holders -= 1
            if _holders == 0 and _was_enabled:
                gc.enable()
