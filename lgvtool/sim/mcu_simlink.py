"""The MCU's serial link to the host (115200 baud, 8N1), with its faults.

Each frame the MCU sends is lost with probability ``faults.mcu_drop_rate`` or gets one bit
flipped after its sync and length bytes with probability ``faults.mcu_corrupt_rate`` (so the
CRC fails and the host's decoder drops it); the rest reach the host in one or two reads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lgvtool.sim import faults as faultlib
from lgvtool.sim.faults import FaultEvent
from lgvtool.sim.mcu_model import McuOutput
from lgvtool.sim.serial_timing import BITS_8N1, Chunk, deliver
from lgvtool.sim.settings import FaultSettings, McuSettings


@dataclass(frozen=True)
class McuTraffic:
    """What the host reads from the MCU, and the faults on the way."""

    rx: tuple[Chunk, ...]
    delivered: tuple[bytes | None, ...]
    """Per frame, the bytes as delivered (None when lost)."""
    faults: tuple[FaultEvent, ...]


def simulate(out: McuOutput, mcu: McuSettings, fault: FaultSettings, noise: bool,
             rng_link: np.random.Generator, rng_faults: np.random.Generator) -> McuTraffic:
    """Deliver every frame of ``out`` to the host."""
    n = len(out)
    sizes = np.array([len(d) for d in out.data], dtype=np.int64)
    delivery = deliver(out.t, sizes, mcu.baud, BITS_8N1, mcu.host_latency_s,
                       mcu.host_jitter_s * (1.0 if noise else 0.0), mcu.split_probability,
                       rng_link)
    lost = faultlib.choose(fault.mcu_drop_rate, n, rng_faults)
    corrupt = faultlib.choose(fault.mcu_corrupt_rate, n, rng_faults) & ~lost
    rx: list[Chunk] = []
    delivered: list[bytes | None] = []
    events: list[FaultEvent] = []
    for i in range(n):
        t = float(out.t[i])
        seq = out.frames[i].seq
        if lost[i]:
            delivered.append(None)
            events.append(FaultEvent(t, "simulator", "mcu_frame_dropped",
                                     f"MCU frame seq {seq} lost on the link", {"seq": seq}))
            continue
        data = out.data[i]
        if corrupt[i]:
            data, byte, bit = faultlib.flip_bit(data, 4, len(data), rng_faults)
            events.append(FaultEvent(t, "simulator", "mcu_frame_corrupted",
                                     f"MCU frame seq {seq}: byte {byte} bit {bit} flipped",
                                     {"seq": seq, "byte_index": byte, "bit": bit}))
        delivered.append(data)
        rx.extend(delivery.chunks(i, data))
    return McuTraffic(rx=tuple(rx), delivered=tuple(delivered), faults=tuple(events))
