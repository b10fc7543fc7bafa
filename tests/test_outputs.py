"""The output policy: an input is never harmed, an existing file needs --force, writes are atomic."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from lgvtool.errors import InputError
from lgvtool.outputs import atomic_output, guard_output, printable


def test_output_equal_to_input_refused_through_links(tmp_path: Path) -> None:
    src = tmp_path / "in.mcap"
    src.write_bytes(b"data")
    sym = tmp_path / "sym.mcap"
    sym.symlink_to(src)
    hard = tmp_path / "hard.mcap"
    os.link(src, hard)
    for out in (src, sym, hard):
        with pytest.raises(InputError, match="is the input"):
            guard_output(out, [src], force=True)
    assert src.read_bytes() == b"data"


def test_output_inside_input_dataset_refused(tmp_path: Path) -> None:
    ds = tmp_path / "ds"
    ds.mkdir()
    with pytest.raises(InputError, match="inside the input"):
        guard_output(ds / "new.mcap", [ds])


def test_existing_output_needs_force(tmp_path: Path) -> None:
    out = tmp_path / "out.mcap"
    out.write_bytes(b"old")
    with pytest.raises(InputError, match="--force"):
        guard_output(out, [])
    assert guard_output(out, [None], force=True) == out


def test_atomic_output_keeps_old_file_on_failure(tmp_path: Path) -> None:
    out = tmp_path / "out.bin"
    out.write_bytes(b"old")
    with pytest.raises(RuntimeError), atomic_output(out) as tmp:
        tmp.write_bytes(b"half")
        raise RuntimeError("writer failed")
    assert out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.bin"]
    with atomic_output(out) as tmp:
        tmp.write_bytes(b"new")
    assert out.read_bytes() == b"new"


def test_printable_strips_terminal_escapes() -> None:
    assert printable("a\x1b]0;owned\x07b\tc\n") == "a\ufffd]0;owned\ufffdb\tc\n"
