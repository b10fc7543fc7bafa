"""Write a simulation as an lgvtool log, as the recorder would have logged the run.

The host side of the run goes into the log in log-time order: raw reads and writes of both
serial ports (/mcu/rx, /nav200/tx, /nav200/rx) in the chunks the ports delivered, the frames and
poses decoded from those bytes by the devices' log decoders, the one decoding path that
``lgvtool decode`` and the recorder use (:mod:`lgvtool.devices.log_decoding`: /mcu/frame,
/nav/pose, with decoder errors on /diagnostics; what the end of the run completes is written
at its end), the ground truth of O (/truth/pose), the injected faults (/diagnostics, source
'simulator'), the reflector map and the metadata ('simulator' with every setting and the seed,
and 'config').

Reflector observations (/nav/reflectors) are what the device delivers: a NAV350 its landmarks
of every revolution, decoded from its replies, with its own timestamps and ids; a NAV200 none
(no NAV200 host protocol delivers them), unless ``sim.paper_scans`` logs them as the paper's
experiment had them: per revolution, when its solution is available, with the device's ids,
and marked so (the 'simulator' metadata's ``observations`` is ``"paper-scans"``:
:attr:`lgvtool.sim.simulation.Simulation.observations`).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from itertools import takewhile
from pathlib import Path
from typing import IO, TypeVar, cast

from lgvtool.devices.device_registry import registration
from lgvtool.devices.log_decoding import LogDecoder, WriterOutput, decode_chunk, finish_decoding
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import pose_in_frame, reflector_scan_message
from lgvtool.sim.event_stream import NavScan, TruthSample, nav_scans, truth_samples
from lgvtool.sim.faults import FaultEvent
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


Payload = TruthSample | FaultEvent | bytes | NavScan
"""What a record carries, by its kind: a truth sample (:data:`_TRUTH`), an injected fault
(:data:`_FAULT`), the bytes of a read or a write (:data:`_MCU`, :data:`_NAV_TX`,
:data:`_NAV_RX`), a reflector scan (:data:`_SCAN`)."""
Record = tuple[int, int, int, Payload]
"""(log time ns, kind, position in its source, payload): records compare by log time, then
kind, then position (the payload is never compared)."""
P = TypeVar("P")


def _records(sim: Simulation) -> Iterator[Record]:
    """Every record of the run's host side in log-time order, one at a time: records of one
    log time in the order of their kind (:data:`_TRUTH` first), those of one kind in the order
    their source made them.

    Each source is in time order already or put in it (a stable sort of its times), so the
    sources are merged as they go and the whole run is never held as records.
    """
    late = sim.settings.install.nav_time_offset_ms * 1e-3  # NAV-to-host time offset, s
    truth = ((sim.host_ns(s.t), s)
             for s in truth_samples(sim, sim.settings.sim.truth_rate_hz))
    sources = [_numbered(_TRUTH, _checked(truth)),
               _numbered(_FAULT, _in_time_order(sim, [(f.t, f) for f in sim.faults])),
               _numbered(_MCU, _in_time_order(sim, [(c.t, c.data) for c in sim.mcu_traffic.rx]))]
    if sim.settings.sim.nav_device == "nav350":  # the host side of a NAV350 instead
        from lgvtool.sim.nav350_simlink import nav350_traffic

        traffic = nav350_traffic(sim)
        tx = [(t, data) for t, direction, data in traffic if direction != "rx"]
        rx = [(t + late, data) for t, direction, data in traffic if direction == "rx"]
        sources += [_numbered(_NAV_TX, _in_time_order(sim, tx)),
                    _numbered(_NAV_RX, _in_time_order(sim, rx))]
    else:
        tx = [(c.t, c.data) for c in sim.nav_traffic.tx]
        rx = [(c.t + late, c.data) for c in sim.nav_traffic.rx]
        sources += [_numbered(_NAV_TX, _in_time_order(sim, tx)),
                    _numbered(_NAV_RX, _in_time_order(sim, rx))]
        if sim.settings.sim.paper_scans:
            reported = takewhile(lambda r: r[0] <= sim.duration,
                                 zip(sim.solutions.available.tolist(), nav_scans(sim),
                                     strict=False))
            scans = ((sim.host_ns(t + late), scan) for t, scan in reported)
            sources.append(_numbered(_SCAN, _checked(scans)))
    return heapq.merge(*sources)


def _in_time_order(sim: Simulation, items: Sequence[tuple[float, P]]) -> Iterator[tuple[int, P]]:
    """``items`` (simulation time s, payload) as (log time ns, payload), stably sorted by
    time (in linear time when they are in order already, as they usually are)."""
    return iter(sorted(((sim.host_ns(t), payload) for t, payload in items), key=lambda r: r[0]))


def _checked(items: Iterator[tuple[int, P]]) -> Iterator[tuple[int, P]]:
    """``items``, made in time order by construction, checked to be (an error otherwise)."""
    last = -1
    for ns, payload in items:
        if ns < last:
            raise RuntimeError("simulated records out of time order")
        last = ns
        yield ns, payload


def _numbered(kind: int, items: Iterator[tuple[int, Payload]]) -> Iterator[Record]:
    """``items`` as records of ``kind``, numbered in their order."""
    for i, (ns, payload) in enumerate(items):
        yield ns, kind, i, payload


def write_log(sim: Simulation, path: str | Path | IO[bytes], *, command: str | None = None,
              compression: str = "zstd") -> LogSummary:
    """Write ``sim`` to ``path`` (see the module docstring); return what was written."""
    late = sim.settings.install.nav_time_offset_ms * 1e-3  # NAV-to-host time offset, s
    nav_family = sim.settings.sim.nav_device
    mcu = registration("mcu").log_decoder({})
    nav = registration(nav_family).log_decoder({})
    with LogWriter(path, compression=compression, source="simulate", command=command) as w:
        out = WriterOutput(w)

        def feed(family: str, direction: str, decoder: LogDecoder, ns: int, data: bytes
                 ) -> None:
            w.write_raw(family, direction, data, ns)
            decode_chunk(decoder, topics.raw_topic(family, direction), data, ns, out)

        w.add_metadata("simulator", sim.metadata())
        w.write_config(sim.config)
        w.write_map(sim.config.reflectors, sim.start_ns)
        # a record's kind says what its payload is (:data:`Payload`, as :func:`_records`
        # makes them)
        for ns, order, _, payload in _records(sim):
            if order == _TRUTH:
                sample = cast("TruthSample", payload)
                w.write(topics.TRUTH, pose_in_frame(ns, sample.x, sample.y, sample.heading),
                        ns)
            elif order == _FAULT:
                fault = cast("FaultEvent", payload)
                w.write_diagnostic(fault.source, fault.kind, fault.message, ns, level=3,
                                   details=fault.details)
            elif order == _MCU:
                feed("mcu", "rx", mcu, ns, cast("bytes", payload))
            elif order in (_NAV_TX, _NAV_RX):
                feed(nav_family, "tx" if order == _NAV_TX else "rx", nav, ns,
                     cast("bytes", payload))
            else:
                scan = cast("NavScan", payload)
                w.write(topics.NAV_REFLECTORS,
                        reflector_scan_message(sim.host_ns(scan.start + late),
                                               scan.period, scan.observations), ns)
        end_ns = sim.host_ns(sim.duration)
        finish_decoding(mcu, out, end_ns)
        finish_decoding(nav, out, end_ns)
        total = w.message_count
    return LogSummary(path=str(path), messages=total, duration_s=sim.duration,
                      faults=sim.fault_counts())

