"""What the estimators need from a log, read into arrays (:func:`load_log`).

Times are seconds relative to the first message read (``LogData.t0_ns``). Reflector scans are
kept as their JSON bytes (:class:`LazyScans`) until an estimator uses them, then decoded once,
or decoded as they are read when the caller says it will use them all.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from operator import itemgetter
from typing import TYPE_CHECKING, Any, NotRequired, TypedDict, TypeVar, overload

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Reflector, Vehicle
from lgvtool.errors import LogFormatError
from lgvtool.localize.motion import (
    Increments,
    MotionSettings,
    increments_from_mcu,
    increments_from_twist,
)
from lgvtool.localize.observations import RawScan, ScanBatch
from lgvtool.localize.packed import PackedBytes
from lgvtool.log.validate import flags, plausible_poses
from lgvtool.timestamps import message_stamps_ns
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.json_types import JSONRecord
    from lgvtool.log import LogReader
    from lgvtool.log.reader import RawBlock, Tap

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
#: an array of one field of decoded messages: its dtype (float, integer, boolean) is the
#: field's (its reader states which it expects)
Column = NDArray[np.generic]
#: a decoded message, as the log contract describes its topic
_M = TypeVar("_M")
_S = TypeVar("_S", bound=np.generic)
#: the scans as the view channels draw them (:meth:`LazyScans.decoded_columns`): log time
#: (ns), start (ns), count, then per reflector range (m), bearing (rad), id and time in scan (s)
ScanViewColumns = tuple[IntArray, IntArray, IntArray, FloatArray, FloatArray, IntArray,
                        FloatArray]


class ScanReflector(TypedDict):
    """One reflector of a /nav/reflectors message: ``range`` (m), ``bearing`` (rad),
    ``time_in_scan`` (s after the scan's start) and ``id``."""

    range: float
    bearing: float
    time_in_scan: float
    id: int


class ScanMessage(TypedDict):
    """What :func:`scan_columns` reads of a /nav/reflectors message: its reflectors and the
    head's revolution period (``scan_period``, s; 0 when it has none)."""

    observations: list[ScanReflector]
    scan_period: NotRequired[float]


class _Position(TypedDict):
    x: float
    y: float


class _Orientation(TypedDict, total=False):
    z: float
    w: float


class _Pose(TypedDict):
    position: _Position
    orientation: _Orientation


class TruthMessage(TypedDict):
    """What :func:`load_log` reads of a /truth/pose message: the pose of O, position (m) and
    orientation (a quaternion about z: ``z`` 0 and ``w`` 1 when absent)."""

    pose: _Pose


def _seconds(ns: NDArray[np.int64], t0_ns: int) -> FloatArray:
    """Integer ns since the epoch as float s after ``t0_ns``."""
    return np.asarray((ns - t0_ns) * 1e-9, dtype=np.float64)


class LazyScans(Sequence[RawScan]):
    """Reflector scans kept as their JSON bytes (compressed, :class:`PackedBytes`, when read
    by :func:`load_log`) until an estimator first needs them, then decoded once, all of them,
    into flat arrays that every later use shares (the arrays take about as much memory as the
    compressed bytes they replace, which are freed)."""

    def __init__(self, t0_ns: int, received_ns: list[int] | NDArray[np.int64],
                 raw: list[bytes] | PackedBytes, source: str = "log") -> None:
        self._t0 = t0_ns
        self._raw: list[bytes] | PackedBytes | None = raw
        self._n = len(raw)
        self._all: tuple[ScanBatch, NDArray[np.int64]] | None = None
        self._start_ns: NDArray[np.int64] | None = None
        #: what the scans came from, for messages (the log's path)
        self.source = source
        #: receive (log) time of each scan, ns since the epoch
        self.received_ns = np.asarray(received_ns, dtype=np.int64)
        #: receive (log) time of each scan, s after ``t0_ns``
        self.received = _seconds(self.received_ns, t0_ns)

    @classmethod
    def of_columns(cls, t0_ns: int, received_ns: NDArray[np.int64], columns: ScanColumns,
                   source: str = "log") -> LazyScans:
        """Scans decoded already (:func:`load_log` asked to decode them as it reads), in
        the order of ``received_ns``: ``columns`` as :func:`scan_columns` gives them."""
        scans = cls(t0_ns, received_ns, [], source)
        scans._raw, scans._n = None, len(received_ns)
        scans._set(*scans._batch(columns))
        return scans

    def decoded(self) -> tuple[ScanBatch, NDArray[np.int64]]:
        """Every scan as flat read-only arrays, with the offset of each scan's first reflector
        (``len + 1`` entries); decoded on the first call."""
        if self._all is None:
            if self._raw is None:
                raise LogFormatError(f"{self.source}: reflector scans could not be decoded")
            raw, self._raw = self._raw, None  # the bytes are consumed by the decoding
            self._set(*self._decode(raw.consume() if isinstance(raw, PackedBytes)
                                    else [raw]))
        assert self._all is not None
        return self._all

    def _set(self, b: ScanBatch, start_ns: NDArray[np.int64]) -> None:
        """Keep the decoded scans ``b`` (their start times ``start_ns``) as read-only."""
        for a in (b.t, b.period, b.counts, b.ranges, b.bearings, b.times, b.ids, start_ns):
            a.setflags(write=False)
        offsets = np.concatenate(([0], np.cumsum(b.counts))).astype(np.int64)
        self._all, self._start_ns = (b, offsets), start_ns

    def decoded_columns(self) -> ScanViewColumns | None:
        """The scans as the view channels draw them (:class:`lgvtool.log.view_channels.LogRows`)
        once an estimator has decoded them, else None: log time (ns), start (ns), count, then
        per reflector range (m), bearing (rad), id and time in scan (s)."""
        if self._all is None or self._start_ns is None:
            return None
        b = self._all[0]
        return (self.received_ns, self._start_ns, b.counts, b.ranges, b.bearings, b.ids,
                b.times)

    def _decode(self, blocks: Iterable[Sequence[bytes]]
                ) -> tuple[ScanBatch, NDArray[np.int64]]:
        """Flat arrays of the JSON scans of ``blocks`` (one after the other), and their start
        times (ns)."""
        try:
            return self._batch(scan_columns(blocks))
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise LogFormatError(f"{self.source}: {_what(exc)}") from None

    def _batch(self, columns: ScanColumns) -> tuple[ScanBatch, NDArray[np.int64]]:
        """The scans ``columns`` as a batch (times in s after ``t0_ns``), and their start
        times (ns)."""
        t, cols = columns
        if not cols:
            return ScanBatch.from_scans([]), np.zeros(0, dtype=np.int64)
        period, counts, ranges, bearings, times, ids = cols
        f64, i64 = np.float64, np.int64
        return ScanBatch(_seconds(t, self._t0), np.asarray(period, f64),
                         np.asarray(counts, i64), np.asarray(ranges, f64),
                         np.asarray(bearings, f64), np.asarray(times, f64),
                         np.asarray(ids, i64)), t

    def start_and_period(self, indices: Sequence[int]) -> tuple[FloatArray, FloatArray]:
        """Start time (s after ``t0_ns``) and revolution period (s) of the scans ``indices``
        (they give the scans' observation times)."""
        b, _ = self.decoded()
        idx = np.asarray(indices, dtype=np.int64)
        return b.t[idx], b.period[idx]

    def __len__(self) -> int:
        return self._n

    @overload
    def __getitem__(self, i: int) -> RawScan: ...

    @overload
    def __getitem__(self, i: slice) -> list[RawScan]: ...

    def __getitem__(self, i: int | slice) -> RawScan | list[RawScan]:
        if isinstance(i, slice):
            return [self[k] for k in range(*i.indices(len(self)))]
        b = self.batch([i if i >= 0 else len(self) + i])
        return RawScan(float(b.t[0]), float(b.period[0]), b.ranges, b.bearings, b.times, b.ids)

    def batch(self, indices: Sequence[int] | None = None) -> ScanBatch:
        """The scans ``indices`` (all if None) as flat arrays (read-only: shared)."""
        b, offsets = self.decoded()
        if indices is None:
            return b
        idx = np.asarray(indices, dtype=np.int64)
        if len(idx) and (idx.min() < -self._n or idx.max() >= self._n):
            raise IndexError("scan index out of range")
        idx = np.where(idx < 0, idx + self._n, idx)
        counts = b.counts[idx]
        flat = _reflectors_of(offsets, counts, idx)
        return ScanBatch(b.t[idx], b.period[idx], counts, b.ranges[flat], b.bearings[flat],
                         b.times[flat], b.ids[flat])


def _reflectors_of(offsets: NDArray[np.int64], counts: NDArray[np.int64],
                   idx: NDArray[np.int64]) -> NDArray[np.int64]:
    """The flat indices of the reflectors of the scans ``idx`` (``counts`` theirs, in that
    order), given each scan's first offset ``offsets``: each scan's first, then one after the
    other."""
    ends = np.cumsum(counts)
    return np.repeat(offsets[idx] - (ends - counts), counts) + np.arange(
        int(ends[-1]) if len(ends) else 0)


def _scans_in_order(columns: ScanColumns, order: NDArray[np.int64]) -> ScanColumns:
    """The scans ``columns`` put in the order ``order`` (a permutation of the scans)."""
    t, cols = columns
    period, counts, ranges, bearings, times, ids = cols
    offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    chosen = np.asarray(counts, dtype=np.int64)[order]
    flat = _reflectors_of(offsets, chosen, order)
    return t[order], [period[order], chosen, ranges[flat], bearings[flat], times[flat],
                      ids[flat]]


#: decoded scans: their own start times (ns since the epoch; 0 for a scan without one), then
#: per scan its period (s) and count, per reflector range (m), bearing (rad), time in scan (s)
#: and id (no columns when there is no scan)
ScanColumns = tuple[IntArray, list[Column]]


def scan_columns(blocks: Iterable[Sequence[bytes]]) -> ScanColumns:
    """Decode the JSON scans of ``blocks`` (lists of messages, one after the other) and check
    their ranges; raises KeyError, TypeError or ValueError when they do not match the
    contract."""
    stamps: list[NDArray[np.int64]] = []
    parts: list[Sequence[Column]] = []
    for chosen in blocks:
        t, cols = _scan_block(chosen)
        if cols:
            stamps.append(t)
            parts.append(cols)
    return _scans_joined(stamps, parts)


def _scan_block(raw: Sequence[bytes]) -> tuple[IntArray, list[Column]]:
    """One block of JSON scans decoded: their own start stamps (ns, 0 where a scan has none)
    and the columns of :func:`_scan_fields`."""
    return _decode_columns(raw, np.zeros(len(raw), dtype=np.int64), _scan_fields)


def _scans_joined(stamps: list[IntArray], parts: list[Sequence[Column]]) -> ScanColumns:
    """Blocks of decoded scans joined (``parts`` emptied) and range-checked."""
    if not parts:
        return np.zeros(0, dtype=np.int64), []
    t, cols = np.concatenate(stamps), _joined(parts)
    _checked("/nav/reflectors", t[t != 0], ranges=cols[2], bearings=cols[3],
             time_in_scan=cols[4])
    return t, cols


def _scan_fields(docs: Sequence[ScanMessage]) -> tuple[Column, ...]:
    """Per scan its period and count, per reflector range, bearing, time in scan and id."""
    obs = [d["observations"] for d in docs]
    flat = [o for os in obs for o in os]
    n = len(flat)
    return (np.array([d.get("scan_period", 0.0) for d in docs], dtype=np.float64),
            np.array([len(o) for o in obs], dtype=np.int64),
            np.fromiter(map(itemgetter("range"), flat), dtype=np.float64, count=n),
            np.fromiter(map(itemgetter("bearing"), flat), dtype=np.float64, count=n),
            np.fromiter(map(itemgetter("time_in_scan"), flat), dtype=np.float64, count=n),
            np.fromiter(map(itemgetter("id"), flat), dtype=np.int64, count=n))


def scan_batch(scans: Sequence[RawScan], indices: Sequence[int] | None = None) -> ScanBatch:
    """Flat arrays of the scans ``indices`` (all if None) of a scan list."""
    if isinstance(scans, LazyScans):
        return scans.batch(indices)
    chosen = scans if indices is None else [scans[i] for i in indices]
    return ScanBatch.from_scans(chosen)


@dataclass
class LogData:
    """What the estimators need from a log, as arrays. Times in s after ``t0_ns``.

    ``mcu``: t, seq, mcu_time_ms, enc_left, enc_right, gyro_rate (MCU frames);
    ``twist``: t, v, omega (generic odometry); ``nav``: t, x, y, heading, valid, used (NAV
    head poses; used: the number of reflectors the device reports using);
    ``scans``: reflector scans; ``truth``: the ground truth of O (s after ``t0_ns``, m, m,
    rad: twice the angle of its quaternion, not wrapped) when the log has it (read only when
    asked for).
    """

    t0_ns: int
    reflectors: tuple[Reflector, ...]
    mcu: dict[str, NDArray[Any]] | None = None
    twist: dict[str, FloatArray] | None = None
    nav: dict[str, NDArray[Any]] | None = None
    scans: Sequence[RawScan] = field(default_factory=list)
    truth: Trajectory | None = None

    @property
    def has_motion(self) -> bool:
        """Whether the log holds at least two motion samples."""
        return (self.mcu is not None and len(self.mcu["t"]) >= 2) or (
            self.twist is not None and len(self.twist["t"]) >= 2)

    @property
    def has_scans(self) -> bool:
        """Whether the log has reflector scans and a map to match them against."""
        return len(self.scans) > 0 and bool(self.reflectors)

    @property
    def has_poses(self) -> bool:
        """Whether the log has at least one valid NAV pose."""
        return self.nav is not None and bool(np.any(self.nav["valid"]))

    @property
    def end(self) -> float:
        """Time of the last motion sample or observation, s after ``t0_ns``."""
        ends = [0.0]
        for d in (self.mcu, self.twist, self.nav):
            if d is not None and len(d["t"]):
                ends.append(float(d["t"][-1]))
        if len(self.scans):
            ends.append(float(self.scan_received()[-1]))
        return max(ends)

    def scan_received(self) -> FloatArray:
        """When each scan was complete (received), s after ``t0_ns``."""
        if isinstance(self.scans, LazyScans):
            return self.scans.received
        return np.array([s.t + s.period for s in self.scans], dtype=np.float64)

    def increments(self, settings: MotionSettings, vehicle: Vehicle) -> Increments:
        """Motion increments from the MCU frames if any, else from the generic odometry."""
        if self.mcu is not None and len(self.mcu["t"]) >= 2:
            m = self.mcu
            return increments_from_mcu(m["t"], m["seq"], m["mcu_time_ms"], m["enc_left"],
                                       m["enc_right"], m["gyro_rate"], vehicle, settings)
        if self.twist is not None:
            return increments_from_twist(self.twist["t"], self.twist["v"], self.twist["omega"])
        return Increments(np.zeros(0), np.zeros(0), np.zeros(0))


#: messages gathered per topic before they are decoded, and the most decoded at a time
_DECODE_BLOCK = 2048

#: JSON decoded at a time, about, bytes: the dicts of one block are freed before the next is
#: decoded, so decoding reuses the same memory, which stays in the processor's caches (the
#: hour's 28 800 scans of about 1.6 kB: 0.26-0.40 s decoded 2048 at a time, 0.16-0.18 s 40 at
#: a time; the small MCU frames and NAV poses take the same time either way)
_DECODE_BYTES = 64 * 1024


def _decode_columns(raw: Sequence[bytes], log_ns: IntArray,
                    fields: Callable[[list[_M]], tuple[Column, ...]],
                    stamped: str | None = None) -> tuple[IntArray, list[Column]]:
    """Decode JSON messages block by block (about :data:`_DECODE_BYTES` each): their own time
    stamps (ns, else the log times) and the arrays ``fields`` extracts from each block's dicts
    (messages on the last axis). With ``stamped`` (the topic's name) every message must carry
    its ``timestamp`` (``{sec, nsec}``): the time its content refers to, which the log time
    (when the host wrote it) cannot stand in for.

    :raises ValueError: ``topic ...: ...`` when a message of a ``stamped`` topic has none."""
    import orjson

    loads = orjson.loads
    stamps: list[IntArray] = []
    parts: list[Sequence[Column]] = []
    size = sum(map(len, raw))
    step = max(1, min(_DECODE_BLOCK, _DECODE_BYTES * len(raw) // max(size, 1)))
    for a in range(0, len(raw), step):
        docs = [loads(x) for x in raw[a:a + step]]
        if stamped is not None:
            _require_stamps(stamped, docs, a)
        stamps.append(message_stamps_ns(docs, log_ns[a:a + step]))
        parts.append(fields(docs))
    if not parts:
        return np.zeros(0, dtype=np.int64), []
    return np.concatenate(stamps), _joined(parts)


def _require_stamps(topic: str, docs: Sequence[object], first: int) -> None:
    """Raise ``ValueError`` (``topic ...``) naming the first of ``docs`` (messages ``first``
    on of ``topic``) without a ``timestamp`` of ``sec`` and ``nsec``."""
    for i, d in enumerate(docs):
        ts = d.get("timestamp") if isinstance(d, Mapping) else None
        if not (isinstance(ts, Mapping) and "sec" in ts and "nsec" in ts):
            raise ValueError(f"topic {topic}: message {first + i + 1} has no timestamp "
                             f"({{sec, nsec}}): the time a NAV pose refers to must be in it")


def _joined(parts: list[Sequence[Column]]) -> list[Column]:
    """The columns of ``parts`` (blocks of columns, messages on the last axis) joined, one
    column at a time, each column's blocks freed once it is joined (``parts`` is emptied)."""
    columns = [list(c) for c in zip(*parts, strict=True)]
    parts.clear()
    out: list[Column] = []
    for col in columns:
        out.append(np.concatenate(col, axis=-1))
        col.clear()
    return out


def _columns(docs: Sequence[JSONRecord], keys: Sequence[str], dtype: type[_S]) -> NDArray[_S]:
    """The fields ``keys`` of every message as the rows of one array, (len(keys), n)."""
    n = len(docs)
    return np.stack([np.fromiter(map(itemgetter(k), docs), dtype=dtype, count=n)
                     for k in keys]) if keys else np.empty((0, n), dtype=dtype)


def _truth_fields(docs: Sequence[TruthMessage]) -> tuple[Column, ...]:
    return (np.array(
        [(d["pose"]["position"]["x"], d["pose"]["position"]["y"],
          d["pose"]["orientation"].get("z", 0.0), d["pose"]["orientation"].get("w", 1.0))
         for d in docs], dtype=np.float64).reshape(-1, 4).T,)


#: per topic, the arrays taken from a block of its decoded messages (messages on the last axis;
#: /truth/pose's by :func:`_truth_fields`)
_FIELDS: dict[str, Callable[[Sequence[JSONRecord]], tuple[Column, ...]]] = {
    "/mcu/frame": lambda docs: (
        _columns(docs, ("seq", "mcu_time_ms", "enc_left", "enc_right"), np.int64),
        _columns(docs, ("gyro_rate",), np.float64)[0]),
    "/odom/twist": lambda docs: (_columns(docs, ("v", "omega"), np.float64),),
    "/nav/pose": lambda docs: (
        _columns(docs, ("x", "y", "heading", "reflectors_used"), np.float64),
        np.array(flags(docs, "valid"), dtype=bool)),
}


class _Topic:
    """One topic's messages decoded chunk by chunk: log times (ns), own time stamps (ns) and
    the arrays of :data:`_FIELDS`."""

    def __init__(self) -> None:
        self.log_ns: list[IntArray] = []
        self.stamps: list[IntArray] = []
        self.cols: list[list[Column]] = []

    def add(self, log_ns: IntArray, stamps: IntArray, cols: list[Column]) -> None:
        self.log_ns.append(log_ns)
        self.stamps.append(stamps)
        self.cols.append(cols)

    def done(self) -> tuple[IntArray, IntArray, list[Column]]:
        """Everything in log-time order (ties in stored order), as one array each."""
        log_ns = np.concatenate(self.log_ns)
        stamps = np.concatenate(self.stamps)
        cols = [np.concatenate(c, axis=-1) for c in zip(*self.cols, strict=True)]
        if len(log_ns) > 1 and not bool(np.all(log_ns[1:] >= log_ns[:-1])):
            o = np.argsort(log_ns, kind="stable")
            log_ns, stamps, cols = log_ns[o], stamps[o], [c[..., o] for c in cols]
        return log_ns, stamps, cols


def load_log(reader: LogReader, reflectors: Sequence[Reflector] | None = None, *,
             truth: bool = False, tap: Tap | None = None,
             decode_scans: bool = False) -> LogData:
    """Read the motion and observation topics of a log (and the ground truth if ``truth``)
    into arrays; reflector scans are kept undecoded (compressed) until first used, then
    decoded once (:class:`LazyScans`), or, with ``decode_scans`` (for a caller that will use
    them all: the scans decoded as they are read cost neither the compression nor the
    decompression) and a reflector map to match them against, decoded as they are read.

    The log is read one chunk at a time and each chunk's messages are decoded before the next
    is read, so memory holds the arrays, not the messages. ``tap`` is handed every chunk's
    messages of its topics too (the read's errors are load_log's, the tap's its own).
    """
    from lgvtool.log import topics as T

    wanted = [T.MCU_FRAME, T.ODOM, T.NAV_POSE, T.NAV_REFLECTORS]
    if truth:
        wanted.append(T.TRUTH)
    own = frozenset(wanted)
    chunks: Iterable[RawBlock] = (
        reader.raw_column_chunks(wanted) if tap is None
        else _tapped(reader.raw_column_chunks([*wanted, *tap.topics]), tap, own))
    try:
        return _log_data(reader, chunks, reflectors, decode_scans)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError) as exc:
        from lgvtool.errors import LogFormatError

        raise LogFormatError(f"{reader.path}: {_what(exc)}") from None


def _tapped(chunks: Iterable[RawBlock], tap: Tap, own: frozenset[str]) -> Iterator[RawBlock]:
    """``chunks`` handed to ``tap``, then passed on with only the topics ``own``."""
    for block in chunks:
        tap.add(block)
        yield {topic: found for topic, found in block.items() if topic in own}


def _what(exc: BaseException) -> str:
    """One phrase for a decoding failure of :func:`_log_data`."""
    if isinstance(exc, ValueError) and str(exc).startswith("topic "):
        return str(exc)
    return f"messages do not match the log contract ({type(exc).__name__}: {exc})"


@contextlib.contextmanager
def _about(topic: str) -> Iterator[None]:
    """Name ``topic`` in a decoding failure (KeyError, TypeError, ValueError) inside."""
    try:
        yield
    except (KeyError, TypeError, ValueError, AttributeError, IndexError, OverflowError) as exc:
        if isinstance(exc, ValueError) and str(exc).startswith("topic "):
            raise
        raise ValueError(f"topic {topic}: messages do not match the log contract "
                         f"({type(exc).__name__}: {exc})") from None


def _checked(topic: str, ti: IntArray, **columns: Column) -> None:
    """Range checks of one decoded topic: plausible times, finite numbers."""
    from lgvtool.log.validate import check_finite, check_times

    if len(ti):
        check_times(topic, (int(ti.min()), int(ti.max())))
    check_finite(topic, columns)


def _log_data(reader: LogReader, chunks: Iterable[RawBlock],
              reflectors: Sequence[Reflector] | None, decode_scans: bool) -> LogData:
    """:func:`load_log` from the raw messages of each chunk; raises KeyError, TypeError or
    ValueError when they do not match the contract."""
    from lgvtool.log import topics as T

    refl = tuple(reflectors) if reflectors is not None else reader.reflector_map()
    eager = decode_scans and bool(refl)
    acc: dict[str, _Topic] = {}
    scan_ns: list[NDArray[np.int64]] = []
    packed = PackedBytes()
    # the scans decoded so far (eager): their start times and blocks of columns
    scan_stamps: list[NDArray[np.int64]] = []
    scan_parts: list[Sequence[Column]] = []
    # raw messages of the chunks read so far, decoded once a block's worth is pending
    pending: dict[str, tuple[list[NDArray[np.int64]], list[bytes]]] = {}

    def decode(topic: str) -> None:
        times, raw = pending.pop(topic)
        if topic == T.NAV_REFLECTORS:  # their start times are their own stamps
            with _about(topic):
                stamps, cols = _scan_block(raw)
            scan_stamps.append(stamps)
            scan_parts.append(cols)
            return
        log_ns = np.concatenate(times)
        with _about(topic):
            if topic == T.TRUTH:
                stamps, cols = _decode_columns(raw, log_ns, _truth_fields)
            else:
                stamps, cols = _decode_columns(raw, log_ns, _FIELDS[topic],
                                               topic if topic == T.NAV_POSE else None)
        acc.setdefault(topic, _Topic()).add(log_ns, stamps, cols)

    for block in chunks:
        for topic, (log_ns, raw) in block.items():
            if topic == T.NAV_REFLECTORS:
                scan_ns.append(log_ns)
                if not eager:
                    packed.append_block(raw)
                    continue
            times, msgs = pending.setdefault(topic, ([], []))
            if topic != T.NAV_REFLECTORS:  # the scans' log times are kept in scan_ns
                times.append(log_ns)
            msgs.extend(raw)
            if len(msgs) >= _DECODE_BLOCK:
                decode(topic)
    for topic in list(pending):
        decode(topic)
    done = {topic: a.done() for topic, a in acc.items()}
    scans_log_ns = np.concatenate(scan_ns) if scan_ns else np.zeros(0, np.int64)
    # the clock starts with the motion and observation data, whether the truth is read or not
    firsts = [int(d[0][0]) for topic, d in done.items() if len(d[0]) and topic != T.TRUTH]
    if len(scans_log_ns):
        firsts.append(int(scans_log_ns.min()))
    t0 = min(firsts, default=0)
    data = LogData(t0, refl)
    if T.MCU_FRAME in done:
        with _about(T.MCU_FRAME):
            _, ti, (ints, gyro) = done[T.MCU_FRAME]
            _checked(T.MCU_FRAME, ti, gyro_rate=gyro)
            order = np.argsort(ti, kind="stable")
            ints = ints[:, order]
            data.mcu = {"t": _seconds(ti[order], t0), "seq": ints[0], "mcu_time_ms": ints[1],
                        "enc_left": ints[2], "enc_right": ints[3], "gyro_rate": gyro[order]}
    if T.ODOM in done:
        with _about(T.ODOM):
            _, ti, (a,) = done[T.ODOM]
            _checked(T.ODOM, ti, v=a[0], omega=a[1])
            order = np.argsort(ti, kind="stable")
            a = a[:, order]
            data.twist = {"t": _seconds(ti[order], t0), "v": a[0], "omega": a[1]}
    if T.NAV_POSE in done:
        with _about(T.NAV_POSE):
            _, ti, (a, valid) = done[T.NAV_POSE]
            _checked(T.NAV_POSE, ti)
            order = np.argsort(ti, kind="stable")
            a = a[:, order]
            data.nav = {"t": _seconds(ti[order], t0), "x": a[0], "y": a[1], "heading": a[2],
                        "valid": np.asarray(valid, dtype=np.bool_)[order]
                        & plausible_poses(a[0], a[1], a[2]),
                        "used": a[3].astype(np.int64)}
    if len(scan_ns):
        with _about(T.NAV_REFLECTORS):
            _checked(T.NAV_REFLECTORS, scans_log_ns)
            o = None
            if len(scans_log_ns) > 1 and not bool(np.all(scans_log_ns[1:] >= scans_log_ns[:-1])):
                o = np.argsort(scans_log_ns, kind="stable")
                scans_log_ns = scans_log_ns[o]
            if eager:
                cols = _scans_joined(scan_stamps, scan_parts)
                data.scans = LazyScans.of_columns(
                    t0, scans_log_ns, cols if o is None else _scans_in_order(cols, o),
                    str(reader.path))
            else:
                if o is not None:
                    packed.reorder(o)
                data.scans = LazyScans(t0, scans_log_ns, packed, str(reader.path))
    if T.TRUTH in done:
        with _about(T.TRUTH):
            _, ti, (a,) = done[T.TRUTH]
            _checked(T.TRUTH, ti, x=a[0], y=a[1], orientation=a[2:])
            a = a[:, np.argsort(ti, kind="stable")]
            data.truth = Trajectory(_seconds(np.sort(ti, kind="stable"), t0), a[0], a[1],
                                    2.0 * np.arctan2(a[2], a[3]), t0)
    return data
