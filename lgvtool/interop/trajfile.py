"""Trajectory files of other tools: TUM, KITTI, CSV and Parquet (docs/interop.md).

A trajectory is a :class:`lgvtool.trajectory.Trajectory` of the target rotation centre O: t (s
since the Unix epoch), x, y (m, map frame) and heading (rad, counter-clockwise from the map x
axis).

- **TUM** (``NAME.tum``): one pose a line, ``t x y z qx qy qz qw`` separated by single spaces,
  t in s, position in m, z 0, the unit quaternion of a rotation by the heading about z; lines
  starting with ``#`` are comments.
- **KITTI** (``NAME.kitti.txt``): one pose a line, the first three rows of the 4x4 homogeneous
  pose matrix, row-major (``r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz``), m; KITTI has no
  time, so the stamps go to ``NAME.times.txt``, one t in s a line, as KITTI's ``times.txt``.
- **CSV** (``NAME.csv``): a header ``t_s,x_m,y_m,heading_rad`` (every column named with its SI
  unit), then one pose a row.
- **Parquet** (``NAME.parquet``): the same four float64 columns; each field's metadata holds its
  ``unit``, the file's metadata the frame, the point (O) and what the trajectory is.

:func:`read_trajectory` reads TUM (``.tum``, ``.txt``) and CSV (``.csv``) files back, telling
the line of the first bad line; the poses come back sorted by time, one per time (the last).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from itertools import chain
from pathlib import Path

import numpy as np

from lgvtool.errors import InputError
from lgvtool.extras import require
from lgvtool.trajectory import Trajectory

FORMATS = ("tum", "kitti", "csv", "parquet")
"""Formats :func:`write_trajectory` writes."""

COLUMNS = {"t_s": "s", "x_m": "m", "y_m": "m", "heading_rad": "rad"}
"""CSV and Parquet columns and their units."""

_CSV_ALIASES = {
    "t": ("t_s", "t", "time", "timestamp", "stamp"),
    "x": ("x_m", "x"),
    "y": ("y_m", "y"),
    "heading": ("heading_rad", "heading", "yaw_rad", "yaw", "theta"),
}


def file_names(name: str, fmt: str) -> list[str]:
    """The files :func:`write_trajectory` writes for trajectory ``name`` in ``fmt``."""
    if fmt == "kitti":
        return [f"{name}.kitti.txt", f"{name}.times.txt"]
    if fmt not in FORMATS:
        raise InputError(f"unknown trajectory format '{fmt}' (known: {', '.join(FORMATS)})")
    return [f"{name}.{fmt}"]


def require_pyarrow() -> None:
    """Raise a one-line :class:`InputError` naming the extra when pyarrow is missing."""
    require("--format parquet", "fleet", "pyarrow")


def _arrays(tr: Trajectory) -> tuple[np.ndarray, ...]:
    """t (s since the epoch), x, y (m), heading (rad)."""
    tr = tr.on_epoch()
    return tr.t, tr.x, tr.y, tr.heading


#: rows turned into Python floats and lines at a time by the writers: memory holds one block's
#: lines, not the file's (a four-hour log's 288 000 truth poses took about 45 MB as lines)
_BLOCK = 8192


def _rows(*columns: np.ndarray) -> Iterator[tuple[float, ...]]:
    """The rows of ``columns`` as tuples of Python floats, converted a block of
    :data:`_BLOCK` rows at a time."""
    for a in range(0, len(columns[0]), _BLOCK):
        yield from zip(*(c[a:a + _BLOCK].tolist() for c in columns), strict=True)


def _write_lines(path: Path, lines: Iterable[str]) -> None:
    with open(path, "w", encoding="utf-8", newline="\n") as f:
        f.writelines(line + "\n" for line in lines)


def write_tum(df: Trajectory, path: Path, comments: Sequence[str] = ()) -> None:
    """``t x y z qx qy qz qw`` per pose (s, m, unit quaternion); ``comments`` as ``#`` lines."""
    t, x, y, h = _arrays(df)
    qz, qw = np.sin(h / 2.0), np.cos(h / 2.0)
    _write_lines(path, chain(
        (f"# {c}" for c in comments), ["# t x y z qx qy qz qw"],
        (f"{a:.9f} {b:.6f} {c:.6f} 0.000000 0.000000000 0.000000000 {d:.9f} {e:.9f}"
         for a, b, c, d, e in _rows(t, x, y, qz, qw))))


def write_kitti(df: Trajectory, path: Path) -> None:
    """Rows ``r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz`` of each pose matrix (m)."""
    _t, x, y, h = _arrays(df)
    c, s = np.cos(h), np.sin(h)
    _write_lines(path, (
        f"{ci:.9f} {-si:.9f} 0.000000000 {xi:.6f} {si:.9f} {ci:.9f} 0.000000000 {yi:.6f} "
        f"0.000000000 0.000000000 1.000000000 0.000000"
        for ci, si, xi, yi in _rows(c, s, x, y)))


def write_times(df: Trajectory, path: Path) -> None:
    """One stamp per line, s (KITTI's ``times.txt``)."""
    _write_lines(path, (f"{t:.9f}" for (t,) in _rows(_arrays(df)[0])))


def write_csv(df: Trajectory, path: Path) -> None:
    """Header ``t_s,x_m,y_m,heading_rad``, then one row per pose."""
    t, x, y, h = _arrays(df)
    _write_lines(path, chain([",".join(COLUMNS)], (f"{a:.9f},{b:.6f},{c:.6f},{d:.9f}"
                                                   for a, b, c, d in _rows(t, x, y, h))))


