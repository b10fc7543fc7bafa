"""The one reflector layout file format ([[reflectors]] TOML) and SICK's .imk beside it."""

from __future__ import annotations

from pathlib import Path

import pytest

from lgvtool.config import Reflector
from lgvtool.errors import ConfigError
from lgvtool.layout_file import format_imk, merge_mapped, parse_imk, read_layout, write_layout

IMK = """# saved by SOPAS ET
globID x_mm y_mm type subtype size_mm layer
1 1000 -2000 1 1 80 0
2 3000 4000 1 2 100 0 1
"""


def test_imk_reads_ids_metres_radii_and_first_layer() -> None:
    assert parse_imk(IMK) == (Reflector(1, 1.0, -2.0, 0.04, 0), Reflector(2, 3.0, 4.0, 0.05, 0))


def test_toml_and_imk_round_trip_through_files(tmp_path: Path) -> None:
    layout = parse_imk(IMK)
    for name in ("l.toml", "l.imk"):
        write_layout(tmp_path / name, layout)
        assert read_layout(tmp_path / name) == layout
    assert format_imk(layout).splitlines()[1] == "1 1000 -2000 1 1 80 0"


@pytest.mark.parametrize(("text", "says"), [
    ("1 2 3 4 5 6\n", "at least 7"),
    ("1 a 3 4 5 6 7\n", "not a landmark line"),
    ("1 0 0 1 1 80 0\n1 5 5 1 1 80 0\n", "duplicate id 1"),
])
def test_bad_imk_lines_are_refused(text: str, says: str) -> None:
    with pytest.raises(ConfigError, match=says):
        parse_imk(text)


def test_a_toml_file_without_reflectors_is_refused(tmp_path: Path) -> None:
    (tmp_path / "c.toml").write_text("[vehicle]\nh = 1.2\n")
    with pytest.raises(ConfigError, match=r"no \[\[reflectors\]\]"):
        read_layout(tmp_path / "c.toml")


def test_mapped_landmarks_merge_with_the_nearest_reflector_and_new_ones_are_added() -> None:
    layout = (Reflector(4, 0.0, 0.0, 0.05, 0), Reflector(9, 5.0, 0.0, 0.05, 0),
              Reflector(2, 5.1, 0.0, 0.05, 1))  # another layer: never merged
    found = [(0.1, 0.0), (5.04, 0.02), (5.2, 0.0), (20.0, 3.0)]
    merged = merge_mapped(layout, found, layer=0, radius=0.04)
    by_id = {r.id: r for r in merged}
    assert by_id[4].x == pytest.approx(0.05) and by_id[9].x == pytest.approx(5.02)
    assert by_id[2] == layout[2]
    # (5.2, 0) is within 0.25 m of reflector 9, but 9 took the nearer (5.04, 0.02)
    assert [(r.id, r.x, r.y, r.layer) for r in merged[3:]] == [(10, 5.2, 0.0, 0), (11, 20.0, 3.0, 0)]
    assert merge_mapped((), found[:1]) == (Reflector(1, 0.1, 0.0, 0.04, 0),)


def test_layout_convert_writes_the_format_its_suffix_names(run_cli, tmp_path: Path) -> None:
    (tmp_path / "site.imk").write_text(IMK)
    r = run_cli("layout", "convert", tmp_path / "site.imk", "-o", tmp_path / "site.toml")
    assert r.returncode == 0, r.stderr
    assert "2 reflectors" in r.stdout
    assert read_layout(tmp_path / "site.toml") == parse_imk(IMK)
    r = run_cli("layout", "convert", tmp_path / "site.toml", "-o", tmp_path / "site.toml",
                "--force")
    assert r.returncode == 2 and "is the input" in r.stderr
