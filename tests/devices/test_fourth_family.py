"""A device family is its declarations and a line in the registry: a fourth family (its
registration, :mod:`fourth_family`, and its emulation, :mod:`fourth_family_emulation`),
registered by patching the registry's table only, gets its ``record`` and ``simulate serve``
options, its log decoder and its emulator with no other lgvtool file changed."""

from __future__ import annotations

import ast
import importlib
import socket
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import fourth_family
import fourth_family_emulation
import pytest
from click.testing import CliRunner

from lgvtool.app.decode_job import decode_log
from lgvtool.devices import device_registry
from lgvtool.devices.device_registry import DeviceFamily
from lgvtool.log import LogReader, LogWriter, topics
from lgvtool.sim.emulate import emulator_registry
from lgvtool.sim.emulate.emulator_registry import FamilyEmulation

if TYPE_CHECKING:  # the two declarations satisfy their Protocols (checked by ``mypy tests``)
    from tests.devices import fourth_family as typed_family
    from tests.devices import fourth_family_emulation as typed_emulation

    CHECKED: tuple[DeviceFamily, FamilyEmulation] = (typed_family, typed_emulation)

#: the modules that apply every family's options when they are imported
_COMMAND_MODULES = ("lgvtool.commands.record", "lgvtool.sim.emulate.serve")


def _reload_commands() -> None:
    for name in _COMMAND_MODULES:
        importlib.reload(importlib.import_module(name))


@pytest.fixture
def fourth() -> Iterator[None]:
    """The registry with the ``fake`` family appended; the command modules re-imported with
    it, and again without it afterwards."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(device_registry, "FAMILIES", (*device_registry.FAMILIES, "fake"))
        mp.setitem(sys.modules, "lgvtool.devices.fake.fake_registration", fourth_family)
        mp.setitem(sys.modules, "lgvtool.sim.emulate.fake.fake_emulation",
                   fourth_family_emulation)
        _reload_commands()
        yield
    _reload_commands()


def _help(*command: str) -> str:
    from lgvtool.cli import cli

    result = CliRunner().invoke(cli, [*command, "--help"])
    assert result.exit_code == 0, result.output
    return result.output


def test_the_fourth_family_is_registered(fourth: None) -> None:
    from test_device_registry import INTERFACE_FUNCTIONS, INTERFACE_NAMES

    assert all(hasattr(fourth_family, n) for n in INTERFACE_NAMES + INTERFACE_FUNCTIONS)
    assert device_registry.registration("fake") is fourth_family
    assert device_registry.registrations()[-1] is fourth_family
    assert device_registry.family_of_topic("/fake/rx") == "fake"
    assert emulator_registry.emulation("fake") is fourth_family_emulation
    assert emulator_registry.emulations()[-2] is fourth_family_emulation  # the MCU is last


def test_its_registration_knows_neither_click_nor_the_simulator() -> None:
    tree = ast.parse(Path(fourth_family.__file__).read_text(encoding="utf-8"))
    imported = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names} | {
        n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not {m for m in imported if m.split(".")[0] == "click" or m.startswith("lgvtool.sim")}


def test_record_and_serve_show_its_options(fourth: None) -> None:
    record = _help("record")
    assert "--fake URL" in record and "Fake device link, recorded by no one." in record
    assert "--nav URL" in record and "--mcu URL" in record and "--nav350 URL" in record
    serve = _help("simulate", "serve")
    assert "--fake PORT" in serve and "Where the fake device listens." in serve


def test_the_usage_line_names_its_option(fourth: None) -> None:
    from lgvtool.devices.recorder import no_device_message

    assert no_device_message() == ("record: give --nav URL, --nav350 URL, --fake URL, "
                                   "--mcu URL or several")


def test_without_it_the_commands_have_no_such_option() -> None:
    assert "--fake" not in _help("record")
    assert "--fake" not in _help("simulate", "serve")


def test_decode_finds_its_log_decoder(fourth: None, tmp_path: Path) -> None:
    src, out = tmp_path / "fake.mcap", tmp_path / "decoded.mcap"
    t0 = 1_700_000_000_000_000_000
    with LogWriter(src, source="test") as w:
        for i, chunk in enumerate((b"\x01\x02", b"\x03", b"\x04\x05\x06")):
            w.write_raw("fake", "rx", chunk, t0 + i * 1_000_000)
    report = decode_log(LogReader(src), out)
    assert report.sections["fake"] == {"chunks": 3, "bytes": 6}
    assert "fake: 3 chunks" in report.lines
    reader = LogReader(out)
    diags = [m.data for m in reader.messages([topics.DIAGNOSTICS])]
    assert [(d["source"], d["kind"]) for d in diags] == [("fake", "chunk")] * 3
    assert [m.log_time_ns for m in reader.messages(["/fake/rx"])] == [t0, t0 + 1_000_000,
                                                                       t0 + 2_000_000]
    assert reader.metadata["decode"]["fake"] == {"chunks": 3}


def _recv_until(sock: socket.socket, want: bytes) -> bytes:
    got = b""
    while not got.endswith(want):
        chunk = sock.recv(4096)
        assert chunk, f"the server closed the link after {got!r}"
        got += chunk
    return got


def test_simulate_serve_serves_its_emulator(fourth: None) -> None:
    from devices_helpers import circle_playback

    from lgvtool.sim.emulate import EmulatorServer

    server = EmulatorServer(circle_playback(2.0), nav=None, mcu=None,
                            fake="tcp://127.0.0.1:0").start()
    try:
        assert set(server.urls) == {"fake"}
        host, _, port = server.urls["fake"][len("tcp://"):].rpartition(":")
        with socket.create_connection((host, int(port)), timeout=10.0) as sock:
            assert _recv_until(sock, fourth_family_emulation.FakeEmulator.GREETING) \
                == fourth_family_emulation.FakeEmulator.GREETING
            sock.sendall(b"ping")
            assert _recv_until(sock, b"ping") == b"ping"
    finally:
        server.stop()
    assert server.sent("fake") == fourth_family_emulation.FakeEmulator.GREETING + b"ping"
    assert server.received("fake") == b"ping"
    assert [e.direction for e in server.transcript if e.device == "fake"] == \
        ["sent", "received", "sent"]
