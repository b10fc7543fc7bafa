"""``record --nav350`` against the virtual NAV350 over TCP, as a user runs it: by default the
device's stored layout is read and nothing is written; ``--write-layout FILE`` erases and writes
once, said first and logged before and after; ``--map-at`` with ``--map-layout`` maps from a
stand and merges the landmarks into a layout file; bad layout options give one line."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.layout_file import read_layout
from lgvtool.log import LogReader
from lgvtool.sim.emulate.emulator_playback import playback_from_scenario
from lgvtool.sim.emulate.emulator_server import EmulatorServer

_WRITES = {"mNLAYEraseLayout", "mNLAYAddLandmark", "mNLAYStoreLayout"}


@pytest.fixture
def served() -> Iterator[EmulatorServer]:
    pb = playback_from_scenario("paper-circle", seed=5, duration=60.0)
    server = EmulatorServer(pb, nav=None, mcu=None, nav350="tcp://127.0.0.1:0", seed=1)
    server.start()
    try:
        yield server
    finally:
        server.stop()


def _requests(server: EmulatorServer) -> list[str]:
    dec = Nav350StreamDecoder()
    with server._lock:
        got = [e.data for e in server.transcript if e.device == "nav350"
               and e.direction != "sent"]
    return [t.name for data in got for t in dec.feed(data)]


def test_record_reads_the_layout_and_writes_nothing_by_default(served, run_cli,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "rec.mcap"
    r = run_cli("record", "--nav350", served.urls["nav350"], "-o", out, "--duration", "3",
                "--no-status")
    assert r.returncode == 0, r.stderr
    names = _requests(served)
    assert "mNLAYGetLayer" in names and "mNPOSGetData" in names
    assert not _WRITES & set(names)
    reader = LogReader(out)
    stored = served.emulators["nav350"].device.layout
    logged = {ref.id: (round(ref.x * 1000), round(ref.y * 1000)) for ref in reader.reflector_map()}
    assert logged == {g: (m.x_mm, m.y_mm) for g, m in stored.items()}
    kinds = [m.data["kind"] for m in reader.messages(["/diagnostics"])]
    assert "layout_read" in kinds and "layout_erasing" not in kinds


def test_write_layout_erases_once_and_logs_before_and_after(served, run_cli,
                                                           tmp_path: Path) -> None:
    layout = tmp_path / "site.imk"
    layout.write_text("globID x_mm y_mm type subtype size_mm layer\n"
                      "7 1000 2000 1 1 80 0\n8 5000 2000 1 1 80 0\n9 3000 7000 1 1 80 0\n")
    out = tmp_path / "rec.mcap"
    r = run_cli("record", "--nav350", served.urls["nav350"], "-o", out, "--duration", "3",
                "--no-status", "--write-layout", layout)
    assert r.returncode == 0, r.stderr
    assert "ERASED" in r.stderr and "3 reflectors" in r.stderr
    names = _requests(served)
    assert names.count("mNLAYEraseLayout") == 1 and names.count("mNLAYStoreLayout") == 1
    stored = served.emulators["nav350"].device.layout
    assert sorted((m.x_mm, m.y_mm) for m in stored.values()) == [
        (1000, 2000), (3000, 7000), (5000, 2000)]
    meta = LogReader(out).metadata["device.nav350"]
    assert len(meta["layout_before"]) > 3 and len(meta["layout_after"]) == 3
    assert layout.read_text().startswith("globID")  # the input is unchanged


def test_map_at_writes_a_layout_file_and_merges_a_second_stand(served, run_cli,
                                                              tmp_path: Path) -> None:
    out = tmp_path / "map.mcap"
    site = tmp_path / "site.toml"
    r = run_cli("record", "--nav350", served.urls["nav350"], "-o", out, "--duration", "12",
                "--no-status", "--map-at", "0,0,0", "--map-layout", site, "--json")
    assert r.returncode == 0, r.stderr
    first = read_layout(site)
    assert len(first) >= 3
    assert "NMAPMapCfg" in _requests(served) and not _WRITES & set(_requests(served))
    meta = LogReader(out).metadata["device.nav350"]
    assert len(meta["mapping"]["landmarks_m"]) == len(first)
    r = run_cli("record", "--nav350", served.urls["nav350"], "-o", tmp_path / "map2.mcap",
                "--duration", "12", "--no-status", "--map-at", "0,0,0", "--map-layout", site)
    assert r.returncode == 0, r.stderr
    merged = read_layout(site)
    assert len(merged) >= len(first)  # the same stand: its landmarks merge, few are new
    assert len(merged) < 2 * len(first)


@pytest.mark.parametrize(("args", "says"), [
    (["--write-layout", "missing.toml"], "cannot read the layout file"),
    (["--map-at", "1,2"], "give X,Y,DEG"),
    (["--map-at", "1,2,nan"], "--map-at"),
    (["--map-layout", "x.toml"], "--map-layout needs --map-at"),
])
def test_bad_layout_options_give_one_line(run_cli, tmp_path: Path, args: list[str],
                                          says: str) -> None:
    r = run_cli("record", "--nav350", "tcp://127.0.0.1:9", "-o", tmp_path / "x.mcap",
                "--duration", "1", *args, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and says in r.stderr


def test_a_nav200_refuses_what_it_cannot_do_in_one_line(run_cli, tmp_path: Path) -> None:
    layout = tmp_path / "l.toml"
    layout.write_text("".join(f"[[reflectors]]\nid = {i}\nx = {i}.0\ny = 1.0\n"
                              for i in (1, 2, 300)))
    r = run_cli("record", "--nav", "tcp://127.0.0.1:9", "-o", tmp_path / "x.mcap",
                "--duration", "1", "--write-layout", layout)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "0..254" in r.stderr
    r = run_cli("record", "--nav", "tcp://127.0.0.1:9", "-o", tmp_path / "x.mcap",
                "--duration", "1", "--map-at", "0,0,0")
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "for the NAV350" in r.stderr
