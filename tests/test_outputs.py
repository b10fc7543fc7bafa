"""The output policy: an input is never harmed, an existing file needs --force, writes are atomic."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from lgvtool.errors import InputError
from lgvtool.outputs import atomic_output, atomic_outputs, guard_output, printable


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


def test_a_device_fifo_or_empty_path_is_never_an_output(tmp_path: Path, run_cli) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    for out in (Path("/dev/null"), fifo):
        with pytest.raises(InputError, match="not a regular file"):
            guard_output(out, [], force=True)
    with pytest.raises(InputError, match="empty path"):
        guard_output("", [], force=True)
    log = Path(__file__).resolve().parent.parent / "sample_logs" / "paper-circle.mcap"
    res = run_cli("replay", log, "-e", "laser", "-o", "/dev/null", "--force", "--no-view")
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert Path("/dev/null").is_char_device()
    for args in (("evaluate", log, "-o", ""), ("export", log, "-o", ""),
                 ("sweep", log, "-o", "")):
        res = run_cli(*args)
        assert res.returncode == 2 and res.stderr.count("\n") == 1, (args, res.stderr)
        assert "an empty path" in res.stderr, (args, res.stderr)


def test_files_written_together_land_together_or_not_at_all(tmp_path: Path) -> None:
    old = tmp_path / "b.txt"
    old.write_text("old")
    with pytest.raises(OSError, match="No space"), atomic_outputs() as place:
        place(tmp_path / "a.txt").write_text("new a")
        place(old).write_text("new b")
        raise OSError(28, "No space left on device")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.txt"]
    assert old.read_text() == "old"
    with atomic_outputs() as place:
        place(tmp_path / "a.txt").write_text("new a")
        place(old).write_text("new b")
    assert (tmp_path / "a.txt").read_text() == "new a" and old.read_text() == "new b"


def test_an_evaluation_that_cannot_finish_its_report_leaves_no_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, run_cli) -> None:
    import lgvtool.evaluate.html_report as html_report
    from lgvtool.cli import main

    def full_disk(*_a: object, **_k: object) -> str:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(html_report, "render_report", full_disk)
    log = Path(__file__).resolve().parent.parent / "sample_logs" / "paper-circle.mcap"
    out = tmp_path / "report"
    with pytest.raises(SystemExit) as exc:
        main(["evaluate", str(log), "-e", "laser", "-o", str(out)])
    assert exc.value.code == 2
    assert list(out.iterdir()) == []  # not the tables without their report
