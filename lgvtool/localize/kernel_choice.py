"""Which inner loops the estimators run: the compiled kernels (numba, the ``fast`` extra) or
the numpy array operations (the reference).

The choice is made here, once per estimator, when it is made: :func:`particle_backend` and
:func:`gaussian_backend` give the backend a filter holds (its one seam,
:mod:`lgvtool.localize.particle_backend`, :mod:`lgvtool.localize.gaussian_backend`); the
compiled ones live in :mod:`lgvtool.localize.pf_compiled` and
:mod:`lgvtool.localize.ekf_compiled`, the only modules that import the kernels.
"""

from __future__ import annotations

import functools
import importlib
import os
from types import ModuleType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from lgvtool.localize.gaussian_backend import GaussianBackend
    from lgvtool.localize.particle_backend import ParticleBackend

#: environment variable choosing the estimators' inner loops: ``numba`` (the compiled
#: kernels, an ImportError without numba), ``numpy`` (the array operations, the reference);
#: anything else, or unset: the kernels when numba is installed
KERNELS_ENV = "LGVTOOL_KERNELS"

#: the compiled backend module of each family of estimators (``Estimator.kernel_family``)
COMPILED = {
    "particles": "lgvtool.localize.pf_compiled",
    "gaussian": "lgvtool.localize.ekf_compiled",
}


def compiled(module: str) -> ModuleType | None:
    """The compiled module ``module`` (e.g. ``lgvtool.localize.pf_compiled``), or None for the
    numpy path (numba not installed, or ``LGVTOOL_KERNELS=numpy``). Importing it imports
    numba, so this is called when an estimator is made, never at start-up."""
    mode = os.environ.get(KERNELS_ENV, "auto").strip().lower()
    if mode == "numpy":
        return None
    try:
        return importlib.import_module(module)
    except ImportError:
        if mode == "numba":
            raise
        return None


def particle_backend() -> ParticleBackend:
    """A new backend for a particle filter: on the compiled kernels when they are used, else
    numpy's."""
    mod = compiled(COMPILED["particles"])
    if mod is not None:
        made: ParticleBackend = mod.CompiledParticles()
        return made
    from lgvtool.localize.particle_backend import NumpyParticles

    return NumpyParticles()


def gaussian_backend() -> GaussianBackend:
    """The backend of a Gaussian estimator (EKF, dead reckoning): on the compiled kernels when
    they are used, else numpy's."""
    mod = compiled(COMPILED["gaussian"])
    if mod is not None:
        made: GaussianBackend = mod.CompiledGaussian()
        return made
    from lgvtool.localize.gaussian_backend import NumpyGaussian

    return NumpyGaussian()


def uses_kernels(family: str = "particles") -> bool:
    """Whether the estimators of ``family`` (a key of :data:`COMPILED`) run the compiled
    kernels here (imports them when they do)."""
    return compiled(COMPILED[family]) is not None


def ready(family: str) -> bool:
    """Import the compiled backend of the estimators of ``family`` (a key of
    :data:`COMPILED`; when the kernels are used) and start numba's compiler machinery in this
    thread: numba's first call of a compiled function imports its typing registries (about
    0.15 s), and estimators run side by side must not import at once (an import that waits
    for the interpreter behind a busy thread is many times slower). Returns whether the
    compiled kernels are used."""
    if compiled(COMPILED[family]) is None:
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
