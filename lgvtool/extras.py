"""The optional extras of lgvtool and the one check that names the missing one.

The base install records, simulates, replays and evaluates; heavier packages come with an
extra, installed as the README installs lgvtool: ``pip install '.[NAME]'`` in the project
folder (a source checkout; an installed package from an index: ``pip install 'lgvtool[NAME]'``):

========== ==================================== =========================================
extra      packages                             needed by
========== ==================================== =========================================
fleet      dask, distributed, pyarrow           sweep, evaluate --workers/--scheduler,
                                                export --format parquet
live       foxglove-sdk                         record --live, view
ros2       rosbags                              import ros2
calibrate  scipy                                calibrate, layout refine
png        kaleido                              evaluate --png
========== ==================================== =========================================
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

from lgvtool.errors import InputError


def available(*modules: str) -> bool:
    """True when every module of ``modules`` can be imported (without importing it)."""
    return all(importlib.util.find_spec(m) is not None for m in modules)


def install_source() -> tuple[Path | None, bool]:
    """The source folder lgvtool runs from or was installed from (``pip install .``), when it
    is still there (None for a package from an index or a wheel), and whether the install is
    an editable one of that folder (``pip install -e .``)."""
    here = Path(__file__).resolve().parent.parent
    record = _direct_url()
    info = record.get("dir_info")
    url = record.get("url")
    folder = None
    if isinstance(info, dict) and isinstance(url, str) and url.startswith("file://"):
        from urllib.parse import unquote, urlparse

        folder = Path(unquote(urlparse(url).path)).resolve()
        if not _is_project(folder):
            folder = None
    editable = isinstance(info, dict) and info.get("editable") is True
    if _is_project(here):  # a source checkout: installed editable, or run from its folder
        return here, editable and folder == here
    return folder, False


def _direct_url() -> dict[str, object]:
    """The installed distribution's ``direct_url.json`` (PEP 610), or {}."""
    from importlib.metadata import PackageNotFoundError, distribution

    try:
        raw = distribution("lgvtool").read_text("direct_url.json")
        record = json.loads(raw or "{}")
    except (PackageNotFoundError, OSError, ValueError):
        return {}
    return record if isinstance(record, dict) else {}


def _is_project(folder: Path) -> bool:
    """Whether ``folder`` holds lgvtool's pyproject.toml (a source checkout)."""
    try:
        text = (folder / "pyproject.toml").read_text(encoding="utf-8")
    except OSError:
        return False
    return 'name = "lgvtool"' in text


def install_hint(extra: str) -> str:
    """How to install ``extra`` into this install of lgvtool, as README.md's install lines
    say: ``pip install '.[fleet]'`` from the source folder it came from (named; ``-e`` for an
    editable install), else ``pip install 'lgvtool[fleet]'``."""
    folder, editable = install_source()
    if folder is None:
        return f"pip install 'lgvtool[{extra}]'"
    return f"pip install {'-e ' if editable else ''}'.[{extra}]' from the project folder ({folder})"


def require(what: str, extra: str, *modules: str) -> None:
    """Raise one line naming the extra and how to install it when ``what`` (e.g. ``sweep``)
    lacks ``modules``."""
    missing = [m for m in modules if importlib.util.find_spec(m) is None]
    if missing:
        raise InputError(f"{what} needs {', '.join(missing)} (not installed): "
                         f"{install_hint(extra)}")
