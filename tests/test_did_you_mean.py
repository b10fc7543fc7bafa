"""A mistyped name is answered with the closest known ones ("did you mean ...?"), on the one
error line, exit 2: commands, estimators (also where a log's own estimates are picked),
scenarios, ``--set`` keys and the keys of configuration files."""

from __future__ import annotations

from pathlib import Path

import pytest

from lgvtool.cli import main
from lgvtool.errors import InputError
from lgvtool.localize.registry import check_names, split_settings
from lgvtool.suggest import SHORT_LIST, closest, did_you_mean, unknown_tail

REPO = Path(__file__).resolve().parents[1]
SAMPLE = str(REPO / "sample_logs" / "paper-circle.mcap")


def _error_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    """The one stderr line of ``lgvtool ARGV``, which must exit 2."""
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(argv)
    err = capsys.readouterr().err
    assert exc.value.code == 2, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("lgvtool: error: "), err
    return lines[0]


def test_closest_names() -> None:
    params = ["min_particles", "particles", "start_particles", "kld"]
    assert closest("partcles", params) == ["particles"]  # not every name that looks alike
    assert closest("PF-PAPER", ["pf", "pf-paper"]) == ["pf-paper"]  # letter case aside
    assert closest("zzz", params) == []
    assert did_you_mean("pf-papr", ["laser", "pf-paper", "pf"]) == "did you mean 'pf-paper'?"
    assert did_you_mean("ek", ["ekf", "ek1"]) == "did you mean 'ekf' or 'ek1'?"
    assert did_you_mean("partcles", params, prefix="pf.") == "did you mean 'pf.particles'?"
    assert did_you_mean("zzz", params) == ""


def test_a_long_list_is_named_by_its_count_and_where_it_is() -> None:
    many = [f"name_{i:02d}" for i in range(SHORT_LIST + 1)]
    tail = unknown_tail("name_1x", many, more="13 names; see the docs")
    assert tail.startswith(": did you mean ") and tail.endswith(" (13 names; see the docs)")
    assert unknown_tail("zzz", many[:3]) == " (known: name_00, name_01, name_02)"


def test_mistyped_command(capsys: pytest.CaptureFixture[str]) -> None:
    line = _error_line(["evalute"], capsys)
    assert line == "lgvtool: error: No such command 'evalute'. Did you mean 'evaluate'?"
    line = _error_line(["simulate", "srve"], capsys)
    assert line.endswith("No such command 'srve'. Did you mean 'serve'?")
    assert "Did you mean" not in _error_line(["frobnicate"], capsys)


def test_mistyped_estimator(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    line = _error_line(["replay", SAMPLE, "-e", "laser,pf-papr", "-o", str(tmp_path / "r.mcap")],
                       capsys)
    assert "unknown estimator 'pf-papr': did you mean 'pf-paper'? (known: laser, " in line
    line = _error_line(["replay", SAMPLE, "--set", "pf-papr.particles=10",
                        "-o", str(tmp_path / "r.mcap")], capsys)
    assert "unknown estimator 'pf-papr' in setting 'pf-papr.particles': did you mean " \
           "'pf-paper'?" in line
    # evaluate of a log without estimates runs the estimators: the same check
    line = _error_line(["evaluate", SAMPLE, "-e", "pf-papr"], capsys)
    assert "did you mean 'pf-paper'?" in line
    assert not (tmp_path / "r.mcap").exists()


def test_the_shared_name_check_accepts_a_logs_own_names() -> None:
    """``check_names(names, also=...)``: what evaluate and export call with the estimates a
    log holds, so a mistyped name is not taken for an estimate the log lacks."""
    assert check_names(["laser", "amcl", "laser"], also=["amcl"]) == ["laser", "amcl"]
    with pytest.raises(InputError, match=r"unknown estimator 'amlc': did you mean 'amcl'\?"):
        check_names(["amlc"], also=["amcl", "laser"])
    with pytest.raises(InputError, match=r"did you mean 'pf-paper'\?"):
        split_settings({"pf-papr.particles": 3})


@pytest.mark.parametrize("command", ["evaluate", "export"])
def test_mistyped_estimator_of_a_replayed_log(command: str, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    """A log with estimates of its own: a typo is no missing replay."""
    replayed = tmp_path / "replayed.mcap"
    main(["replay", SAMPLE, "-e", "laser", "-o", str(replayed), "--no-progress", "--no-view"])
    argv = [command, str(replayed), "-e", "pf-papr"]
    if command == "export":
        argv += ["-o", str(tmp_path / "out")]
    line = _error_line(argv, capsys)
    assert "unknown estimator 'pf-papr': did you mean 'pf-paper'?" in line
    assert "replay first" not in line and "no estimates of" not in line


def test_mistyped_parameter_is_a_short_line(capsys: pytest.CaptureFixture[str],
                                            tmp_path: Path) -> None:
    line = _error_line(["replay", SAMPLE, "--set", "pf.partcles=100",
                        "-o", str(tmp_path / "r.mcap")], capsys)
    assert "unknown parameter 'pf.partcles': did you mean 'pf.particles'?" in line
    assert "lgvtool config --parameters" in line and "alpha_fast" not in line and len(line) < 200
    # a short list is still shown in full
    line = _error_line(["replay", SAMPLE, "--set", "laser.sigma_xy=1",
                        "-o", str(tmp_path / "r.mcap")], capsys)
    assert line.endswith("did you mean 'laser.sigma_xy_m'? (known: pose_gate, "
                         "sigma_heading_rad, sigma_xy_m)")


def test_mistyped_scenario_and_simulator_setting(capsys: pytest.CaptureFixture[str],
                                                tmp_path: Path) -> None:
    out = str(tmp_path / "s.mcap")
    line = _error_line(["simulate", "-s", "warehous", "-o", out], capsys)
    assert "unknown scenario 'warehous': did you mean 'warehouse'? (known: " in line
    for setting, said in (("nav.skw=1", "unknown setting 'nav.skw': did you mean 'nav.skew'?"),
                          ("nva.skew=1", "unknown setting section 'nva' in 'nva.skew': did you "
                                         "mean 'nav'?"),
                          ("scenario.sped=1", "did you mean 'scenario.speed'?"),
                          ("vehicle.nav_xx=1", "did you mean 'vehicle.nav_x'?")):
        line = _error_line(["simulate", "-s", "paper-circle", "--set", setting, "-o", out],
                           capsys)
        assert said in line, line
    assert not Path(out).exists()


@pytest.mark.parametrize(("text", "said"), [
    ("[vehicle]\nnav_xx = 1.0\n", "unknown key 'vehicle.nav_xx': did you mean 'vehicle.nav_x'? "
                                  "(17 keys in [vehicle]; lgvtool config --parameters lists them)"),
    ("[vehicel]\nh = 1.0\n", "unknown section 'vehicel': did you mean 'vehicle'?"),
    ("[estimators.pf-papr]\nparticles = 10\n", "did you mean 'estimators.pf-paper'?"),
    ("[estimators.pf]\npartcles = 10\n", "did you mean 'pf.particles'?"),
    ("[simulator.nav]\nskw = true\n", "did you mean 'nav.skew'?"),
    ("[simulator.scenario]\nsped = 1.0\n", "did you mean 'scenario.speed'?"),
])
def test_mistyped_configuration_key(text: str, said: str, tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text)
    assert said in _error_line(["config", str(path)], capsys)
