"""Write a simulation as an lgvtool log, as the recorder would have logged the run.

The host side of the run goes into the log in log-time order: raw reads and writes of both
serial ports (/mcu/rx, /nav200/tx, /nav200/rx) in the chunks the ports delivered, the frames and
poses decoded from those bytes by the devices' log decoders, the one decoding path that
``lgvtool decode`` and the recorder use (:mod:`lgvtool.devices.log_decoding`: /mcu/frame,
/nav/pose, with decoder errors on /diagnostics; what the end of the run completes is written
at its end), the head's reflector observations per
revolution (/nav/reflectors, logged when the revolution's solution is available), the ground
truth of O (/truth/pose), the injected faults (/diagnostics, source 'simulator'), the reflector
map and the metadata ('simulator' with every setting and the seed, and 'config').
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from lgvtool.devices.device_registry import registration
from lgvtool.devices.log_decoding import WriterOutput, decode_chunk, finish_decoding
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame, reflector_scan_message
from lgvtool.sim.event_stream import nav_scans, truth_samples
from lgvtool.sim.simulation import Simulation

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
    nav_family = sim.settings.sim.nav_device
    if nav_family == "nav350":  # the host side of a NAV350 instead
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

    mcu = registration("mcu").log_decoder({})
    nav = registration(nav_family).log_decoder({})
    with LogWriter(path, compression=compression, source="simulate", command=command) as w:
        out = WriterOutput(w)

        def feed(family: str, direction: str, decoder: Any, ns: int, data: bytes) -> None:
            w.write_raw(family, direction, data, ns)
            decode_chunk(decoder, topics.raw_topic(family, direction), data, ns, out)

        w.add_metadata("simulator", sim.metadata())
        w.write_config(sim.config)
        w.write_map(sim.config.reflectors, sim.start_ns)
        for ns, order, _, payload in records:
            if order == _TRUTH:
                w.write(topics.TRUTH, pose_in_frame(ns, payload.x, payload.y, payload.heading),
                        ns)
            elif order == _FAULT:
                w.write_diagnostic(payload.source, payload.kind, payload.message, ns, level=3,
                                   details=payload.details)
            elif order == _MCU:
                feed("mcu", "rx", mcu, ns, payload.data)
            elif order in (_NAV_TX, _NAV_RX):
                data = payload if isinstance(payload, bytes) else payload.data
                feed(nav_family, "tx" if order == _NAV_TX else "rx", nav, ns, data)
            else:
                w.write(topics.NAV_REFLECTORS,
                        reflector_scan_message(sim.host_ns(payload.start + late),
                                               payload.period, payload.observations), ns)
        end_ns = sim.host_ns(sim.duration)
        finish_decoding(mcu, out, end_ns)
        finish_decoding(nav, out, end_ns)
        total = w.message_count
    return LogSummary(path=str(path), messages=total, duration_s=sim.duration,
                      faults=sim.fault_counts())

