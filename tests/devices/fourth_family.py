"""A fourth device family, ``fake``, registered only by tests: the registration interface of
:mod:`lgvtool.devices.device_registry`, with a log decoder that turns every raw chunk of
``/fake/rx`` into one diagnostic."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import click

from lgvtool.devices.log_decoding import DecodedQueue
from lgvtool.log import topics
from lgvtool.wire.decode_events import INFO, DecodeEvent

DEVICE = "fake"
TITLE = "the fake device"
ODOMETRY = False
RX = topics.raw_topic(DEVICE, "rx")
RAW_TOPICS = (RX,)
TOPICS = {RX: "lgvtool.RawBytes"}
ABSENT_REPORT: dict[str, Any] | None = None
ABSENT_METADATA: dict[str, dict[str, int]] = {}
RECORD_URL_OPTION, RECORD_URL_PARAM = "--fake", "fake_url"
SERVE_PARAM, SERVE_DEFAULT = "fake", None


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


def log_decoder(metadata: Mapping[str, Any]) -> FakeLogDecoder:
    return FakeLogDecoder()


def record_options(f: Callable[..., Any]) -> Callable[..., Any]:
    return click.option("--fake", RECORD_URL_PARAM, metavar="URL",
                        help="Fake device link, recorded by no one.")(f)


def recorder_settings(options: dict[str, Any], *, layout: Any, speed_input: bool,
                      reply_timeout: float, config: Any) -> Any:
    from lgvtool.devices.recorder import RecordedDevice

    url = options.pop(RECORD_URL_PARAM, None)
    return None if url is None else RecordedDevice(url)


def recorder_link(url: str) -> Any:
    raise AssertionError("the fake device is never recorded")


def recorder_worker(*args: Any, **kwargs: Any) -> Any:
    raise AssertionError("the fake device is never recorded")


def recorder_metadata(device: Any) -> dict[str, Any]:
    return {"fake_url": None if device is None else device.url}


def serve_options(f: Callable[..., Any]) -> Callable[..., Any]:
    return click.option("--fake", SERVE_PARAM, default="none", show_default=True,
                        metavar="PORT", help="Where the fake device listens.")(f)


class FakeEmulator:
    """Sends :data:`GREETING` once the run's clock has started; echoes what it receives."""

    FAULT_KINDS: tuple[str, ...] = ()
    GREETING = b"fake says hello"

    def __init__(self) -> None:
        self.greeted = False

    def serve(self, ep: Any, now: float, t: float | None, log: Callable[[str, bytes], None],
              silent: Callable[[], bool]) -> None:
        if ep is None or t is None:
            return
        if not self.greeted and ep.write(self.GREETING, now):
            self.greeted = True
            log("sent", self.GREETING)
        data = ep.read()
        if data:
            log("received", data)
            if ep.write(data, now):
                log("sent", data)

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        raise AssertionError("the fake device takes no faults of its own")


def emulator_class() -> Any:
    return FakeEmulator


def serve_emulator(playback: Any, spec: str | None, *, loop: bool = False
                   ) -> tuple[str | None, Any]:
    return spec, FakeEmulator()
