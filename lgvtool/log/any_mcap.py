"""What any MCAP file holds, lgvtool's or not: topics, schemas, encodings, counts, times.

``lgvtool info`` uses it for an MCAP file that is not an lgvtool log (a ROS 2 bag, a protobuf
recording): it describes the file and says that it is not an lgvtool log, so the user can see
what the file carries. Read with the ``mcap`` package's own reader, the summary section when
the file has one, else by scanning every message (a file cut off by a crash).
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

from lgvtool.errors import LogFormatError

if TYPE_CHECKING:
    from typing import BinaryIO

    from mcap.summary import Summary


class TopicSummary(TypedDict):
    """A topic's row of :func:`describe_any` (without the topic, its key): its schema and
    encodings, message count, first and last log time (s since the Unix epoch; None before
    its first message)."""

    schema: str
    schema_encoding: str
    message_encoding: str
    count: int
    first_time_s: float | None
    last_time_s: float | None


class TopicRow(TopicSummary):
    """One topic of a file: its name and its :class:`TopicSummary`."""

    topic: str


class McapDescription(TypedDict):
    """What :func:`describe_any` finds in a file: sizes in bytes, times in s since the
    Unix epoch (None without messages)."""

    file: str
    size_bytes: int
    lgvtool_log: bool
    profile: str
    library: str
    message_count: int
    start_time_s: float | None
    end_time_s: float | None
    topics: dict[str, TopicSummary]
    metadata: list[str]


def _topic_rows(summary: Summary) -> dict[int, TopicRow]:
    rows: dict[int, TopicRow] = {}
    for cid, ch in summary.channels.items():
        schema = summary.schemas.get(ch.schema_id)
        rows[cid] = {"topic": ch.topic, "schema": schema.name if schema else "",
                     "schema_encoding": schema.encoding if schema else "",
                     "message_encoding": ch.message_encoding, "count": 0,
                     "first_time_s": None, "last_time_s": None}
    return rows


def describe_any(path: str | Path) -> McapDescription:
    """Stable-key summary of any MCAP file (``lgvtool info`` on a foreign file).

    Keys: ``file``, ``size_bytes``, ``lgvtool_log`` (False), ``profile`` and ``library`` of the
    header, ``message_count``, ``topics`` (topic -> schema, schema_encoding,
    message_encoding, count, first_time_s, last_time_s), ``metadata`` (names).

    :raises LogFormatError: the file is not a readable MCAP file.
    """
    from mcap.exceptions import McapError
    from mcap.reader import make_reader

    p = Path(path)
    try:
        with p.open("rb") as f:
            reader = make_reader(f)
            header = reader.get_header()
            summary = reader.get_summary()
            rows: dict[str, TopicRow] = {}
            if summary is not None and summary.statistics is not None:
                by_id = _topic_rows(summary)
                for cid, n in summary.statistics.channel_message_counts.items():
                    if cid in by_id:
                        by_id[cid]["count"] = n
                rows = {r["topic"]: r for r in by_id.values()}
                metadata = [m.name for m in summary.metadata_indexes]
                total = summary.statistics.message_count
                span = (summary.statistics.message_start_time, summary.statistics.message_end_time)
            else:
                f.seek(0)
                rows, metadata, total, span = _scan(f)
    except (McapError, OSError, ValueError, KeyError, EOFError, struct.error) as exc:
        # struct.error: the mcap package's reader on a file cut inside its first record
        why = "cut off inside a record" if isinstance(exc, struct.error) else type(exc).__name__
        raise LogFormatError(f"{p}: not a readable MCAP file ({why})") from None
    return {"file": str(p), "size_bytes": p.stat().st_size, "lgvtool_log": False,
            "profile": header.profile, "library": header.library, "message_count": total,
            "start_time_s": span[0] / 1e9 if total else None,
            "end_time_s": span[1] / 1e9 if total else None,
            "topics": {t: _without_topic(r) for t, r in rows.items()},
            "metadata": metadata}


def _without_topic(row: TopicRow) -> TopicSummary:
    """``row`` without its topic, the key it is listed under."""
    return {"schema": row["schema"], "schema_encoding": row["schema_encoding"],
            "message_encoding": row["message_encoding"], "count": row["count"],
            "first_time_s": row["first_time_s"], "last_time_s": row["last_time_s"]}


def _scan(f: BinaryIO) -> tuple[dict[str, TopicRow], list[str], int, tuple[int, int]]:
    """Count messages by streaming the file (no summary section); stops at a cut-off end."""
    from mcap.exceptions import McapError
    from mcap.records import Channel, Message, Metadata, Schema
    from mcap.stream_reader import StreamReader

    schemas: dict[int, Schema] = {}
    channels: dict[int, TopicRow] = {}
    metadata: list[str] = []
    total, first, last = 0, 0, 0
    try:
        for record in StreamReader(f, validate_crcs=True).records:
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                s = schemas.get(record.schema_id)
                channels[record.id] = {"topic": record.topic, "schema": s.name if s else "",
                                       "schema_encoding": s.encoding if s else "",
                                       "message_encoding": record.message_encoding, "count": 0,
                                       "first_time_s": None, "last_time_s": None}
            elif isinstance(record, Message) and record.channel_id in channels:
                row = channels[record.channel_id]
                row["count"] += 1
                t = record.log_time / 1e9
                row["first_time_s"] = t if row["first_time_s"] is None else row["first_time_s"]
                row["last_time_s"] = t
                first = record.log_time if total == 0 else min(first, record.log_time)
                last = max(last, record.log_time)
                total += 1
            elif isinstance(record, Metadata):
                metadata.append(record.name)
    except (McapError, EOFError, ValueError, struct.error):
        pass  # a file cut off: what was read so far is described
    return {r["topic"]: r for r in channels.values()}, metadata, total, (first, last)


def format_any(d: McapDescription) -> str:
    """The summary as a terminal table (strings from the file made printable)."""
    from lgvtool.outputs import printable

    lines = [f"file:      {d['file']} ({d['size_bytes']} bytes)",
             f"format:    MCAP, profile {d['profile'] or 'none'!r}, written by "
             f"{d['library'] or 'an unnamed library'}: not an lgvtool log (no lgvtool metadata "
             "and no lgvtool topics)",
             f"messages:  {d['message_count']}", ""]
    rows: list[tuple[str, ...]] = [("topic", "schema", "schema encoding", "message encoding",
                                    "count")]
    rows += [tuple(printable(str(v)) for v in (t, r["schema"], r["schema_encoding"],
                                              r["message_encoding"], r["count"]))
             for t, r in d["topics"].items()]
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    for k, r in enumerate(rows):
        lines.append("  ".join(v.rjust(w) if c == 4 else v.ljust(w)
                               for c, (v, w) in enumerate(zip(r, widths, strict=True))).rstrip())
        if k == 0:
            lines.append("  ".join("-" * w for w in widths))
    if d["metadata"]:
        lines += ["", "metadata:  " + ", ".join(d["metadata"])]
    return "\n".join(lines)
