"""Directory outputs (``evaluate -o DIR``, ``sweep -o DIR``, ``import mrclam --all -o DIR``).

The rule, the same as for a file output (:mod:`lgvtool.outputs`) applied to each file: the
directory may exist (it is created when it does not); every file the command writes into it
is refused when it is an input (same file, through symlinks and hard links) or lies inside an
input directory, and an existing one is replaced only with ``--force``. Files are written to a
temporary file and renamed, so a run that fails leaves the old ones as they were. Files of the
directory that the command does not write are left alone (a sweep's ``tasks/`` cache is reused,
never replaced).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from lgvtool.errors import InputError
from lgvtool.outputs import atomic_output, guard_output


def guard_directory(outdir: str | os.PathLike[str], names: Iterable[str],
                    inputs: Iterable[str | os.PathLike[str] | None], *, force: bool = False) -> Path:
    """Check the output directory and each file ``names`` in it; return the directory.

    :raises InputError: the path is empty, the directory is a file or an input, or a file in it
        is an input, lies inside an input directory, or exists and ``force`` is false.
    """
    if str(outdir) == "":
        raise InputError("output directory: an empty path; name a directory")
    out = Path(outdir)
    sources = [Path(i) for i in inputs if i is not None]
    if out.exists() and not out.is_dir():
        raise InputError(f"output directory {out} is a file")
    for src in sources:
        if out.exists() and src.exists() and out.resolve() == src.resolve():
            raise InputError(f"output directory {out} is the input {src}; choose another one")
    if not out.exists():  # created by the command: only where it lies matters
        for src in sources:
            if src.is_dir() and out.resolve().is_relative_to(src.resolve()):
                raise InputError(f"output directory {out} is inside the input {src}; "
                                 "choose another one")
        return out
    names = list(names)
    for name in names:  # an input first: that is the graver mistake
        guard_output(out / name, sources, force=True)
    for name in names:
        guard_output(out / name, sources, force=force)
    return out


def write_text(path: Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file renamed on success."""
    with atomic_output(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
