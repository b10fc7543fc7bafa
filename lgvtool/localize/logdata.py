"""What the estimators need from a log, read into arrays (:func:`load_log`).

Times are seconds relative to the first message read (``LogData.t0_ns``). Reflector scans are
kept as their JSON bytes (:class:`LazyScans`) and decoded only for the estimators that use them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, overload

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Reflector
from lgvtool.localize.motion import (
    Increments,
    MotionSettings,
    increments_from_mcu,
    increments_from_twist,
)
from lgvtool.localize.observations import RawScan, ScanBatch

if TYPE_CHECKING:
    from lgvtool.log import LogReader

FloatArray = NDArray[np.float64]


def _seconds(ns: NDArray[np.int64], t0_ns: int) -> FloatArray:
    """Integer ns since the epoch as float s after ``t0_ns``."""
    return np.asarray((ns - t0_ns) * 1e-9, dtype=np.float64)


class LazyScans(Sequence[RawScan]):
    """Reflector scans kept as their JSON bytes and decoded only when an estimator needs them
    (the paper's filter uses one revolution per NAV poll, about a quarter of them)."""

    def __init__(self, t0_ns: int, received_ns: list[int], raw: list[bytes]) -> None:
        self._t0 = t0_ns
        self._raw = raw
        #: receive (log) time of each scan, s after ``t0_ns``
        self.received = _seconds(np.array(received_ns, dtype=np.int64), t0_ns)

    def __len__(self) -> int:
        return len(self._raw)

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
        """Decode the scans ``indices`` (all if None) into flat arrays."""
        import orjson

        loads = orjson.loads
        raw = self._raw
        idx = range(len(raw)) if indices is None else indices
        t: list[int] = []
        period: list[float] = []
        counts: list[int] = []
        rr: list[float] = []
        bb: list[float] = []
        tt: list[float] = []
        ii: list[int] = []
        for k in idx:
            d = loads(raw[k])
            ts = d["timestamp"]
            t.append(ts["sec"] * 1_000_000_000 + ts["nsec"])
            period.append(d.get("scan_period", 0.0))
            obs = d["observations"]
            counts.append(len(obs))
            for o in obs:
                rr.append(o["range"])
                bb.append(o["bearing"])
                tt.append(o["time_in_scan"])
                ii.append(o["id"])
        return ScanBatch(_seconds(np.array(t, dtype=np.int64), self._t0),
                         np.array(period, dtype=np.float64), np.array(counts, dtype=np.int64),
                         np.array(rr, dtype=np.float64), np.array(bb, dtype=np.float64),
                         np.array(tt, dtype=np.float64), np.array(ii, dtype=np.int64))


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
    ``twist``: t, v, omega (generic odometry); ``nav``: t, x, y, heading, valid (NAV head poses);
    ``scans``: reflector scans; ``truth``: t, x, y, heading of O when the log has ground truth
    (read only when asked for).
    """

    t0_ns: int
    reflectors: tuple[Reflector, ...]
    mcu: dict[str, NDArray[Any]] | None = None
    twist: dict[str, FloatArray] | None = None
    nav: dict[str, NDArray[Any]] | None = None
    scans: Sequence[RawScan] = field(default_factory=list)
    truth: dict[str, FloatArray] | None = None

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

    def increments(self, settings: MotionSettings, vehicle: Any) -> Increments:
        """Motion increments from the MCU frames if any, else from the generic odometry."""
        if self.mcu is not None and len(self.mcu["t"]) >= 2:
            m = self.mcu
            return increments_from_mcu(m["t"], m["seq"], m["mcu_time_ms"], m["enc_left"],
                                       m["enc_right"], m["gyro_rate"], vehicle, settings)
        if self.twist is not None:
            return increments_from_twist(self.twist["t"], self.twist["v"], self.twist["omega"])
        return Increments(np.zeros(0), np.zeros(0), np.zeros(0))


def load_log(reader: LogReader, reflectors: Sequence[Reflector] | None = None, *,
             truth: bool = False) -> LogData:
    """Read the motion and observation topics of a log (and the ground truth if ``truth``)
    into arrays; reflector scans are kept undecoded until used."""
    import orjson

    from lgvtool.log import topics as T

    wanted = [T.MCU_FRAME, T.ODOM, T.NAV_POSE, T.NAV_REFLECTORS]
    if truth:
        wanted.append(T.TRUTH)
    mcu: list[tuple[int, int, int, int, int, float]] = []
    twist: list[tuple[int, float, float]] = []
    nav: list[tuple[int, float, float, float, bool]] = []
    scan_ns: list[int] = []
    scan_raw: list[bytes] = []
    poses: list[tuple[int, float, float, float, float]] = []
    loads = orjson.loads
    first: int | None = None
    mcu_topic, nav_topic, scan_topic, odom_topic = T.MCU_FRAME, T.NAV_POSE, T.NAV_REFLECTORS, \
        T.ODOM
    for m in reader.raw_messages(wanted):
        if first is None:
            first = m.log_time_ns
        topic = m.topic
        if topic == scan_topic:
            scan_ns.append(m.log_time_ns)
            scan_raw.append(m.data)
            continue
        d = loads(m.data)
        ts = d.get("timestamp")
        t_ns = ts["sec"] * 1_000_000_000 + ts["nsec"] if ts else m.log_time_ns
        if topic == mcu_topic:
            mcu.append((t_ns, d["seq"], d["mcu_time_ms"], d["enc_left"], d["enc_right"],
                        d["gyro_rate"]))
        elif topic == nav_topic:
            nav.append((t_ns, d["x"], d["y"], d["heading"], bool(d["valid"])))
        elif topic == odom_topic:
            twist.append((t_ns, d["v"], d["omega"]))
        else:
            q = d["pose"]["orientation"]
            p = d["pose"]["position"]
            poses.append((t_ns, p["x"], p["y"], q.get("z", 0.0), q.get("w", 1.0)))
    t0 = first or 0
    refl = tuple(reflectors) if reflectors is not None else reader.reflector_map()
    data = LogData(t0, refl)
    if mcu:
        ti = np.array([r[0] for r in mcu], dtype=np.int64)
        order = np.argsort(ti, kind="stable")
        cols = list(zip(*mcu, strict=True))
        data.mcu = {"t": _seconds(ti[order], t0),
                    "seq": np.array(cols[1], dtype=np.int64)[order],
                    "mcu_time_ms": np.array(cols[2], dtype=np.int64)[order],
                    "enc_left": np.array(cols[3], dtype=np.int64)[order],
                    "enc_right": np.array(cols[4], dtype=np.int64)[order],
                    "gyro_rate": np.array(cols[5], dtype=np.float64)[order]}
    if twist:
        ti = np.array([r[0] for r in twist], dtype=np.int64)
        a = np.array([r[1:] for r in twist], dtype=np.float64)
        order = np.argsort(ti, kind="stable")
        data.twist = {"t": _seconds(ti[order], t0), "v": a[order, 0], "omega": a[order, 1]}
    if nav:
        ti = np.array([r[0] for r in nav], dtype=np.int64)
        a = np.array([r[1:4] for r in nav], dtype=np.float64)
        order = np.argsort(ti, kind="stable")
        data.nav = {"t": _seconds(ti[order], t0), "x": a[order, 0], "y": a[order, 1],
                    "heading": a[order, 2],
                    "valid": np.array([r[4] for r in nav], dtype=bool)[order]
                    & np.isfinite(a[order]).all(axis=1)}
    if scan_raw:
        data.scans = LazyScans(t0, scan_ns, scan_raw)
    if poses:
        ti = np.array([r[0] for r in poses], dtype=np.int64)
        a = np.array([r[1:] for r in poses], dtype=np.float64)
        order = np.argsort(ti, kind="stable")
        a = a[order]
        data.truth = {"t": _seconds(ti[order], t0), "x": a[:, 0], "y": a[:, 1],
                      "heading": 2.0 * np.arctan2(a[:, 2], a[:, 3])}
    return data
