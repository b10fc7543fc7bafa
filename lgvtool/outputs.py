"""One policy for every file a command writes: never harm an input, never leave half a file.

Every command that writes a file goes through :func:`guard_output` before it starts and through
:func:`atomic_output` while it writes:

* an output that is the same file as an input (same device and inode, so through symlinks and
  hard links), or that lies inside an input directory (a dataset), is refused;
* an existing output is replaced only when the user passed ``--force``;
* the data go to a temporary file beside the output, which is renamed over the output only when
  the writer finished without an error; a failed run leaves any existing file as it was.

:func:`printable` strips control characters from strings read from a log or a file before they
reach a terminal.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from lgvtool.errors import InputError

#: C0 and C1 control characters except tab and newline (ESC, BEL, CSI, OSC ... retitle a terminal)
_CONTROL = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f]")


def _same_file(a: Path, b: Path) -> bool:
    """True when ``a`` and ``b`` exist and are one file (device and inode)."""
    try:
        sa, sb = a.stat(), b.stat()
    except OSError:
        return False
    return (sa.st_dev, sa.st_ino) == (sb.st_dev, sb.st_ino)


def _inside(path: Path, directory: Path) -> bool:
    """True when ``path`` (resolved) lies below the existing directory ``directory``."""
    try:
        if not directory.is_dir():
            return False
        target = path.parent.resolve() / path.name
        return target.is_relative_to(directory.resolve())
    except OSError:
        return False


def guard_output(output: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str] | None],
                 *, force: bool = False, what: str = "output", in_place: bool = False) -> Path:
    """Check that writing ``output`` harms no input; return it as a :class:`Path`.

    ``inputs`` are every file or directory the command reads (``None`` entries are skipped).
    Raises :class:`InputError` (exit 2, one line) when the output is an input, lies inside an
    input directory, is empty, a directory or something other than a regular file (a device
    such as ``/dev/null``, a FIFO: it would be replaced by the new file; allowed with
    ``in_place``, for a command that writes into the file where it is, as ``record``), or
    exists and ``force`` is false.
    """
    out = Path(output)
    for item in inputs:
        if item is None:
            continue
        src = Path(item)
        if _same_file(out, src) or (out.parent.resolve() / out.name) == (src.parent.resolve() / src.name):
            raise InputError(f"{what} {out} is the input {src}; choose another {what}")
        if _inside(out, src):
            raise InputError(f"{what} {out} is inside the input {src}; choose another {what}")
    if str(output) == "":
        raise InputError(f"{what}: an empty path; name a file")
    if out.is_dir():
        raise InputError(f"{what} {out} is a directory")
    if out.exists() and not out.is_file() and not in_place:
        # a device, a FIFO or a socket: renaming a new file over it would replace it
        raise InputError(f"{what} {out} is not a regular file (a device, FIFO or socket); "
                         f"choose a file")
    if not out.parent.is_dir():
        raise InputError(f"{what} {out}: no such directory {out.parent}")
    if (out.exists() or out.is_symlink()) and not force:
        raise InputError(f"{what} {out} exists; pass --force to replace it")
    return out


@contextlib.contextmanager
def atomic_output(output: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``output``; rename it over ``output`` on success.

    On an exception (including KeyboardInterrupt) the temporary file is removed and an existing
    ``output`` is left untouched. A symlink at ``output`` is replaced by the new file, never
    written through.
    """
    out = Path(output)
    directory = out.parent if str(out.parent) else Path(".")
    fd, tmp_name = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".part", dir=directory)
    umask = os.umask(0)
    os.umask(umask)
    os.fchmod(fd, 0o666 & ~umask)  # mkstemp's 0600 would hide the output from its group
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        os.replace(tmp, out)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


@contextlib.contextmanager
def atomic_outputs() -> Iterator[Callable[[str | os.PathLike[str]], Path]]:
    """Files that land together: ``place(output)`` gives a temporary path beside ``output`` (as
    :func:`atomic_output`). When the block ends without an exception every one is renamed
    over its output; on an exception every temporary file is removed and no output is
    touched, so a run that fails (a full disk) leaves none of the set half written."""
    with contextlib.ExitStack() as stack:
        def place(output: str | os.PathLike[str]) -> Path:
            return stack.enter_context(atomic_output(output))

        yield place


def printable(text: str) -> str:
    """``text`` with control characters (terminal escapes) replaced by U+FFFD."""
    return _CONTROL.sub("\ufffd", text)
