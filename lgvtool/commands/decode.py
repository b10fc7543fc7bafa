"""``lgvtool decode``: re-decode the raw device traffic of a log into fresh decoded channels."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from lgvtool.options import compression_option, force_option, warn

if TYPE_CHECKING:
    from lgvtool.log import LogReader, LogWriter
    from lgvtool.wire.decode_events import DecodeEvent

#: Diagnostic sources that the decoders produce; their old events are replaced.
DECODER_SOURCES = ("mcu", "nav200", "nav350")


@dataclass
class DecodeReport:
    """What :func:`decode_log` did. Counts are dimensionless; stats keys as ``DecoderStats``."""

    input: str
    output: str
    mcu_frames: int = 0
    nav_replies: int = 0
    nav_poses: int = 0
    nav_requests: int = 0
    diagnostics: int = 0
    copied: int = 0
    mcu_stats: dict[str, int] = field(default_factory=dict)
    nav_stats: dict[str, int] = field(default_factory=dict)
    nav_request_stats: dict[str, int] = field(default_factory=dict)
    nav350: dict[str, Any] = field(default_factory=dict)
    """NAV350: poses, scans, landmarks and the reply stream's stats (empty: no NAV350)."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-able report with stable keys."""
        return {
            "input": self.input,
            "output": self.output,
            "mcu": {"frames": self.mcu_frames, "stats": self.mcu_stats},
            "nav200": {
                "replies": self.nav_replies,
                "poses": self.nav_poses,
                "requests": self.nav_requests,
                "stats": self.nav_stats,
                "request_stats": self.nav_request_stats,
            },
            **({"nav350": self.nav350} if self.nav350 else {}),
            "diagnostics": self.diagnostics,
            "copied": self.copied,
        }

    def summary(self) -> str:
        """Human-readable lines: frames decoded and error counts per device."""

        def errors(stats: dict[str, int]) -> str:
            from lgvtool.wire.decode_events import DecoderStats

            kinds = DecoderStats.ERROR_KINDS
            keys = ("bytes_skipped", *kinds[: kinds.index("seq_gaps") + 1], "frames_missing",
                    *kinds[kinds.index("seq_gaps") + 1 :])
            found = [f"{k} {stats[k]}" for k in keys if stats.get(k)]
            return ", ".join(found) if found else "none"

        lines = [f"decoded {self.input} -> {self.output}"]
        if self.mcu_stats:
            lines.append(f"mcu: {self.mcu_frames} frames; errors: {errors(self.mcu_stats)}")
        if self.nav_stats or self.nav_request_stats:
            lines.append(
                f"nav200: {self.nav_replies} replies ({self.nav_poses} poses), "
                f"{self.nav_requests} requests; errors: {errors(self.nav_stats)}"
            )
            if any(
                v
                for k, v in self.nav_request_stats.items()
                if k not in ("bytes_received", "bytes_decoded", "frames")
            ):
                lines.append(f"nav200 requests: errors: {errors(self.nav_request_stats)}")
        if self.nav350:
            n = self.nav350
            lines.append(f"nav350: {n['poses']} poses, {n['scans']} scans ({n['landmarks']} "
                         f"landmarks); errors: {errors(n['stats'])}")
        lines.append(f"{self.diagnostics} diagnostics written, {self.copied} messages copied")
        return "\n".join(lines)


def _raw_bytes(data: bytes) -> bytes:
    import base64

    import orjson

    from lgvtool.errors import LogFormatError

    try:
        return base64.b64decode(orjson.loads(data)["data"], validate=True)
    except (ValueError, KeyError, TypeError) as exc:
        raise LogFormatError(f"unreadable raw-bytes message: {exc}") from None


def _write_events(writer: LogWriter, events: list[DecodeEvent], log_time_ns: int) -> int:
    for event in events:
        writer.write_diagnostic(
            event.source,
            event.kind,
            event.message,
            log_time_ns,
            level=event.level,
            count=event.count,
            details=event.details,
        )
    return len(events)


