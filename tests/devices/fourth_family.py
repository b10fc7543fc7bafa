"""A fourth device family, ``fake``, registered only by tests: a
:class:`~lgvtool.devices.device_registry.DeviceFamily` (declarations only: no click, no
simulator), with a log decoder that turns every raw chunk of ``/fake/rx`` into one diagnostic.
Its emulator is :mod:`fourth_family_emulation`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from lgvtool.devices.device_registry import JSON, JSONObject, RecordOption
from lgvtool.devices.log_decoding import DecodedQueue
from lgvtool.log import topics
from lgvtool.wire.decode_events import INFO, DecodeEvent

DEVICE = "fake"
TITLE = "the fake device"
ODOMETRY = False
RX = topics.raw_topic(DEVICE, "rx")
RAW_TOPICS = (RX,)
TOPICS = {RX: "lgvtool.RawBytes"}
ABSENT_REPORT: JSONObject | None = None
ABSENT_METADATA: dict[str, dict[str, int]] = {}
RECORD_URL_OPTION, RECORD_URL_PARAM = "--fake", "fake_url"
RECORD_OPTIONS = (RecordOption(RECORD_URL_OPTION, RECORD_URL_PARAM, metavar="URL",
                               help="Fake device link, recorded by no one."),)


class FakeLogDecoder(DecodedQueue):
    """One ``chunk`` diagnostic per raw chunk; counts the chunks and bytes."""

    decoded_topics: frozenset[str] = frozenset()
    sources = frozenset({DEVICE})
    event_kinds = frozenset({"chunk"})

    def __init__(self) -> None:
        super().__init__()
        self.chunks = self.bytes = 0
        self._events: list[DecodeEvent] = []

    def chunk(self, topic: str, data: bytes, t_ns: int) -> None:
        self.last_ns = t_ns
        self.chunks += 1
        self.bytes += len(data)
        self._events.append(DecodeEvent(DEVICE, "chunk", f"{len(data)} bytes", level=INFO,
                                        details={"size_bytes": len(data)}))

    def finish(self, t_ns: int) -> None:
        self.last_ns = max(self.last_ns, t_ns)

    def pop_events(self) -> list[DecodeEvent]:
        out, self._events = self._events, []
        return out

    def report(self) -> dict[str, Any]:
        return {"chunks": self.chunks, "bytes": self.bytes}

    def summary(self) -> list[str]:
        return [f"fake: {self.chunks} chunks"]

    def stats_metadata(self) -> dict[str, dict[str, int]]:
        return {DEVICE: {"chunks": self.chunks}}


def log_decoder(metadata: Mapping[str, Mapping[str, JSON]]) -> FakeLogDecoder:
    return FakeLogDecoder()


def recorder_settings(options: dict[str, Any], *, layout: Any, speed_input: bool,
                      reply_timeout: float, config: Any) -> Any:
    from lgvtool.devices.recorder import RecordedDevice

    url = options.pop(RECORD_URL_PARAM, None)
    return None if url is None else RecordedDevice(url)


def recorder_link(url: str) -> Any:
    raise AssertionError("the fake device is never recorded")


def recorder_worker(*args: Any, **kwargs: Any) -> Any:
    raise AssertionError("the fake device is never recorded")


def recorder_metadata(device: Any) -> JSONObject:
    return {"fake_url": None if device is None else device.url}
