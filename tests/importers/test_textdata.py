"""The text-table reader: clean files, broken rows skipped and counted, unusable files refused."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest

from lgvtool.errors import InputError
from lgvtool.importers.textdata import read_table

COLS = ("t", "code", "value")


def write(tmp_path: Path, text: str | bytes, name: str = "table.dat") -> Path:
    p = tmp_path / name
    p.write_bytes(text if isinstance(text, bytes) else text.encode())
    return p


def test_clean_file_reads_every_row_with_types_and_digest(tmp_path: Path) -> None:
    text = "# head\n# more\n1248444187.156 \t 14 \t 3.787\n\n1248444187.186 90 -0.005\n"
    p = write(tmp_path, text)
    t = read_table(p, COLS, integer=("code",))
    assert t.broken == 0 and t.data_rows == 2
    assert t.frame["code"].dtype == np.int64 and t.frame["t"].dtype == np.float64
    assert t.frame["t"].tolist() == [1248444187.156, 1248444187.186]
    assert t.frame["code"].tolist() == [14, 90]
    assert t.sha256 == hashlib.sha256(text.encode()).hexdigest()
    assert t.size_bytes == len(text.encode()) and t.name == "table.dat"


def test_broken_rows_are_skipped_and_counted_with_line_numbers(tmp_path: Path) -> None:
    rows = ["# header", "1 2 3", "1 2", "1 x 3", "1 2 3 4", "", "4 5 6  # trailing comment",
            "7 8 nan", "1 2.5 3", *[f"{i} {i} {i}" for i in range(10, 20)]]
    t = read_table(write(tmp_path, "\n".join(rows) + "\n"), COLS, integer=("code",))
    assert t.broken_lines == (3, 4, 5, 8, 9)
    assert t.broken == 5
    assert t.first_broken_text == "1 2"
    assert t.data_rows == 17
    assert t.frame["t"].tolist()[:2] == [1.0, 4.0]
    assert len(t.frame) == 12
    assert list(t.frame.index) == list(range(12))


@pytest.mark.parametrize(("text", "needle"), [
    ("# only comments\n", "no data rows"),
    ("", "no data rows"),
    ("a b c\nd e f\n", "none of its 2 rows"),
    ("1 2 3\nx\ny\n", "2 of 3 rows are broken"),
    (b"\x00\x01\xff\xfe garbage", "none of its 1 rows"),
])
def test_unusable_files_raise_one_clear_line(tmp_path: Path, text: str | bytes,
                                             needle: str) -> None:
    with pytest.raises(InputError) as err:
        read_table(write(tmp_path, text), COLS)
    assert needle in str(err.value)
    assert "\n" not in str(err.value)


def test_missing_file_and_folder_raise_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="file not found"):
        read_table(tmp_path / "nope.dat", COLS)
    with pytest.raises(InputError, match="is a folder"):
        read_table(tmp_path, COLS)
