"""Read whitespace-separated numeric text tables, skipping and counting broken rows.

A data row is any line that is neither blank nor a comment; ``#`` starts a comment, also after
values on a line.
A row is *broken* when it does not have exactly the expected number of fields, when a field is
not a finite number, or when a field declared integer holds a fractional value. Broken rows are
skipped and their 1-based line numbers kept; a file whose broken rows outnumber its good ones
(or that has no good row at all) is refused with :class:`lgvtool.errors.InputError`.

Parsing is vectorised: a fast pass with pandas' C parser takes clean files (a 60 000-row file in
about 20 ms); only a file that fails it is re-read row by row with pandas string methods to find
and count the broken rows.
"""

from __future__ import annotations

import hashlib
import io
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from lgvtool.errors import InputError


@dataclass(frozen=True)
class TextTable:
    """The usable rows of one text file, and what was skipped."""

    name: str
    """File name (no folder)."""
    frame: pd.DataFrame
    """Good rows in file order (index 0..n-1); float64 columns, int64 for the integer ones."""
    sha256: str
    """SHA-256 of the file's bytes, hex."""
    size_bytes: int
    """File size, bytes."""
    data_rows: int
    """Rows that are neither blank nor comments."""
    broken_lines: tuple[int, ...]
    """1-based line numbers of the skipped (broken) rows."""
    first_broken_text: str = ""
    """The text of the first broken row (empty when none), for messages."""

    @property
    def broken(self) -> int:
        """Number of broken rows skipped."""
        return len(self.broken_lines)


def _fast(raw: bytes, columns: Sequence[str], integer: Sequence[str]) -> pd.DataFrame | None:
    """All rows with pandas' C parser, or None when any row is broken (or the parser fails)."""
    extra = "_extra_field_"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            df = pd.read_csv(io.BytesIO(raw), sep=r"\s+", comment="#", header=None,
                             names=[*columns, extra], index_col=False, engine="c",
                             skip_blank_lines=True, encoding="utf-8")
    except Exception:
        return None
    if len(df) == 0 or not df[extra].isna().all():
        return None
    df = df.drop(columns=extra)
    if not all(df[c].dtype.kind in "iuf" for c in columns):
        return None
    df = df.astype(np.float64)
    if not np.isfinite(df.to_numpy()).all():
        return None
    for name in integer:
        col = df[name].to_numpy()
        if not (np.floor(col) == col).all():
            return None
        df[name] = col.astype(np.int64)
    return df


def _rowwise(raw: bytes, columns: Sequence[str], integer: Sequence[str]
             ) -> tuple[pd.DataFrame, int, tuple[int, ...], str]:
    """Good rows, number of data rows, broken line numbers (1-based), first broken text."""
    lines = pd.Series(raw.decode("utf-8", errors="replace").splitlines(), dtype=object)
    stripped = lines.str.split("#", n=1).str[0].str.strip()
    data = stripped[stripped != ""]
    data.index = data.index + 1  # 1-based line numbers
    fields = data.str.split()
    good = fields[fields.str.len() == len(columns)]
    if len(good):
        frame = pd.DataFrame(good.tolist(), index=good.index, columns=list(columns))
        frame = frame.apply(pd.to_numeric, errors="coerce").astype(np.float64)
    else:
        frame = pd.DataFrame({c: pd.Series(dtype=np.float64) for c in columns})
    ok = np.isfinite(frame.to_numpy()).all(axis=1)
    for name in integer:
        col = frame[name].to_numpy()
        with np.errstate(invalid="ignore"):
            ok &= np.floor(col) == col
    frame = frame[ok]
    for name in integer:
        frame[name] = frame[name].astype(np.int64)
    bad_index = data.index[~data.index.isin(frame.index)]
    broken = tuple(int(i) for i in bad_index)
    first_text = str(lines.loc[broken[0] - 1]).strip()[:60] if broken else ""
    return frame.reset_index(drop=True), len(data), broken, first_text


def read_table(
    path: str | Path,
    columns: Sequence[str],
    *,
    integer: Sequence[str] = (),
    layout: str | None = None,
) -> TextTable:
    """Parse ``path`` into the columns ``columns`` (SI values as written in the file).

    :param path: the text file.
    :param columns: expected field names, in order; every field is numeric.
    :param integer: names among ``columns`` whose values must be whole numbers.
    :param layout: how to describe the expected row in error messages (default: the names).
    :raises InputError: the file cannot be read, holds no data row, or more broken rows than
        good ones.
    """
    p = Path(path)
    try:
        raw = p.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{p}: file not found") from None
    except IsADirectoryError:
        raise InputError(f"{p}: is a folder, expected a text file") from None
    except OSError as exc:
        raise InputError(f"{p}: cannot read: {exc.strerror or exc}") from None
    digest = hashlib.sha256(raw).hexdigest()
    what = layout or ", ".join(columns)
    fast = _fast(raw, columns, integer)
    broken: tuple[int, ...] = ()
    if fast is not None:
        frame, data_rows, first_text = fast, len(fast), ""
    else:
        frame, data_rows, broken, first_text = _rowwise(raw, columns, integer)
    table = TextTable(
        name=p.name, frame=frame, sha256=digest, size_bytes=len(raw), data_rows=data_rows,
        broken_lines=broken, first_broken_text=first_text,
    )
    if len(frame) == 0:
        if table.data_rows == 0:
            raise InputError(f"{p}: no data rows (expected rows of: {what})")
        raise InputError(f"{p}: none of its {table.data_rows} rows is a row of: {what} "
                         f"(line {broken[0]}: {first_text!r})")
    if table.broken > len(frame):
        raise InputError(f"{p}: {table.broken} of {table.data_rows} rows are broken, expected "
                         f"rows of: {what} (first: line {broken[0]}: {first_text!r})")
    return table
