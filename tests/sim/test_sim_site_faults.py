"""Site faults (``site.missing``, ``site.moved``, ``site.weak``, ``site.extra``): each does what
docs/simulator.md says on one simulated warehouse run, against the simulator's own truth
(``sim.site``, ``sim.scans``); the TOML and ``--set`` forms work; bad input is one line and
exit 2; the older ``faults.false_reflector`` still works; the defaults change nothing.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from lgvtool.config import default_config
from lgvtool.json_types import member
from lgvtool.log import LogReader
from lgvtool.sim.settings import ExtraObject, MovedReflector, SimSettings, apply_overrides
from lgvtool.sim.simulation import Simulation, simulate
from lgvtool.sim.site_model import FALSE_ID
from tests.inprocess import run_command

EXACT = {"sim.noise": False, "site.survey_sigma_mm": 0.0, "nav.angle_step_deg": 0.0,
         "nav.skew": False, "site.range_bias_sigma_mm": 0.0, "site.floor_tilt_deg": 0.0}
"""No noise, an exact layout, centres at mid-revolution, no bias, a level floor."""

SITE_TOML = """\
[simulator.site]
missing = [12]

[[simulator.site.moved]]
id = 7
dx = 0.06
dy = -0.03

[[simulator.site.weak]]
id = 3
detection = 0.3

