"""Rebuild a complete, indexed log from a broken one (``lgvtool recover``)."""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass
from pathlib import Path

from lgvtool.errors import InputError
from lgvtool.log.reader import LogReader
from lgvtool.log.writer import LogWriter


@dataclass(frozen=True)
class RecoveryReport:
    """What :func:`recover` saved. Sizes in bytes, times in s since the Unix epoch."""

    source_bytes: int
    intact_bytes: int
    messages: int
    topics: dict[str, int]
    first_s: float | None
    last_s: float | None
    was_complete: bool
    corrupt_chunks: int = 0

    def summary(self) -> str:
        """One human-readable line."""
        span = ""
        if self.first_s is not None and self.last_s is not None:
            span = f", {self.last_s - self.first_s:.1f} s of data"
        state = "the input was complete already" if self.was_complete else "the input was cut off"
        if self.corrupt_chunks:
            chunks = "chunk" if self.corrupt_chunks == 1 else "chunks"
            state += f"; {self.corrupt_chunks} corrupt {chunks} skipped"
        topics = "topic" if len(self.topics) == 1 else "topics"
        return (f"recovered {self.messages} messages on {len(self.topics)} {topics}{span} from "
                f"{self.intact_bytes} of {self.source_bytes} bytes ({state})")


def recover(src: str | Path, dst: str | Path, compression: str = "zstd") -> RecoveryReport:
    """Copy every intact message and metadata record of ``src`` into a complete log ``dst``."""
    src, dst = Path(src), Path(dst)
    if src.resolve() == dst.resolve():
        raise InputError("recover: the output must be a different file from the input")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(src)
    with LogWriter(dst, chunk_seconds=None, source="recover", compression=compression,
                   command=f"lgvtool recover {src.name}") as w:
        for name, record in reader.metadata.items():
            if name == "lgvtool":
                w.add_metadata("recovered_from", {**record, "file": src.name,
                                                  "complete": reader.complete})
                continue
            w.add_metadata(name, record)
        # the intact chunks' records copied as they are into new chunks (compressed as asked),
        # a run of chunks at a time
        n = w.copy_from(reader, metadata=False, verbatim=False)
    info = {t: i for t, i in reader.topics().items() if i.count}
    first = min((i.start_ns for i in info.values()), default=None)
    last = max((i.end_ns for i in info.values()), default=None)
    return RecoveryReport(
        source_bytes=reader.size, intact_bytes=reader.salvaged_bytes, messages=n,
        topics={t: i.count for t, i in info.items()},
        first_s=None if first is None else first / 1e9,
        last_s=None if last is None else last / 1e9, was_complete=reader.complete,
        corrupt_chunks=len(reader.corrupt_chunks),
    )


def report_json(report: RecoveryReport) -> str:
    """The report as JSON (keys as the dataclass fields)."""
    return json.dumps(report.__dict__, indent=2)