def _is_decoder_diagnostic(topic: str, data: bytes, sources: set[str]) -> bool:
    import orjson

    from lgvtool.log import topics

    if topic not in (topics.DIAGNOSTICS, topics.DIAGNOSTICS_LOG):
        return False
    try:
        msg = orjson.loads(data)
    except orjson.JSONDecodeError:
        return False
    source = msg.get("source" if topic == topics.DIAGNOSTICS else "name")
    return isinstance(source, str) and source in sources


def decode_log(reader: LogReader, output: str | Path, compression: str = "zstd") -> DecodeReport:
    """Write ``output``: ``reader``'s log with its decoded channels rebuilt from its raw traffic.

    ``/mcu/rx`` is decoded into ``/mcu/frame``; ``/nav200/tx`` and ``/nav200/rx`` through a host
    session into ``/nav/pose``; the decoders' errors and gaps go to ``/diagnostics``. A device's
    old decoded channel and old decoder diagnostics are dropped only when its raw channel is in
    the log. Every other message and the metadata are copied. Decoded messages get the log time
    of the raw chunk that completed them.
    """
    from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
    from lgvtool.devices.nav200.nav200_commands import Reply
    from lgvtool.devices.nav200.nav200_matcher import Nav200ReplyMatcher
    from lgvtool.devices.nav200.nav200_payloads import Pose
    from lgvtool.errors import MissingDataError
    from lgvtool.log import LogWriter, topics
    from lgvtool.log.messages import mcu_frame_message, nav_pose_message
    from lgvtool.timestamps import stamp as timestamp_from_ns

    present = set(reader.topic_names())
    has_mcu = topics.MCU_RX in present
    has_nav = topics.NAV_RX in present or topics.NAV_TX in present
    has_nav350 = topics.NAV350_RX in present
    if not (has_mcu or has_nav or has_nav350):
        raise MissingDataError(
            f"{reader.path}: no raw device traffic to decode "
            f"({topics.MCU_RX}, {topics.NAV_RX}, {topics.NAV_TX})"
        )
    replaced: set[str] = set()
    sources: set[str] = set()
    if has_mcu:
        replaced.add(topics.MCU_FRAME)
        sources.add("mcu")
    if has_nav:
        replaced.add(topics.NAV_POSE)
        sources.add("nav200")
    if has_nav350:
        from lgvtool.devices.nav350.nav350_logdecode import Nav350LogDecoder

        ids = reader.metadata.get("device.nav350", {}).get("global_ids")
        nav350 = Nav350LogDecoder(map_id=None if not isinstance(ids, dict) else
                                  {int(k): int(v) for k, v in ids.items()})
        replaced |= {topics.NAV_POSE, topics.NAV_REFLECTORS}
        sources.add("nav350")

    report = DecodeReport(str(reader.path), str(output))
    mcu = McuStreamDecoder()
    nav = Nav200ReplyMatcher()
    last_mcu_ns = last_nav_ns = 0
    with LogWriter(output, source="decode", compression=compression) as writer:
        for name, record in reader.metadata.items():
            if name != "lgvtool":
                writer.add_metadata(name, record)
        for m in reader.raw_messages():
            if m.topic in replaced or _is_decoder_diagnostic(m.topic, m.data, sources):
                continue
            if m.schema:
                writer.channel_id(m.topic, m.schema)
            writer.write_encoded(m.topic, m.data, m.log_time_ns, m.publish_time_ns)
            t = m.log_time_ns
            stamp = timestamp_from_ns(t)
            if m.topic == topics.MCU_RX:
                for frame in mcu.feed(_raw_bytes(m.data)):
                    writer.write(topics.MCU_FRAME, mcu_frame_message(frame, stamp), t)
                    report.mcu_frames += 1
                report.diagnostics += _write_events(writer, mcu.pop_events(), t)
                last_mcu_ns = t
            elif m.topic == topics.NAV_TX:
                report.nav_requests += len(nav.sent(_raw_bytes(m.data)))
                report.diagnostics += _write_events(writer, nav.pop_events(), t)
                last_nav_ns = t
            elif m.topic == topics.NAV_RX:
                for exchange in nav.feed(_raw_bytes(m.data)):
                    report.nav_replies += 1
                    reply = exchange.reply
                    if isinstance(reply, Reply) and isinstance(reply.payload, Pose):
                        writer.write(topics.NAV_POSE, nav_pose_message(reply, stamp), t)
                        report.nav_poses += 1
                report.diagnostics += _write_events(writer, nav.pop_events(), t)
                last_nav_ns = t
            elif has_nav350 and m.topic in (topics.NAV350_TX, topics.NAV350_RX):
                feed = nav350.sent if m.topic == topics.NAV350_TX else nav350.received
                feed(_raw_bytes(m.data), t)
                for topic, message, at in nav350.pop_messages():
                    writer.write(topic, message, at)
                report.diagnostics += _write_events(writer, nav350.pop_events(), t)
            else:
                report.copied += 1
        if has_nav350:
            nav350.flush()
            report.nav350 = {"poses": nav350.poses, "scans": nav350.scans,
                             "landmarks": nav350.landmarks, "stats": nav350.stats.as_dict()}
        if has_mcu:
            for frame in mcu.flush():
                writer.write(
                    topics.MCU_FRAME,
                    mcu_frame_message(frame, timestamp_from_ns(last_mcu_ns)),
                    last_mcu_ns,
                )
                report.mcu_frames += 1
            report.diagnostics += _write_events(writer, mcu.pop_events(), last_mcu_ns)
            report.mcu_stats = mcu.stats.as_dict()
        if has_nav:
            for exchange in nav.flush():
                report.nav_replies += 1
                reply = exchange.reply
                if isinstance(reply, Reply) and isinstance(reply.payload, Pose):
                    writer.write(
                        topics.NAV_POSE,
                        nav_pose_message(reply, timestamp_from_ns(last_nav_ns)),
                        last_nav_ns,
                    )
                    report.nav_poses += 1
            report.diagnostics += _write_events(writer, nav.pop_events(), last_nav_ns)
            report.nav_stats = nav.stats.as_dict()
            report.nav_request_stats = nav.request_stats.as_dict()
        writer.add_metadata(
            "decode",
            {
                "mcu": report.mcu_stats,
                "nav200": report.nav_stats,
                "nav200_requests": report.nav_request_stats,
                **({"nav350": report.nav350["stats"]} if report.nav350 else {}),
            },
        )
    return report


