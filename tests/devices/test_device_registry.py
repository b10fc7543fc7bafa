"""The device registry and the one decoding path from raw bytes to log messages."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pytest

from lgvtool.app.decode_job import decode_log
from lgvtool.devices.device_registry import (
    FAMILIES,
    DeviceFamily,
    OptionValue,
    RecordOption,
    family_of_topic,
    registration,
)
from lgvtool.devices.layout_plan import LayoutPlan
from lgvtool.devices.log_decoding import decode_chunk, finish_decoding
from lgvtool.devices.mcu import mcu_registration
from lgvtool.devices.nav200 import nav200_registration
from lgvtool.devices.nav200.nav200_replies import build_pose_reply
from lgvtool.devices.nav200.nav200_requests import request_pose
from lgvtool.devices.nav350 import nav350_registration
from lgvtool.log import LogReader, topics
from lgvtool.sim import simulate, write_log
from lgvtool.wire.decode_events import DecodeEvent


class _Out:
    def __init__(self) -> None:
        self.messages: list[tuple[str, dict, int]] = []
        self.events: list[tuple[str, int]] = []

    def message(self, topic: str, message: Mapping[str, Any], t_ns: int) -> None:
        self.messages.append((topic, dict(message), t_ns))

    def event(self, event: DecodeEvent, t_ns: int) -> None:
        self.events.append((event.kind, t_ns))


#: every registration satisfies the Protocol: mypy checks each module against it (``mypy
#: tests``), so a family missing a name, or declaring one of another type, fails the check
CHECKED: tuple[DeviceFamily, ...] = (mcu_registration, nav200_registration, nav350_registration)


def _members(protocol: type) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The names (properties) and the functions a Protocol declares."""
    own = [(n, v) for n, v in vars(protocol).items() if not n.startswith("_")]
    return (tuple(n for n, v in own if isinstance(v, property)),
            tuple(n for n, v in own if callable(v)))


#: what every registration holds (DeviceFamily): names, then functions
INTERFACE_NAMES, INTERFACE_FUNCTIONS = _members(DeviceFamily)


def test_the_interface_is_the_protocol() -> None:
    assert INTERFACE_NAMES == ("DEVICE", "TITLE", "ODOMETRY", "RAW_TOPICS", "TOPICS",
                               "ABSENT_REPORT", "ABSENT_METADATA", "RECORD_URL_OPTION",
                               "RECORD_URL_PARAM", "RECORD_OPTIONS")
    assert INTERFACE_FUNCTIONS == ("log_decoder", "recorder_settings", "recorder_link",
                                   "recorder_worker", "recorder_metadata")


def test_every_family_has_the_same_interface() -> None:
    assert [registration(f) for f in FAMILIES] == list(CHECKED)
    for family in FAMILIES:
        reg = registration(family)
        assert [n for n in INTERFACE_NAMES if not hasattr(reg, n)] == [], family
        assert [n for n in INTERFACE_FUNCTIONS if not callable(getattr(reg, n, None))] == [], \
            family
        options = reg.RECORD_OPTIONS
        assert all(isinstance(o, RecordOption) for o in options), family
        assert (options[0].flag, options[0].param) == (reg.RECORD_URL_OPTION,
                                                        reg.RECORD_URL_PARAM), family
    assert [registration(f).ODOMETRY for f in FAMILIES] == [True, False, False]


def test_a_family_takes_only_its_own_record_options() -> None:
    options: dict[str, OptionValue] = {"nav_url": "tcp://h:1", "poll_period": 0.2,
                                       "mcu_url": "tcp://h:2", "nav350_cola": "ascii"}
    shared: dict[str, Any] = {"layout": LayoutPlan(), "speed_input": False,
                              "reply_timeout": 1.0, "config": None}
    mcu = registration("mcu").recorder_settings(options, **shared)
    assert mcu.url == "tcp://h:2" and mcu.settings is None
    nav = registration("nav200").recorder_settings(options, **shared)
    assert nav.url == "tcp://h:1" and nav.settings.poll_period == 0.2
    assert registration("nav350").recorder_settings(options, **shared) is None
    assert options == {}


