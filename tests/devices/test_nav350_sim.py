"""The simulator's NAV350 mode, the serve faults of the NAV350, and its topics."""

from __future__ import annotations

from pathlib import Path

import pytest

from lgvtool.errors import ConfigError, InputError
from lgvtool.log import LogReader, topics
from lgvtool.sim.emulate.emulator_server import parse_fault


def test_simulate_nav350_mode_logs_the_traffic_and_what_it_decodes_to(tmp_path: Path,
                                                                     run_cli) -> None:
    out = tmp_path / "sim350.mcap"
    r = run_cli("simulate", "-s", "paper-circle", "--duration", "12", "--set",
                "sim.nav_device=nav350", "-o", out)
    assert r.returncode == 0, r.stderr
    reader = LogReader(out)
    names = set(reader.topic_names())
    assert {topics.NAV350_TX, topics.NAV350_RX, topics.NAV_POSE, topics.NAV_REFLECTORS} <= names
    assert topics.NAV_TX not in names
    poses = [m.data for m in reader.messages([topics.NAV_POSE])]
    scans = [m for m in reader.messages([topics.NAV_REFLECTORS])]
    assert len(poses) > 70 and len(scans) == len(poses)  # one reply per revolution, 8 Hz
    # the pose tick is mid-revolution: it reaches the host half a revolution (62.5 ms) plus
    # the device's latency (nav.latency_s, 40 ms) plus the link later, by the clock estimate
    stamped = [m for m in reader.messages([topics.NAV_POSE]) if "device_stamp" in m.data]
    assert len(stamped) > 60
    for m in stamped[5:]:
        st = m.data["device_stamp"]
        age = (m.log_time_ns - (st["sec"] * 10**9 + st["nsec"])) / 1e9
        assert 0.09 < age < 0.12
    dec = run_cli("decode", out, "-o", tmp_path / "dec.mcap", "--json")
    assert dec.returncode == 0, dec.stderr
    assert f'"poses": {len(poses)}' in dec.stdout
    # both files pass the reference checker's checks through the mcap package's reader
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "log"))
    from mcap_doctor import assert_reference_clean, schema_errors

    for path in (out, tmp_path / "dec.mcap"):
        assert_reference_clean(path)
        assert schema_errors(path) == []


def test_nav_device_setting_is_checked(run_cli, tmp_path: Path) -> None:
    r = run_cli("simulate", "-s", "paper-circle", "--set", "sim.nav_device=nav300", "-o",
                tmp_path / "x.mcap")
    assert r.returncode == 2 and "sim.nav_device" in r.stderr
    from lgvtool.sim.settings import SimSettings, apply_overrides

    with pytest.raises(ConfigError):
        apply_overrides(SimSettings(), {"sim.nav_device": "x"})


@pytest.mark.parametrize(("spec", "kind", "arg", "code"), [
    ("sfa:nav350:3", "sfa", 0.0, 0), ("sfa:nav350:3:2", "sfa", 2.0, 0),
    ("error:nav350:4:1.5", "error", 1.5, 0), ("error:nav350:4:1.5:4", "error", 1.5, 4),
    ("badsum:nav350:5:3", "badsum", 3.0, 0), ("reset:nav350:6", "reset", 0.0, 0),
    ("drop:nav350:7:3", "drop", 3.0, 0)])
def test_nav350_fault_specs(spec: str, kind: str, arg: float, code: int) -> None:
    f = parse_fault(spec)
    assert (f.kind, f.device, f.arg, f.code) == (kind, "nav350", arg, code)


@pytest.mark.parametrize("spec", ["sfa:nav200:3", "error:nav350:4", "error:nav350:4:1:9",
                                  "badsum:mcu:5:3", "reset:mcu:1"])
def test_bad_nav350_fault_specs(spec: str) -> None:
    with pytest.raises(InputError):
        parse_fault(spec)


def test_port_spec_clock_parameters() -> None:
    from lgvtool.sim.emulate.nav350.nav350_emulator import split_port_spec

    assert split_port_spec("tcp://h:1?drift_ppm=50&offset_ms=7") == (
        "tcp://h:1", {"drift_ppm": 50.0, "offset_ms": 7.0})
    for bad in ("tcp://h:1?drift=5", "tcp://h:1?drift_ppm=x"):
        with pytest.raises(InputError):
            split_port_spec(bad)


def test_raw_topics_are_registered() -> None:
    from lgvtool.devices.nav350 import nav350_registration as registration

    assert topics.schema_for_topic(registration.RX) == "lgvtool.RawBytes"
    assert topics.raw_topic("nav350", "tx") == registration.TX
    assert registration.TX in topics.RAW_TOPICS


def test_evaluate_and_the_reflector_filter_on_a_nav350_log(tmp_path: Path, run_cli) -> None:
    import json

    out = tmp_path / "circle350.mcap"
    r = run_cli("simulate", "-s", "paper-circle", "--duration", "60", "--set",
                "sim.nav_device=nav350", "-o", out)
    assert r.returncode == 0, r.stderr
    ev = run_cli("evaluate", out, "-e", "laser,pf-paper", "--json")
    assert ev.returncode == 0, ev.stderr
    doc = json.loads(ev.stdout)
    assert doc["rotations"]["complete"] >= 2
    laser = doc["estimators"]["laser"]["circle"]["rmse_mm"]
    paper = doc["estimators"]["pf-paper"]["circle"]["rmse_mm"]
    # the reflectors the NAV350 reports let the paper's filter beat the device's own pose
    assert paper < 0.5 * laser


@pytest.mark.parametrize(("port", "expect"), [("bogus", "expected 'pty' or tcp://HOST:PORT"),
                                              ("tcp://127.0.0.1:0?foo=1", "unknown port")])
def test_serve_rejects_a_bad_nav350_port_in_one_line(run_cli, port: str, expect: str) -> None:
    r = run_cli("simulate", "serve", "--duration", "12", "--nav", "none", "--mcu", "none",
                "--nav350", port)
    assert r.returncode == 2
    assert expect in r.stderr and r.stderr.count("\n") == 1