[[simulator.site.extra]]
x = 14.0
y = 19.9
"""


def _column(sim: Simulation, rid: int) -> int:
    return int(np.nonzero(sim.landmarks.ids == rid)[0][0])


def _true_ranges(sim: Simulation, j: int) -> np.ndarray:
    """The horizontal range from the head (at each revolution's measurement instant) to where
    landmark ``j`` truly stands, m."""
    t = sim.scans.start + sim.scans.time_in_scan[:, j]
    v = sim.vehicle
    hx, hy, _ = sim.truth.point_at(t, v.nav_x, v.nav_y)
    return np.asarray(np.hypot(sim.landmarks.x[j] - hx, sim.landmarks.y[j] - hy))


@pytest.fixture(scope="module")
def baseline() -> Simulation:
    return simulate("warehouse", seed=4, duration=60)


@pytest.fixture(scope="module")
def busiest(baseline: Simulation) -> list[int]:
    """Layout ids, the most often seen first."""
    seen = baseline.scans.seen.sum(axis=0)
    order = np.argsort(-seen, kind="stable")
    return [int(baseline.landmarks.ids[j]) for j in order if not baseline.landmarks.is_false[j]]


def test_a_missing_reflector_is_never_seen_nor_matched(busiest: list[int]) -> None:
    rid = busiest[0]
    sim = simulate("warehouse", seed=4, duration=60, overrides={"site.missing": [rid]})
    j = _column(sim, rid)
    assert not sim.scans.seen[:, j].any()
    assert not (sim.scans.matched == j).any()
    assert sim.landmarks.map_x[j] == next(r.x for r in sim.config.reflectors if r.id == rid)
    assert sim.metadata()["site_faults"] == {"missing": [rid]}


def test_a_moved_reflector_is_measured_at_its_new_place(busiest: list[int]) -> None:
    rid = busiest[0]
    sim = simulate("warehouse", seed=4, duration=60, overrides={
        **EXACT, "site.moved": [{"id": rid, "dx": 0.06, "dy": -0.03}]})
    j = _column(sim, rid)
    layout = next(r for r in sim.config.reflectors if r.id == rid)
    assert (sim.landmarks.map_x[j], sim.landmarks.map_y[j]) == (layout.x, layout.y)
    assert sim.landmarks.x[j] == pytest.approx(layout.x + 0.06, abs=1e-12)
    assert sim.landmarks.y[j] == pytest.approx(layout.y - 0.03, abs=1e-12)
    seen = sim.scans.seen[:, j]
    assert seen.sum() > 50
    measured = sim.scans.range[seen, j]
    assert np.abs(measured - _true_ranges(sim, j)[seen]).max() < 1e-9
    # against the stored layout the ranges are off by up to the shift
    t = sim.scans.start[seen] + sim.scans.time_in_scan[seen, j]
    hx, hy, _ = sim.truth.point_at(t, sim.vehicle.nav_x, sim.vehicle.nav_y)
    off = np.abs(measured - np.hypot(layout.x - hx, layout.y - hy))
    assert off.max() > 0.02 and off.max() <= math.hypot(0.06, 0.03) + 1e-9
    assert member(sim.metadata()["site_faults"], "moved") == [{"id": rid, "dx": 0.06, "dy": -0.03}]


def test_a_weak_reflector_is_seen_on_its_share_of_chances(busiest: list[int]) -> None:
    rid = busiest[0]
    sim = simulate("warehouse", seed=4, duration=60, overrides={
        **EXACT, "site.weak": [{"id": rid, "detection": 0.3}]})
    j = _column(sim, rid)
    r = _true_ranges(sim, j)
    chances = int(((r >= sim.settings.nav.range_min) & (r <= sim.settings.nav.range_max)).sum())
    assert chances > 100
    k = int(sim.scans.seen[:, j].sum())
    assert abs(k - 0.3 * chances) < 4.0 * math.sqrt(chances * 0.3 * 0.7), (k, chances)
    # the others, with the noise off, on every chance
    other = _column(sim, busiest[1])
    ro = _true_ranges(sim, other)
    assert sim.scans.seen[:, other].sum() == ((ro >= sim.settings.nav.range_min)
                                              & (ro <= sim.settings.nav.range_max)).sum()


def test_an_extra_object_is_seen_and_is_not_in_the_stored_layout(tmp_path: Path) -> None:
    from lgvtool.sim.logfile import write_log

    sim = simulate("warehouse", seed=4, duration=60,
                   overrides={"site.extra": [{"x": 14.0, "y": 19.9}]})
    j = int(np.nonzero(sim.landmarks.is_false)[0][0])
    assert sim.landmarks.ids[j] == FALSE_ID and len(sim.landmarks) == len(sim.config.reflectors) + 1
    assert (sim.landmarks.x[j], sim.landmarks.y[j]) == (14.0, 19.9)
    seen = int(sim.scans.seen[:, j].sum())
    assert seen > 20
    # what the device called it: a layout id where it matched one, none elsewhere
    matched = sim.scans.matched[sim.scans.seen[:, j], j]
    given = {int(sim.landmarks.ids[m]) for m in matched if m >= 0}
    assert given <= {r.id for r in sim.config.reflectors}
    extra = member(sim.metadata()["site_faults"], "extra")
    assert extra == [{"x": 14.0, "y": 19.9, "detection": 0.6, "seen": seen}]
    out = tmp_path / "e.mcap"
    write_log(sim, out)
    stored = [json.loads(m.data) for m in LogReader(out).raw_messages()
              if m.topic == "/map/reflectors"]
    assert stored
    for message in stored:
        assert len(message["reflectors"]) == len(sim.config.reflectors)
        assert all(math.hypot(r["x"] - 14.0, r["y"] - 19.9) > 0.5 for r in message["reflectors"])


def test_the_toml_form_and_set_work(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    cfg = tmp_path / "site.toml"
    cfg.write_text(SITE_TOML, encoding="utf-8")
    out = tmp_path / "s.mcap"
    code, _, err = run_command(capsys, "simulate", "--scenario", "warehouse", "--duration",
                               "20", "--config", cfg, "--set", "site.missing=12",
                               "--set", "site.survey_sigma_mm=5", "-o", out)
    assert code == 0, err
    meta = LogReader(out).metadata["simulator"]
    faults = meta["site_faults"]
    assert faults["missing"] == [12]
    assert faults["moved"] == [{"id": 7, "dx": 0.06, "dy": -0.03}]
    assert faults["weak"] == [{"id": 3, "detection": 0.3}]
    assert faults["extra"][0]["x"] == 14.0 and faults["extra"][0]["detection"] == 0.6
    assert meta["settings"]["site"]["survey_sigma_mm"] == 5.0
    # the log's stored configuration reads back (its [simulator] table is checked on opening)
    code, _, err = run_command(capsys, "info", out)
    assert code == 0, err
    settings = apply_overrides(SimSettings(), {
        f"site.{k}": v for k, v in meta["settings"]["site"].items()})
    assert settings.site.moved == (MovedReflector(id=7, dx=0.06, dy=-0.03),)
    assert settings.site.extra == (ExtraObject(x=14.0, y=19.9),)


@pytest.mark.parametrize(("toml", "words"), [
    ("[simulator.site]\nmissing = [99]\n", "site.missing names reflector 99"),
    ("[[simulator.site.moved]]\nid = 77\ndx = 0.1\n", "site.moved names reflector 77"),
    ("[[simulator.site.weak]]\nid = 0\ndetection = 0.5\n", "site.weak names reflector 0"),
    ("[[simulator.site.weak]]\nid = 3\ndetection = 1.5\n", "site.weak[0].detection"),
    ("[[simulator.site.extra]]\nx = 1.0\ny = 1.0\ndetection = -0.1\n",
     "site.extra[0].detection"),
    ("[[simulator.site.moved]]\nid = 7\ndx = 6.0\n", "site.moved[0].dx must be at most 5"),
    ("[[simulator.site.moved]]\nid = 7\ndz = 0.1\n", "site.moved[0].dz"),
    ("[[simulator.site.moved]]\ndx = 0.1\n", "site.moved[0].id"),
    ("[simulator.site]\nmissing = [4, 4]\n", "site.missing lists reflector 4 more than once"),
    ("[[simulator.site.weak]]\nid = 3\ndetection = 0.5\n[[simulator.site.weak]]\nid = 3\n"
     "detection = 0.2\n", "site.weak lists reflector 3 more than once"),
    ("[simulator.site]\nmoved = 3\n", "site.moved must be a list"),
])
def test_bad_site_faults_are_one_line_and_exit_2(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path, toml: str, words: str) -> None:
    cfg = tmp_path / "bad.toml"
    cfg.write_text(toml, encoding="utf-8")
    code, _, err = run_command(capsys, "simulate", "--scenario", "warehouse", "--duration", "5",
                               "--config", cfg, "-o", tmp_path / "x.mcap")
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1, err
    assert words in err
    assert not (tmp_path / "x.mcap").exists()


def test_a_bad_set_of_a_list_is_one_line_and_exit_2(capsys: pytest.CaptureFixture[str],
                                                    tmp_path: Path) -> None:
    for value, words in (("site.missing=abc", "site.missing[0] must be an integer"),
                         ("site.missing=12,12", "more than once")):
        code, _, err = run_command(capsys, "simulate", "--scenario", "warehouse", "--duration",
                                   "5", "--set", value, "-o", tmp_path / "x.mcap")
        assert code == 2 and len(err.strip().splitlines()) == 1 and words in err, err


def test_the_older_false_reflector_still_works() -> None:
    old = simulate("warehouse", seed=2, duration=30, overrides={"faults.false_reflector": True})
    cfg = default_config()
    r3 = next(r for r in cfg.reflectors if r.id == 3)
    new = simulate("warehouse", seed=2, duration=30, overrides={
        "site.extra": [{"x": r3.x + 0.3, "y": r3.y, "detection": 0.6}]})
    assert old.landmarks.is_false.sum() == 1
    for a, b in ((old.scans.seen, new.scans.seen), (old.scans.range, new.scans.range),
                 (old.scans.matched, new.scans.matched)):
        assert np.array_equal(a, b)
    assert old.metadata()["false_reflector"] == new.metadata()["false_reflector"]
    assert (member(old.metadata()["site_faults"], "extra")
            == member(new.metadata()["site_faults"], "extra"))


def test_the_defaults_change_nothing() -> None:
    """Empty site faults leave the draws and the recorded settings as they were (the sample
    logs: tests/sim/test_sim_determinism.py)."""
    a = simulate("warehouse", seed=5, duration=20)
    b = simulate("warehouse", seed=5, duration=20, overrides={
        "site.missing": [], "site.moved": [], "site.weak": [], "site.extra": []})
    assert np.array_equal(a.scans.seen, b.scans.seen)
    assert np.array_equal(a.scans.range, b.scans.range)
    meta: dict[str, Any] = a.metadata()
    assert "site_faults" not in meta
    assert set(meta["settings"]["site"]) == {"survey_sigma_mm", "range_bias_sigma_mm",
                                             "floor_tilt_deg", "floor_wavelength_m"}
