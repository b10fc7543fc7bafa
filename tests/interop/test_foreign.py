"""``lgvtool evaluate --trajectory NAME=FILE``: a trajectory made elsewhere, scored beside the
built-in estimators; bad files refused with one line."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from lgvtool.interop.trajectory_export import export_log

CLI = Callable[..., tuple[int, str, str]]


@pytest.fixture(scope="module")
def files(sim_log: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("foreign")
    export_log(sim_log, out / "tum", "tum", estimators=["ekf"])
    export_log(sim_log, out / "csv", "csv", estimators=["ekf"])
    return out


def test_a_foreign_trajectory_scores_as_the_estimator_it_copies(
        sim_log: Path, files: Path, tmp_path: Path, cli: CLI) -> None:
    code, out, err = cli("evaluate", sim_log, "-e", "ekf", "--json", "-o",
                         tmp_path / "report",
                         "--trajectory", f"mine={files / 'tum' / 'ekf.tum'}",
                         "--trajectory", f"sheet={files / 'csv' / 'ekf.csv'}")
    assert code == 0, err
    doc = json.loads(out)
    ekf = doc["estimators"]["ekf"]
    for name in ("mine", "sheet"):
        got = doc["estimators"][name]
        assert got["truth"]["samples"] == ekf["truth"]["samples"]
        assert got["truth"]["position_rmse_m"] == pytest.approx(
            ekf["truth"]["position_rmse_m"], abs=1e-6)
        if ekf["circle"]["rotations"]:
            assert got["circle"]["rmse_mm"] == pytest.approx(ekf["circle"]["rmse_mm"],
                                                             abs=1e-3)
    table = (tmp_path / "report" / "table1.csv").read_text()
    assert "mine" in table and "sheet" in table
    assert "mine" in (tmp_path / "report" / "report.html").read_text()


@pytest.mark.parametrize(("text", "expected"), [
    ("1704067210.0 1 2 0 0 0 0 1\n1704067210.1 1 2 0\n", ":2: expected 8 numbers"),
    ("# only a comment\n", "no poses"),
    ("", "no poses"),
])
def test_bad_or_empty_tum_files_are_refused(sim_log: Path, tmp_path: Path, text: str,
                                            expected: str,
                                            cli: CLI) -> None:
    bad = tmp_path / "bad.tum"
    bad.write_text(text)
    code, _, err = cli("evaluate", sim_log, "-e", "laser", "--trajectory", f"x={bad}")
    assert code == 2
    assert expected in err and len(err.strip().splitlines()) == 1


def test_option_errors(sim_log: Path, files: Path, tmp_path: Path,
                       cli: CLI) -> None:
    tum = files / "tum" / "ekf.tum"
    cases = [
        (["--trajectory", str(tum)], "NAME=FILE"),
        (["--trajectory", f"ekf={tum}"], "already an estimator"),
        (["--trajectory", f"a={tmp_path / 'missing.tum'}"], "not found"),
        (["--trajectory", f"a={tmp_path / 'x.json'}"], "unknown trajectory file type"),
    ]
    for extra, expected in cases:
        code, _, err = cli("evaluate", sim_log, "-e", "ekf", *extra)
        assert code == 2 and expected in err, (extra, err)
        assert len(err.strip().splitlines()) == 1
    code, _, err = cli("evaluate", sim_log, sim_log, "--trajectory", f"a={tum}")
    assert code == 2 and "one LOG" in err


def test_stamps_outside_the_log_are_refused(sim_log: Path, tmp_path: Path,
                                            cli: CLI) -> None:
    rel = tmp_path / "relative.tum"
    rel.write_text("".join(f"{0.1 * i:.1f} 11 9 0 0 0 0 1\n" for i in range(50)))
    code, _, err = cli("evaluate", sim_log, "-e", "laser", "--trajectory", f"r={rel}")
    assert code == 2 and "outside" in err and "log's time" in err
