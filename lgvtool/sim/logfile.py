"""Write a simulation as an lgvtool log, as the recorder would have logged the run.

The host side of the run goes into the log in log-time order: raw reads and writes of both
serial ports (/mcu/rx, /nav200/tx, /nav200/rx) in the chunks the ports delivered, the frames and
poses decoded from those bytes by the same stream decoders the recorder uses (/mcu/frame,
/nav/pose, with decoder errors on /diagnostics), the head's reflector observations per
revolution (/nav/reflectors, logged when the revolution's solution is available), the ground
truth of O (/truth/pose), the injected faults (/diagnostics, source 'simulator'), the reflector
map and the metadata ('simulator' with every setting and the seed, and 'config').
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from lgvtool.devices.mcu.mcu_stream import McuStreamDecoder
from lgvtool.devices.nav200.nav200_commands import Reply
from lgvtool.devices.nav200.nav200_matcher import Nav200ReplyMatcher
from lgvtool.devices.nav200.nav200_payloads import Pose
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import mcu_frame_message, nav_pose_message, pose_in_frame
from lgvtool.sim.event_stream import nav_scans, truth_samples
from lgvtool.sim.simulation import Simulation
from lgvtool.timestamps import stamp
from lgvtool.wire.decode_events import DecodeEvent

# order of records that share a log time
_TRUTH, _FAULT, _MCU, _NAV_TX, _NAV_RX, _SCAN = range(6)


@dataclass(frozen=True)
class LogSummary:
    """What was written."""

    path: str
    messages: int
    """Messages written, all topics."""
    duration_s: float
    """Length of the run, s."""
    faults: dict[str, int]
    """Injected faults by kind."""


def _scan_message(start_ns: int, period: float, obs: Any) -> dict[str, Any]:
    return {
        "timestamp": stamp(start_ns),
        "scan_period": period,
        "observations": [{"range": o.range, "bearing": o.bearing,
                          "time_in_scan": o.time_in_scan, "id": o.id} for o in obs],
    }


def write_log(sim: Simulation, path: str | Path | IO[bytes], *, command: str | None = None,
              compression: str = "zstd") -> LogSummary:
    """Write ``sim`` to ``path`` (see the module docstring); return what was written."""
    records: list[tuple[int, int, int, Any]] = []

    def add(t: float, order: int, payload: Any) -> None:
        records.append((sim.host_ns(t), order, len(records), payload))

    for sample in truth_samples(sim, sim.settings.sim.truth_rate_hz):
        add(sample.t, _TRUTH, sample)
    for fault in sim.faults:
        add(fault.t, _FAULT, fault)
    for chunk in sim.mcu_traffic.rx:
        add(chunk.t, _MCU, chunk)
    late = sim.settings.install.nav_time_offset_ms * 1e-3  # NAV-to-host time offset, s
    if sim.settings.sim.nav_device == "nav350":  # the host side of a NAV350 instead
        from lgvtool.devices.nav350.nav350_simlink import nav350_traffic

        for t, direction, data in nav350_traffic(sim):
            add(t + late if direction == "rx" else t, _NAV_TX if direction == "tx" else _NAV_RX,
                data)
    else:
        for chunk in sim.nav_traffic.tx:
            add(chunk.t, _NAV_TX, chunk)
        for chunk in sim.nav_traffic.rx:
            add(chunk.t + late, _NAV_RX, chunk)
        available = sim.solutions.available
        for k, scan in enumerate(nav_scans(sim)):
            if available[k] > sim.duration:
                break
            add(float(available[k]) + late, _SCAN, scan)
    records.sort(key=lambda r: (r[0], r[1], r[2]))

    mcu_decoder = McuStreamDecoder()
    nav350 = None
    session = Nav200ReplyMatcher()
    with LogWriter(path, compression=compression, source="simulate", command=command) as w:
        w.add_metadata("simulator", sim.metadata())
        w.write_config(sim.config)
        w.write_map(sim.config.reflectors, sim.start_ns)
        if sim.settings.sim.nav_device == "nav350":
            from lgvtool.devices.nav350.nav350_simlink import Nav350LogWriter

            nav350 = Nav350LogWriter(w)
        for ns, order, _, payload in records:
            if order == _TRUTH:
                w.write(topics.TRUTH, pose_in_frame(ns, payload.x, payload.y, payload.heading),
                        ns)
            elif order == _FAULT:
                w.write_diagnostic(payload.source, payload.kind, payload.message, ns, level=3,
                                   details=payload.details)
            elif order == _MCU:
                _mcu_read(w, mcu_decoder, ns, payload.data)
            elif nav350 is not None and order in (_NAV_TX, _NAV_RX):
                nav350.chunk(ns, "tx" if order == _NAV_TX else "rx", payload)
            elif order == _NAV_TX:
                _nav_write(w, session, ns, payload.data)
            elif order == _NAV_RX:
                _nav_read(w, session, ns, payload.data)
            else:
                w.write(topics.NAV_REFLECTORS,
                        _scan_message(sim.host_ns(payload.start + late), payload.period,
                                      payload.observations), ns)
        end_ns = sim.host_ns(sim.duration)
        for frame in mcu_decoder.flush():
            w.write(topics.MCU_FRAME, mcu_frame_message(frame, stamp(end_ns)), end_ns)
        _diagnostics(w, mcu_decoder.pop_events(), end_ns)
        session.flush()
        _diagnostics(w, session.pop_events(), end_ns)
        total = w.message_count
    return LogSummary(path=str(path), messages=total, duration_s=sim.duration,
                      faults=sim.fault_counts())


def _diagnostics(w: LogWriter, events: list[DecodeEvent], ns: int) -> None:
    for e in events:
        w.write_diagnostic(e.source, e.kind, e.message, ns, level=e.level, count=e.count,
                           details=e.details)


def _mcu_read(w: LogWriter, decoder: McuStreamDecoder, ns: int, data: bytes) -> None:
    w.write_raw("mcu", "rx", data, ns)
    for frame in decoder.feed(data):
        w.write(topics.MCU_FRAME, mcu_frame_message(frame, stamp(ns)), ns)
    _diagnostics(w, decoder.pop_events(), ns)


def _nav_write(w: LogWriter, session: Nav200ReplyMatcher, ns: int, data: bytes) -> None:
    w.write_raw("nav200", "tx", data, ns)
    session.sent(data)
    _diagnostics(w, session.pop_events(), ns)


def _nav_read(w: LogWriter, session: Nav200ReplyMatcher, ns: int, data: bytes) -> None:
    w.write_raw("nav200", "rx", data, ns)
    for exchange in session.feed(data):
        reply = exchange.reply
        if isinstance(reply, Reply) and isinstance(reply.payload, Pose):
            w.write(topics.NAV_POSE, nav_pose_message(reply, stamp(ns)), ns)
    _diagnostics(w, session.pop_events(), ns)
