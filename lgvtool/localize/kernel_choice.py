"""Which inner loops the estimators run: the compiled kernels (numba, the ``fast`` extra) or
the numpy array operations (the reference)."""

from __future__ import annotations

import functools
import importlib
import os
from types import ModuleType

#: environment variable choosing the estimators' inner loops: ``numba`` (the compiled
#: kernels, an ImportError without numba), ``numpy`` (the array operations, the reference);
#: anything else, or unset: the kernels when numba is installed
KERNELS_ENV = "LGVTOOL_KERNELS"


def compiled(module: str) -> ModuleType | None:
    """The kernel module ``module`` (e.g. ``lgvtool.localize.pf_kernels``), or None for the
    numpy path (numba not installed, or ``LGVTOOL_KERNELS=numpy``). Importing it imports
    numba, so this is called when an estimator runs, never at start-up."""
    mode = os.environ.get(KERNELS_ENV, "auto").strip().lower()
    if mode == "numpy":
        return None
    try:
        return importlib.import_module(module)
    except ImportError:
        if mode == "numba":
            raise
        return None


def ready(module: str) -> bool:
    """Import the kernel module ``module`` (when the kernels are used) and start numba's
    compiler machinery in this thread: numba's first call of a compiled function imports its
    typing registries (about 0.15 s), and estimators run side by side must not import at once
    (an import that waits for the interpreter behind a busy thread is many times slower).
    Returns whether the compiled kernels are used."""
    if compiled(module) is None:
        return False
    _machinery()
    return True


@functools.cache
def _machinery() -> None:
    """One call of a trivial compiled function (cached on disk): numba's machinery loaded."""
    import numba

    numba.njit(cache=True)(_plus_one)(0.0)


def _plus_one(x: float) -> float:
    """``x + 1`` (compiled by :func:`_machinery` only to load numba)."""
    return x + 1.0
