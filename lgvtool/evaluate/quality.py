"""The data quality of a log: what went wrong while it was recorded, from its own records.

Pure core (:func:`summarise`) over plain inputs, and one reader-side function
(:func:`read_quality`) that gathers them from a log: the ``/diagnostics`` events, the NAV's
valid/invalid pose flags and the receive times of the main topics.

- events counted by ``(source, kind)`` and level (a diagnostic's ``count`` is honoured);
- dropped MCU frames (``seq_gap`` events' ``missing_frames``), corrupt frames (bad checksum
  or length), bytes skipped while resynchronising;
- NAV poll replies without a position (``valid = false`` on ``/nav/pose``) and requests that
  got no reply;
- gaps: intervals between consecutive messages of a topic longer than
  ``max(GAP_FACTOR x its median interval, GAP_MIN_S)``, with their start and length.

Times are s after the log's start (``t0``).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.json_types import JSONObject, JSONRecord, as_int, member_or

if TYPE_CHECKING:
    from lgvtool.evaluate.evaluation import EvaluationResult
    from lgvtool.log import LogReader

__all__ = ["GAP_FACTOR", "GAP_MIN_S", "DataQuality", "Gap", "QualityInputs", "find_gaps",
           "log_quality", "quality_of_log", "read_quality", "summarise"]

GAP_FACTOR = 3.0
"""A gap is an interval longer than this many median intervals of its topic ..."""
GAP_MIN_S = 0.25
"""... and longer than this, s."""

#: decoder kinds that mean a frame arrived corrupt
CORRUPT_KINDS = frozenset({"bad_checksum", "bad_length", "bad_frame", "bad_version"})
#: topics whose gaps are looked for
GAP_TOPICS = ("/mcu/frame", "/odom/twist", "/nav/pose", "/nav/reflectors")


@dataclass(frozen=True)
class Gap:
    """A silence on ``topic``: from ``start`` (s after t0) for ``length`` s."""

    topic: str
    start: float
    length: float


@dataclass
class DataQuality:
    """What :func:`summarise` finds (see the module docstring). ``events`` holds per event
    ``(t s, source, kind, level, count)`` for the timeline."""

    t0: float
    duration: float
    by_kind: dict[tuple[str, str], int] = field(default_factory=dict)
    by_level: dict[int, int] = field(default_factory=dict)
    dropped_frames: int = 0
    corrupt_frames: dict[str, int] = field(default_factory=dict)
    skipped_bytes: int = 0
    nav_replies: int = 0
    nav_no_position: int = 0
    nav_unanswered: int = 0
    gaps: list[Gap] = field(default_factory=list)
    events: list[tuple[float, str, str, int, int]] = field(default_factory=list)

    @property
    def diagnostics(self) -> int:
        """Events in all (each diagnostic's count included)."""
        return sum(self.by_kind.values())

    @property
    def any(self) -> bool:
        """True when there is anything to report."""
        return bool(self.by_kind or self.nav_no_position or self.gaps)


def find_gaps(topic: str, t: NDArray[np.float64], *, factor: float = GAP_FACTOR,
              min_s: float = GAP_MIN_S) -> list[Gap]:
    """The gaps of one topic given its message times (s, sorted)."""
    if len(t) < 3:
        return []
    dt = np.diff(t)
    limit = max(factor * float(np.median(dt)), min_s)
    idx = np.nonzero(dt > limit)[0]
    return [Gap(topic, float(t[i]), float(dt[i])) for i in idx.tolist()]


def summarise(diagnostics: Sequence[JSONRecord], *, t0: float, duration: float,
              nav_valid: Sequence[bool] | NDArray[np.bool_] = (),
              topic_times: Mapping[str, NDArray[np.float64]] | None = None) -> DataQuality:
    """The data quality from ``/diagnostics`` dicts, the NAV poses' ``valid`` flags and the
    message times (s since the epoch) of the topics to look for gaps in."""
    q = DataQuality(t0=t0, duration=duration)
    for d in diagnostics:
        source, kind = str(d.get("source", "?")), str(d.get("kind", "?"))
        level = as_int(d.get("level", 0))
        n = max(as_int(d.get("count", 1) or 1), 1)
        details = d.get("details") or {}
        ts = d.get("timestamp") or {}
        t = (as_int(member_or(ts, "sec", 0)) + as_int(member_or(ts, "nsec", 0)) * 1e-9) - t0
        q.by_kind[(source, kind)] = q.by_kind.get((source, kind), 0) + n
        q.by_level[level] = q.by_level.get(level, 0) + n
        q.events.append((t, source, kind, level, n))
        if kind == "seq_gap":
            q.dropped_frames += as_int(member_or(details, "missing_frames", n))
        elif kind in CORRUPT_KINDS:
            q.corrupt_frames[source] = q.corrupt_frames.get(source, 0) + n
        elif kind == "bytes_skipped":
            q.skipped_bytes += as_int(member_or(details, "skipped_bytes", 0))
        elif kind == "unanswered":
            q.nav_unanswered += n
    valid = np.asarray(nav_valid, dtype=bool)
    q.nav_replies = len(valid)
    q.nav_no_position = int((~valid).sum())
    for topic, times in (topic_times or {}).items():
        for g in find_gaps(topic, np.asarray(times, dtype=np.float64)):
            q.gaps.append(Gap(g.topic, g.start - t0, g.length))
    q.gaps.sort(key=lambda g: g.start)
    q.events.sort()
    return q


class QualityInputs:
    """:func:`summarise`'s inputs gathered from a log's chunks as they are read (``add``, one
    chunk's undecoded messages of :attr:`topics` at a time): the diagnostics, the NAV poses'
    valid flags and the receive times of :data:`GAP_TOPICS`; never the bytes of the (100 Hz)
    MCU frames of the whole log."""

    #: a topic's receive times are joined into one array once this many pieces are held
    JOIN = 256

    def __init__(self, reader: LogReader) -> None:
        from lgvtool.log import topics

        #: the topics to read (those of the log)
        self.topics = [t for t in (topics.DIAGNOSTICS, topics.NAV_POSE, *GAP_TOPICS)
                       if reader.has_topic(t)]
        self._diags: list[JSONObject] = []
        self._valid: list[bool] = []
        self._stamps: dict[str, list[NDArray[np.int64]]] = {}

    def add(self, block: Mapping[str, tuple[NDArray[np.int64], list[bytes]]]) -> None:
        """Take one chunk's messages (other topics than :attr:`topics` are passed over)."""
        import orjson

        from lgvtool.log import topics

        for topic, (log_ns, raw) in block.items():
            if topic == topics.DIAGNOSTICS:
                self._diags.extend(orjson.loads(b) for b in raw)
                continue
            if topic not in GAP_TOPICS:
                continue
            if topic == topics.NAV_POSE:
                self._valid.extend(bool(orjson.loads(b).get("valid")) for b in raw)
            parts = self._stamps.setdefault(topic, [])
            parts.append(np.asarray(log_ns, dtype=np.int64))
            if len(parts) >= self.JOIN:  # few large arrays, however small the chunks
                parts[:] = [np.concatenate(parts)]

    def quality(self, reader: LogReader, t0: float | None = None) -> DataQuality:
        """The data quality of what was added, times counted from ``t0`` (s since the epoch;
        default: the log's first message); the topics' spans come from ``reader``'s chunk
        indexes, so the chunks must have been read (checked) first."""
        from lgvtool.log import topics

        infos = reader.topics()
        starts = [i.start_ns for i in infos.values() if i.count]
        ends = [i.end_ns for i in infos.values() if i.count]
        first = min(starts) * 1e-9 if starts else 0.0
        start = first if t0 is None else t0
        duration = (max(ends) * 1e-9 - start) if ends else 0.0
        times: dict[str, NDArray[np.float64]] = {}
        nav_valid = np.array(self._valid, dtype=bool)
        for topic, parts in self._stamps.items():
            t = np.concatenate(parts)
            order = np.argsort(t, kind="stable")
            if topic == topics.NAV_POSE:
                nav_valid = nav_valid[order]
            times[topic] = t[order].astype(np.float64) * 1e-9
        return summarise(self._diags, t0=start, duration=duration, nav_valid=nav_valid,
                         topic_times=times)


def read_quality(reader: LogReader, t0: float | None = None) -> DataQuality:
    """Gather :func:`summarise`'s inputs from a log (``t0``: s since the epoch that times are
    counted from; default: the log's first message)."""
    inputs = QualityInputs(reader)
    # one chunk at a time; after this pass, which checked the chunks, the topics' spans come
    # from the indexes
    for block in reader.raw_column_chunks(inputs.topics):
        inputs.add(block)
    return inputs.quality(reader, t0)


def quality_of_log(path: str, t0: float | None = None) -> DataQuality | None:
    """:func:`read_quality` of the log at ``path``, cached per file (path, size, mtime) and
    ``t0``; None when ``path`` is not a readable lgvtool log."""
    import os

    try:
        st = os.stat(path)
    except OSError:
        return None
    return _cached_quality(path, st.st_size, st.st_mtime_ns, t0)


def log_quality(res: EvaluationResult) -> DataQuality | None:
    """The data quality of an evaluated log: the one gathered while it was read, else
    :func:`quality_of_log` of its path (None without a path)."""
    if res.quality is not None:
        return res.quality
    return quality_of_log(res.path, res.t0) if res.path else None


@functools.lru_cache(maxsize=16)
def _cached_quality(path: str, size: int, mtime_ns: int, t0: float | None) -> DataQuality | None:
    import warnings

    from lgvtool.errors import LgvError
    from lgvtool.log import LogReader

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return read_quality(LogReader(path), t0)
    except (LgvError, OSError, ValueError, KeyError, TypeError, AttributeError):
        return None
