"""Re-decode the raw device traffic of a log into fresh decoded channels (``lgvtool decode``).

Every device family's raw topics go through its log decoder, found in
:mod:`lgvtool.devices.device_registry` and driven by :mod:`lgvtool.devices.log_decoding` (the same
path the simulator's log writer and the recorder use).
"""

from __future__ import annotations

import base64
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import orjson

from lgvtool.app.job_output import JobOutput
from lgvtool.errors import LogFormatError
from lgvtool.json_types import JSONObject
from lgvtool.log import topics
from lgvtool.log.messages import kind_of_log_message

if TYPE_CHECKING:
    from lgvtool.log import LogReader

__all__ = ["DecodeOptions", "DecodeReport", "decode_file", "decode_log"]


@dataclass
class DecodeReport:
    """What :func:`decode_log` did. Counts are dimensionless; stats keys as ``DecoderStats``.

    ``sections`` holds each device family's part (family -> its decoder's report, e.g. the MCU's
    ``{"frames", "stats"}``), in registry order; the properties read the MCU's and NAV200's.
    """

    input: str
    output: str
    diagnostics: int = 0
    #: the input's messages written unchanged (the raw traffic among them)
    copied: int = 0
    sections: dict[str, dict[str, Any]] = field(default_factory=dict)
    lines: list[str] = field(default_factory=list)
    """The families' summary lines."""

    @property
    def mcu_frames(self) -> int:
        """MCU frames decoded."""
        return int(self.sections.get("mcu", {}).get("frames", 0))

    @property
    def mcu_stats(self) -> dict[str, int]:
        """The MCU decoder's counters (empty: no MCU traffic)."""
        return dict(self.sections.get("mcu", {}).get("stats", {}))

    @property
    def nav_replies(self) -> int:
        """NAV200 replies decoded."""
        return int(self.sections.get("nav200", {}).get("replies", 0))

    @property
    def nav_poses(self) -> int:
        """NAV200 pose replies decoded."""
        return int(self.sections.get("nav200", {}).get("poses", 0))

    @property
    def nav_requests(self) -> int:
        """NAV200 requests decoded."""
        return int(self.sections.get("nav200", {}).get("requests", 0))

    @property
    def nav_stats(self) -> dict[str, int]:
        """The NAV200 reply stream's counters (empty: no NAV200 traffic)."""
        return dict(self.sections.get("nav200", {}).get("stats", {}))

    @property
    def nav_request_stats(self) -> dict[str, int]:
        """The NAV200 request stream's counters (empty: no NAV200 traffic)."""
        return dict(self.sections.get("nav200", {}).get("request_stats", {}))

    def as_dict(self) -> JSONObject:
        """JSON-able report with stable keys."""
        return {"input": self.input, "output": self.output, **self.sections,
                "diagnostics": self.diagnostics, "copied": self.copied}

    def summary(self) -> str:
        """Human-readable lines: frames decoded and error counts per device."""
        return "\n".join([f"decoded {self.input} -> {self.output}", *self.lines,
                          f"{self.diagnostics} diagnostics written, {self.copied} messages "
                          "copied"])


def _raw_bytes(data: bytes) -> bytes:
    try:
        return base64.b64decode(orjson.loads(data)["data"], validate=True)
    except (ValueError, KeyError, TypeError) as exc:
        raise LogFormatError(f"unreadable raw-bytes message: {exc}") from None


def _is_decoder_diagnostic(topic: str, data: bytes,
                           regenerated: Mapping[str, frozenset[str]]) -> bool:
    """Whether ``data`` on ``topic`` is a diagnostic (or its foxglove.Log mirror, whose text
    starts with ``[kind]``) of a source and kind in ``regenerated`` (source -> kinds)."""
    if topic not in (topics.DIAGNOSTICS, topics.DIAGNOSTICS_LOG):
        return False
    try:
        msg = orjson.loads(data)
    except orjson.JSONDecodeError:
        return False
    if not isinstance(msg, dict):
        return False
    if topic == topics.DIAGNOSTICS:
        source, kind = msg.get("source"), msg.get("kind")
    else:
        source, kind = msg.get("name"), kind_of_log_message(msg)
    return isinstance(source, str) and isinstance(kind, str) and kind in regenerated.get(
        source, frozenset())


