"""``lgvtool import mrclam``: summary, --json, --all, and one clear line with exit 2 for bad
input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from lgvtool.cli import main


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """Run the command line in-process: exit code, stdout, stderr."""
    try:
        main(argv)
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


def test_import_one_robot_prints_a_short_summary(synthetic: Any, tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "r1.mcap"
    code, text, err = run(["import", "mrclam", str(synthetic.root), "--robot", "1",
                           "-o", str(out)], capsys)
    assert code == 0, err
    assert out.is_file()
    lines = text.splitlines()
    assert lines[0].startswith(f"robot 1 -> {out}")
    assert len(lines) <= 8 + len(synthetic.kinds)
    assert "truth_ends_early" in text and "odometry_gap" in text


def test_json_summary(synthetic: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, text, _ = run(["import", "mrclam", str(synthetic.root), "-r", "1", "-o",
                         str(tmp_path / "r1.mcap"), "--json", "--gap-threshold", "2"], capsys)
    assert code == 0
    d = json.loads(text)
    assert d["robot"] == 1 and d["path"] == str(tmp_path / "r1.mcap")
    assert d["counts"]["odometry"] == synthetic.expected["odometry"]
    assert d["counts"]["odometry_gaps"] == 0                         # --gap-threshold 2 s
    assert {q["kind"] for q in d["quirks"]} == synthetic.kinds - {"odometry_gap"}
    assert set(d["camera"]) >= {"fov_rad", "range_min_m", "range_max_m"}


def test_all_robots(synthetic: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, text, _ = run(["import", "mrclam", str(synthetic.root), "--all", "-o",
                         str(tmp_path / "logs"), "--json"], capsys)
    assert code == 0
    assert [d["robot"] for d in json.loads(text)] == [1]
    assert (tmp_path / "logs" / "robot1.mcap").is_file()


@pytest.mark.parametrize(("case", "needle"), [
    ("not_a_dataset", "not an MRCLAM dataset"),
    ("missing_robot", "robot 4: not in"),
    ("broken_file", "Robot1_Measurement.dat: 3 of 4 rows are broken"),
    ("no_robot_option", "give exactly one of --robot N and --all"),
    ("both_options", "give exactly one of --robot N and --all"),
    ("bad_threshold", "--gap-threshold must be above 0"),
    ("bad_delay", "--odometry-delay expects seconds or auto"),
    ("negative_delay", "--odometry-delay must be within 0 to 5 s"),
    ("absent_folder", "no such folder"),
])
def test_bad_input_is_one_line_and_exit_2(case: str, needle: str, synthetic: Any,
                                          tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    root = synthetic.root
    args = ["--robot", "1"]
    if case == "not_a_dataset":
        root = tmp_path / "empty"
        root.mkdir()
    elif case == "missing_robot":
        args = ["--robot", "4"]
    elif case == "broken_file":
        (root / "Robot1_Measurement.dat").write_text("1 2 3\nbroken\nrows\n1248444001.0 63 1 0\n")
    elif case == "no_robot_option":
        args = []
    elif case == "both_options":
        args = ["--robot", "1", "--all"]
    elif case == "bad_threshold":
        args += ["--gap-threshold", "-1"]
    elif case == "bad_delay":
        args += ["--odometry-delay", "soon"]
    elif case == "negative_delay":
        args += ["--odometry-delay", "-0.2"]
    elif case == "absent_folder":
        root = tmp_path / "absent"
    out = tmp_path / "out.mcap"
    code, text, err = run(["import", "mrclam", str(root), *args, "-o", str(out)], capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("lgvtool: error: ")
    assert needle in err
    assert "Traceback" not in err and text == ""
    assert not out.exists()


def test_broken_rows_are_skipped_when_the_rest_is_usable(
        synthetic: Any, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = synthetic.root / "Robot1_Measurement.dat"
    p.write_text(p.read_text() + "1248444009.000 63 oops 0.1\n")
    code, text, _ = run(["import", "mrclam", str(synthetic.root), "-r", "1", "-o",
                         str(tmp_path / "r1.mcap"), "--json"], capsys)
    assert code == 0
    d = json.loads(text)
    assert d["counts"]["broken_rows"] == 3      # 2 planted in the odometry, 1 here
    broken = next(q for q in d["quirks"] if q["kind"] == "broken_rows")
    assert "Robot1_Measurement.dat 1" in broken["message"]


def test_help_stays_light() -> None:
    code = ("import sys\nfrom lgvtool.cli import main\n"
            "try:\n    main(['import', 'mrclam', '--help'])\nexcept SystemExit:\n    pass\n"
            "print('HEAVY' if {'numpy', 'pandas', 'mcap'} & set(sys.modules) else 'LIGHT')\n")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True)
    assert "[OPTIONS] DIR" in res.stdout and "--robot" in res.stdout
    assert res.stdout.strip().endswith("LIGHT")


def test_odometry_delay_option(synthetic: Any, tmp_path: Path,
                               capsys: pytest.CaptureFixture[str]) -> None:
    for given in ("0.25", "0", "auto"):
        code, text, err = run(["import", "mrclam", str(synthetic.root), "-r", "1", "-o",
                               str(tmp_path / f"r1-{given}.mcap"), "--json",
                               "--odometry-delay", given], capsys)
        assert code == 0, err
        timing = json.loads(text)["timing"]
        if given != "auto":
            assert timing["odometry_delay_s"] == float(given) and timing["method"] == "given"
        else:  # the synthetic excerpt has too few sightings to measure: no delay applied
            assert timing["method"] == "measured from the camera"
            assert timing["odometry_delay_s"] == (timing["measured_delay_s"] or 0.0)
