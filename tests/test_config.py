"""Configuration files: defaults, validation messages, round trip, CLI errors."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from lgvtool.config import (
    config_from_dict,
    default_config,
    load_config,
    parse_set_options,
    to_toml,
)
from lgvtool.errors import ConfigError


def test_defaults_follow_the_paper() -> None:
    cfg = default_config()
    assert cfg.vehicle.encoder_ppr == 1000
    assert cfg.vehicle.circle_radius(math.radians(60)) == pytest.approx(0.6928, abs=1e-4)
    assert len(cfg.reflectors) == 20
    assert len({r.id for r in cfg.reflectors}) == 20
    a = cfg.area
    assert (a.width, a.height) == (25.0, 20.0)
    for r in cfg.reflectors:  # on the walls
        assert min(r.x - a.x_min, a.x_max - r.x, r.y - a.y_min, a.y_max - r.y) == pytest.approx(0.05)


def test_toml_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "v.toml"
    path.write_text(to_toml(default_config().to_dict()))
    assert load_config(path) == default_config()


@pytest.mark.parametrize("text,message", [
    ("[vehicle]\nwheelbase = 1.0\n", "unknown key 'vehicle.wheelbase'"),
    ("[vehicle]\nh = -1.0\n", "vehicle.h must be above 0, got -1"),
    ("[vehicle]\ntrack = 0\n", "vehicle.track must be above 0, got 0"),
    ("[vehicle]\nh = 'long'\n", "vehicle.h must be a number"),
    ("[[reflectors]]\nid = 1\nx = 1.0\ny = 2.0\n[[reflectors]]\nid = 1\nx = 3.0\ny = 2.0\n",
     "duplicate id 1"),
    ("[[reflectors]]\nid = 1\nx = 1.0\n", "missing value for reflectors[0].y"),
    ("[reflectors]\nid = 1\n", "array of tables"),
    ("[wheels]\nn = 3\n", "unknown section 'wheels'"),
    ("[area]\nx_min = 5.0\nx_max = 1.0\n", "x_max must exceed x_min"),
    ("[vehicle\nh = 1\n", "malformed TOML"),
])
def test_bad_config_messages(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_config(path)


def test_partial_file_keeps_other_defaults() -> None:
    cfg = config_from_dict({"vehicle": {"h": 1.5}})
    assert cfg.vehicle.h == 1.5
    assert cfg.vehicle.track == default_config().vehicle.track
    assert cfg.reflectors == default_config().reflectors


def test_set_options() -> None:
    assert parse_set_options(["pf.particles=500", "a.b=true", "name=fast", "x=0.25"]) == {
        "pf.particles": 500, "a.b": True, "name": "fast", "x": 0.25}
    with pytest.raises(ConfigError):
        parse_set_options(["novalue"])


def test_config_cli(tmp_path: Path, run_cli) -> None:
    out = run_cli("config")
    assert out.returncode == 0 and "[vehicle]" in out.stdout and "[[reflectors]]" in out.stdout
    bad = tmp_path / "bad.toml"
    bad.write_text("[vehicle]\nh = -2\n")
    out = run_cli("config", bad)
    assert out.returncode == 2
    assert out.stderr.strip().count("\n") == 0 and "vehicle.h must be above 0" in out.stderr


def test_config_of_a_log_is_the_one_its_replay_uses(tmp_path: Path, run_cli) -> None:
    from lgvtool.log import LogReader

    log = Path(__file__).resolve().parent.parent / "sample_logs" / "paper-circle.mcap"
    out = run_cli("config", log)
    assert out.returncode == 0, out.stderr
    (tmp_path / "run.toml").write_text(out.stdout)
    back, stored = load_config(tmp_path / "run.toml"), LogReader(log).config()
    # TOML has no null: the simulator's unset values (None) are left out, the rest is the same
    assert (back.vehicle, back.area, back.reference, back.reflectors, back.estimators) == (
        stored.vehicle, stored.area, stored.reference, stored.reflectors, stored.estimators)
    assert stored.reflectors and back.vehicle.h == pytest.approx(1.2, abs=1e-12)
    assert run_cli("config", tmp_path / "run.toml").stdout == out.stdout
    foreign = tmp_path / "foreign.mcap"
    foreign.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 40)
    bad = run_cli("config", foreign)
    assert bad.returncode == 2 and bad.stderr.strip().count("\n") == 0, bad.stderr


def test_no_reference_steering_angle_round_trips(tmp_path: Path) -> None:
    cfg = config_from_dict({"reference": {"steering_angle_deg": False}})
    assert cfg.reference.steering_angle_deg is None
    path = tmp_path / "c.toml"
    path.write_text(to_toml(cfg.to_dict()))
    assert load_config(path).reference.steering_angle_deg is None
    assert config_from_dict(cfg.to_dict()).reference.steering_angle_deg is None
