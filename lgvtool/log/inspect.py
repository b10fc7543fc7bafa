"""The facts ``lgvtool info`` shows about a log, as a JSON-able dict with stable keys."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import TypedDict

from lgvtool.json_types import JSON
from lgvtool.log.reader import LogReader


class TopicFacts(TypedDict):
    """One topic of a log: its schema, message count, mean rate (Hz), first and last log
    time (s since the Unix epoch) and largest gap (s)."""

    schema: str
    count: int
    rate_hz: float
    first_time_s: float
    last_time_s: float
    max_gap_s: float


class LogFacts(TypedDict):
    """What :func:`describe` finds in a log: sizes in bytes, times in s since the Unix epoch
    (None without messages), the lgvtool metadata's versions and source (None when absent),
    every metadata record."""

    file: str
    size_bytes: int
    complete: bool
    salvaged: bool
    corrupt_chunks: int
    warnings: list[str]
    format_version: JSON
    tool_version: JSON
    source: JSON
    start_time_s: float | None
    end_time_s: float | None
    duration_s: float
    message_count: int
    topics: dict[str, TopicFacts]
    metadata: dict[str, dict[str, JSON]]


def _iso(ns: int) -> str:
    return datetime.fromtimestamp(ns / 1e9, UTC).isoformat(timespec="milliseconds").replace(
        "+00:00", "Z")


def describe(reader: LogReader) -> LogFacts:
    """Stable-key summary of a log (documented in docs/log-format.md, ``info --json``)."""
    topics = reader.topics()
    reader.verify_chunks()  # also the chunks of no channel topics() reads
    start = min((i.start_ns for i in topics.values()), default=None)
    end = max((i.end_ns for i in topics.values()), default=None)
    meta = reader.metadata.get("lgvtool", {})
    return {
        "file": str(reader.path),
        "size_bytes": reader.size,
        "complete": reader.complete,
        "salvaged": not reader.complete,
        "corrupt_chunks": len(reader.corrupt_chunks),
        "warnings": list(reader.warnings),
        "format_version": meta.get("format_version"),
        "tool_version": meta.get("tool_version"),
        "source": meta.get("source"),
        "start_time_s": None if start is None else start / 1e9,
        "end_time_s": None if end is None else end / 1e9,
        "duration_s": 0.0 if start is None or end is None else (end - start) / 1e9,
        "message_count": sum(i.count for i in topics.values()),
        "topics": {
            name: {
                "schema": i.schema,
                "count": i.count,
                "rate_hz": round(i.rate_hz, 4),
                "first_time_s": i.start_ns / 1e9,
                "last_time_s": i.end_ns / 1e9,
                "max_gap_s": i.max_gap_ns / 1e9,
            }
            for name, i in topics.items()
        },
        "metadata": reader.metadata,
    }


def _short(value: object, width: int = 60) -> str:
    text = value if isinstance(value, str) else repr(value)
    return text if len(text) <= width else text[: width - 3] + "..."


def format_text(d: LogFacts) -> str:
    """The summary as a terminal table."""
    lines = [
        f"file:      {d['file']} ({d['size_bytes']} bytes, "
        + ("complete" if d["complete"] else "SALVAGED: incomplete file")
        + (f", {d['corrupt_chunks']} corrupt chunks skipped" if d.get("corrupt_chunks") else "")
        + ")",
        f"format:    {d['format_version']} (written by lgvtool {d['tool_version']}, "
        f"{d['source'] or 'unknown source'})",
    ]
    start, end = d["start_time_s"], d["end_time_s"]
    if start is not None:
        assert end is not None  # both are None, or neither: the log has messages
        lines.append(f"time:      {_iso(int(start * 1e9))} .. "
                     f"{_iso(int(end * 1e9))} ({d['duration_s']:.3f} s)")
    lines.append(f"messages:  {d['message_count']}")
    lines.append("")
    rows = [("topic", "schema", "count", "rate Hz", "first s", "last s", "max gap s")]
    t0 = d["start_time_s"] or 0.0
    for name, i in d["topics"].items():
        rows.append((name, i["schema"], str(i["count"]), f"{i['rate_hz']:.2f}",
                     f"{i['first_time_s'] - t0:.3f}", f"{i['last_time_s'] - t0:.3f}",
                     f"{i['max_gap_s']:.3f}"))
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    for k, r in enumerate(rows):
        lines.append("  ".join(v.ljust(w) if c < 2 else v.rjust(w)
                               for c, (v, w) in enumerate(zip(r, widths, strict=True))))
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    lines.append("")
    lines.append("metadata:")
    for name, record in d["metadata"].items():
        lines.append(f"  {name}:")
        for key, value in record.items():
            lines.append(f"    {key}: {_short(value)}")
    return "\n".join(lines)
