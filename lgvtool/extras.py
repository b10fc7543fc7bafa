"""The optional extras of lgvtool and the one check that names the missing one.

The base install records, simulates, replays and evaluates; heavier packages come with an
extra, ``pip install 'lgvtool[NAME]'``:

========== ==================================== =========================================
extra      packages                             needed by
========== ==================================== =========================================
fleet      dask, distributed, pyarrow           sweep, evaluate --workers/--scheduler,
                                                export --format parquet
live       foxglove-sdk                         record --live, view
ros2       rosbags                              import ros2
calibrate  scipy                                calibrate
png        kaleido                              evaluate --png
========== ==================================== =========================================
"""

from __future__ import annotations

import importlib.util

from lgvtool.errors import InputError


def available(*modules: str) -> bool:
    """True when every module of ``modules`` can be imported (without importing it)."""
    return all(importlib.util.find_spec(m) is not None for m in modules)


def require(what: str, extra: str, *modules: str) -> None:
    """Raise one line naming the extra when ``what`` (e.g. ``sweep``) lacks ``modules``."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise InputError(f"{what} needs {', '.join(missing)} (not installed): "
                         f"pip install 'lgvtool[{extra}]'")