@click.command()
@click.argument("log", type=click.Path(dir_okay=False, path_type=str))
@click.option(
    "-o",
    "--output",
    required=True,
    type=click.Path(dir_okay=False, path_type=str),
    help="The re-decoded log to write (must differ from LOG).",
)
@compression_option()
@force_option
@click.option("--json", "as_json", is_flag=True, help="Print the counts as JSON.")
def decode(log: str, output: str, compression: str, force: bool, as_json: bool) -> None:
    """Re-decode the raw traffic of LOG (/mcu/rx, /nav200/tx, /nav200/rx) into fresh
    /mcu/frame, /nav/pose and /diagnostics channels in OUTPUT, copying every other channel and
    the metadata; print the frames decoded and the error counts per device (bad checksums,
    bad lengths, skipped bytes, truncated frames, sequence gaps, NAV200 error replies, ...).

    Use it after a decoder fix: raw bytes are always logged, so nothing is lost.
    """
    import json
    import warnings

    from lgvtool.log import LogReader
    from lgvtool.outputs import atomic_output, guard_output, printable

    guard_output(output, [log], force=force)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    if not as_json:
        for w in reader.warnings:
            warn(w)
    with atomic_output(output) as tmp:
        report = decode_log(reader, tmp, compression=compression)
    report.output = output
    click.echo(json.dumps(report.as_dict(), indent=2) if as_json else printable(report.summary()))