def decode_log(reader: LogReader, output: str | Path, compression: str = "zstd") -> DecodeReport:
    """Write ``output``: ``reader``'s log with its decoded channels rebuilt from its raw traffic.

    Each device family with raw traffic in the log is decoded by its log decoder: ``/mcu/rx``
    into ``/mcu/frame``; ``/nav200/tx`` and ``/nav200/rx`` into ``/nav/pose``; ``/nav350/tx``
    and ``/nav350/rx`` into ``/nav/pose`` and ``/nav/reflectors``; the decoders' errors and gaps
    go to ``/diagnostics``. A family's old decoded channels and the old diagnostics its decoder
    writes anew (its sources' diagnostics of the kinds its events have) are dropped only when
    its raw traffic is in the log. Every other message (the raw traffic, the recorder's link
    and session events among them) and the metadata are copied. Decoded messages get the log
    time of the raw chunk that completed them (what the end of the log completes: the time of
    the family's last chunk).

    :raises MissingDataError: the log has no raw device traffic.
    """
    from lgvtool.devices.device_registry import registrations
    from lgvtool.devices.log_decoding import WriterOutput, decode_chunk, finish_decoding
    from lgvtool.errors import MissingDataError
    from lgvtool.log import LogWriter

    present = set(reader.topic_names())
    regs = registrations()
    decoders: dict[str, Any] = {}
    for reg in regs:
        if present & set(reg.RAW_TOPICS):
            decoders[reg.DEVICE] = reg.log_decoder(reader.metadata)
    if not decoders:
        raw = ", ".join(t for reg in regs for t in reg.RAW_TOPICS)
        raise MissingDataError(f"{reader.path}: no raw device traffic to decode ({raw})")
    by_topic = {t: decoders[reg.DEVICE] for reg in regs if reg.DEVICE in decoders
                for t in reg.RAW_TOPICS}
    replaced: set[str] = set().union(*(d.decoded_topics for d in decoders.values()))
    regenerated: dict[str, frozenset[str]] = {}
    for d in decoders.values():
        for source in d.sources:
            regenerated[source] = regenerated.get(source, frozenset()) | d.event_kinds

    report = DecodeReport(str(reader.path), str(output))
    with LogWriter(output, source="decode", compression=compression) as writer:
        out = WriterOutput(writer)
        for name, record in reader.metadata.items():
            if name != "lgvtool":
                writer.add_metadata(name, record)
        for m in reader.raw_messages():
            if m.topic in replaced or _is_decoder_diagnostic(m.topic, m.data, regenerated):
                continue
            if m.schema:
                writer.channel_id(m.topic, m.schema)
            writer.write_encoded(m.topic, m.data, m.log_time_ns, m.publish_time_ns)
            report.copied += 1
            decoder = by_topic.get(m.topic)
            if decoder is not None:
                report.diagnostics += decode_chunk(decoder, m.topic, _raw_bytes(m.data),
                                                   m.log_time_ns, out)
        metadata: dict[str, Any] = {}
        for reg in regs:
            decoder = decoders.get(reg.DEVICE)
            if decoder is None:
                if reg.ABSENT_REPORT is not None:
                    report.sections[reg.DEVICE] = dict(reg.ABSENT_REPORT)
                metadata.update(reg.ABSENT_METADATA)
                continue
            report.diagnostics += finish_decoding(decoder, out)
            report.sections[reg.DEVICE] = decoder.report()
            report.lines.extend(decoder.summary())
            metadata.update(decoder.stats_metadata())
        writer.add_metadata("decode", metadata)
    return report


@dataclass(frozen=True, slots=True)
class DecodeOptions:
    """What :func:`decode_file` decodes, and into what (``lgvtool decode``)."""

    log: str
    """The log (MCAP) whose raw device traffic is decoded."""
    output: str
    """The re-decoded log to write (through a temporary file); an existing one is replaced
    only with :attr:`force`, an input never."""
    compression: str = "zstd"
    """Chunk compression of :attr:`output`: zstd, lz4 or none."""
    force: bool = False
    """Replace an existing :attr:`output`."""


def decode_file(options: DecodeOptions) -> JobOutput:
    """``lgvtool decode``: :func:`decode_log` of the ``options``' log into its output (see
    :class:`DecodeOptions`). The document is :meth:`DecodeReport.as_dict`, the text its
    summary; the warnings are the reader's (e.g. corrupt chunks skipped).

    :raises InputError: (exit 2) an unreadable log, no raw device traffic, a refused output.
    """
    import warnings

    from lgvtool.log import LogReader
    from lgvtool.outputs import atomic_output, guard_output, printable

    guard_output(options.output, [options.log], force=options.force)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(options.log)
    with atomic_output(options.output) as tmp:
        report = decode_log(reader, tmp, compression=options.compression)
    report.output = options.output
    return JobOutput(report.as_dict(), printable(report.summary()),
                     warnings=list(reader.warnings))