def test_every_family_registers_its_parts() -> None:
    assert FAMILIES == ("mcu", "nav200", "nav350")
    for family in FAMILIES:
        reg = registration(family)
        assert family == reg.DEVICE
        for topic in reg.RAW_TOPICS:
            assert topic in reg.TOPICS and topic in topics.RAW_TOPICS
            assert family_of_topic(topic) == family
        decoder = reg.log_decoder({})
        assert decoder.sources == frozenset({family})
        assert callable(reg.recorder_worker)
    assert family_of_topic(topics.NAV_POSE) is None
    with pytest.raises(KeyError):
        registration("nav300")


def test_decode_chunk_writes_messages_then_events_at_the_chunk_time() -> None:
    decoder = registration("nav200").log_decoder({})
    out = _Out()
    assert decode_chunk(decoder, topics.NAV_TX, request_pose().encode(), 10, out) == 0
    reply = build_pose_reply(1.0, 2.0, 0.5, 90, 6)
    assert decode_chunk(decoder, topics.NAV_RX, b"\x55\x55" + reply[:5], 20, out) == 0
    assert out.messages == []
    assert decode_chunk(decoder, topics.NAV_RX, reply[5:] + reply[:4], 30, out) == 1
    assert out.events == [("bytes_skipped", 30)]
    (topic, pose, t), = out.messages
    assert (topic, t) == (topics.NAV_POSE, 30)
    assert pose["x"] == pytest.approx(1.0, abs=1e-3) and pose["quality"] == 90
    # the reply cut off at the end of the log is counted, at the last chunk's time
    before = len(out.events)
    assert finish_decoding(decoder, out) >= 1
    assert ("truncated", 30) in out.events[before:]
    assert decoder.report()["poses"] == 1 and decoder.report()["requests"] == 1


@pytest.mark.parametrize("nav_device", ["nav200", "nav350"])
def test_simulator_and_decode_write_the_same_decoded_messages(tmp_path: Path,
                                                              nav_device: str) -> None:
    sim = simulate("paper-circle", seed=3, duration=12.0,
                   overrides={"sim.nav_device": nav_device, "faults.mcu_corrupt_rate": 0.05})
    src, out = tmp_path / "sim.mcap", tmp_path / "decoded.mcap"
    write_log(sim, src)
    decode_log(LogReader(src), out)
    decoded = [topics.MCU_FRAME, topics.NAV_POSE, topics.DIAGNOSTICS]
    if nav_device == "nav350":
        decoded.append(topics.NAV_REFLECTORS)

    def messages(path: Path) -> list[tuple[str, int, object]]:
        return [(m.topic, m.log_time_ns, m.data) for m in LogReader(path).messages(decoded)]

    written = messages(src)
    assert any(t == topics.MCU_FRAME for t, _, _ in written)
    assert any(t == topics.NAV_POSE for t, _, _ in written)
    assert sorted(written, key=repr) == sorted(messages(out), key=repr)


#: private attributes that ``threading.Thread`` sets on itself in Python versions newer than
#: the one a test may run on (3.13 made ``_handle`` the thread's handle, which shadowed a
#: recorder worker's method of that name and broke ``record``)
THREAD_INTERNALS = frozenset({"_handle", "_os_thread_handle", "_tstate_lock", "_is_stopped",
                              "_started", "_ident", "_native_id", "_name", "_target", "_args",
                              "_kwargs", "_daemonic", "_stderr", "_invoke_excepthook"})


def test_no_recorder_worker_shadows_a_name_of_its_thread() -> None:
    """Every family's recorder worker is a ``threading.Thread``: none of its own private
    attributes may take a name the thread uses for itself, in this Python or a newer one
    (``run`` is the thread's to override)."""
    import importlib
    import pkgutil
    import threading

    import lgvtool.devices
    from lgvtool.devices.link_worker import LinkWorker

    taken = set(THREAD_INTERNALS) | set(dir(threading.Thread)) | set(vars(threading.Thread()))
    for mod in pkgutil.walk_packages(lgvtool.devices.__path__, "lgvtool.devices."):
        if mod.name.endswith("_worker"):
            importlib.import_module(mod.name)
    workers: list[type] = []
    todo: list[type] = [LinkWorker]
    while todo:
        cls = todo.pop()
        workers.append(cls)
        todo.extend(cls.__subclasses__())
    assert len(workers) >= 5  # the base, the session base, the MCU, NAV200 and NAV350
    clashes = {(cls.__name__, n) for cls in workers for n in vars(cls)
               if n in taken and n.startswith("_") and not n.startswith("__")}
    assert not clashes, clashes