def write_parquet(df: Trajectory, path: Path, metadata: Mapping[str, str]) -> None:
    """The CSV columns as float64 with their ``unit`` in the field metadata, ``metadata`` as
    the file's key-value metadata."""
    require_pyarrow()
    import pyarrow as pa
    import pyarrow.parquet as pq

    fields = [pa.field(name, pa.float64(), metadata={"unit": unit})
              for name, unit in COLUMNS.items()]
    schema = pa.schema(fields, metadata={str(k): str(v) for k, v in metadata.items()})
    table = pa.table(dict(zip(COLUMNS, _arrays(df), strict=True)), schema=schema)
    pq.write_table(table, path)


def write_trajectory(df: Trajectory, paths: Sequence[Path], fmt: str,
                     metadata: Mapping[str, str]) -> None:
    """Write ``df`` in ``fmt`` to ``paths`` (as :func:`file_names` names them); ``metadata``
    (what the trajectory is, its frame and point) goes into the TUM comments and the Parquet
    metadata."""
    if fmt == "tum":
        write_tum(df, paths[0], [f"{k}: {v}" for k, v in metadata.items()])
    elif fmt == "kitti":
        write_kitti(df, paths[0])
        write_times(df, paths[1])
    elif fmt == "csv":
        write_csv(df, paths[0])
    elif fmt == "parquet":
        write_parquet(df, paths[0], metadata)
    else:
        raise InputError(f"unknown trajectory format '{fmt}' (known: {', '.join(FORMATS)})")


# --------------------------------------------------------------------------------- reading


def _number(text: str, path: Path, line: int, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{path}:{line}: {what} '{text[:40]}' is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{path}:{line}: {what} is {text}, not a finite number")
    return value


def _frame(rows: list[tuple[float, float, float, float]], path: Path) -> Trajectory:
    if not rows:
        raise InputError(f"{path}: no poses in the file (an empty trajectory cannot be scored)")
    a = np.array(rows, dtype=np.float64)
    return Trajectory.cleaned(a[:, 0], a[:, 1], a[:, 2], a[:, 3])


_TUM_FIELDS = ("t", "x", "y", "z", "qx", "qy", "qz", "qw")


def read_tum(path: Path) -> Trajectory:
    """A TUM file (``t x y z qx qy qz qw``): t, x, y and the yaw of the quaternion as heading.

    :raises InputError: a line that is not 8 finite numbers, a zero quaternion, no pose.
    """
    rows: list[tuple[float, float, float, float]] = []
    for number, line in enumerate(_text_lines(path), start=1):
        text = line.strip()
        if not text or text.startswith("#"):
            continue
        parts = text.split()
        if len(parts) != 8:
            raise InputError(f"{path}:{number}: expected 8 numbers (t x y z qx qy qz qw), "
                             f"got {len(parts)} field(s)")
        t, x, y, _z, qx, qy, qz, qw = (_number(p, path, number, f)
                                       for p, f in zip(parts, _TUM_FIELDS, strict=True))
        if qx * qx + qy * qy + qz * qz + qw * qw < 1e-12:
            raise InputError(f"{path}:{number}: the quaternion is zero")
        rows.append((t, x, y, math.atan2(2.0 * (qw * qz + qx * qy),
                                         1.0 - 2.0 * (qy * qy + qz * qz))))
    return _frame(rows, path)


def _column(header: list[str], key: str) -> int | None:
    names = [h.strip().lower() for h in header]
    for alias in _CSV_ALIASES[key]:
        if alias in names:
            return names.index(alias)
    return None


def read_csv(path: Path) -> Trajectory:
    """A CSV file with a header naming t (``t_s``, ``t``), x (``x_m``, ``x``), y (``y_m``,
    ``y``) and optionally the heading (``heading_rad``, ``heading``, ``yaw``); separated by
    commas, or by semicolons when the header has no comma (a spreadsheet's export).

    :raises InputError: no header with those columns, a row that is not numbers, no pose.
    """
    lines = _text_lines(path)
    first = next((line for line in lines if line.strip()), "")
    reader = csv.reader(lines, delimiter=";" if ";" in first and "," not in first else ",")
    try:
        header = next(reader)
    except StopIteration:
        raise InputError(f"{path}: no poses in the file (an empty trajectory cannot be "
                         f"scored)") from None
    cols = {k: _column(header, k) for k in _CSV_ALIASES}
    missing = [k for k in ("t", "x", "y") if cols[k] is None]
    if missing:
        raise InputError(f"{path}:1: the header names no {', '.join(missing)} column "
                         f"(expected t_s,x_m,y_m[,heading_rad])")
    rows: list[tuple[float, float, float, float]] = []
    for row in reader:
        number = reader.line_num
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{path}:{number}: {len(row)} field(s), the header has "
                             f"{len(header)}")
        vals = {k: _number(row[i], path, number, header[i].strip())
                for k, i in cols.items() if i is not None}
        rows.append((vals["t"], vals["x"], vals["y"], vals.get("heading", math.nan)))
    return _frame(rows, path)


def _text_lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8-sig").splitlines()
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file") from None


_READERS: dict[str, Callable[[Path], Trajectory]] = {
    ".tum": read_tum, ".txt": read_tum, ".csv": read_csv,
}


def read_trajectory(path: str | Path) -> Trajectory:
    """Read a TUM (``.tum``, ``.txt``) or CSV (``.csv``) trajectory of O.

    :raises InputError: unknown suffix, missing file, bad lines (with the line number), no pose.
    """
    p = Path(path)
    reader = _READERS.get(p.suffix.lower())
    if reader is None:
        raise InputError(f"{p}: unknown trajectory file type '{p.suffix}' (known: .tum, .txt "
                         f"for TUM, .csv)")
    if not p.is_file():
        raise InputError(f"trajectory file not found: {p}")
    return reader(p)
