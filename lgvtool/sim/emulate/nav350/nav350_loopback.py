"""A self-check of the NAV350 chain: the virtual NAV350 and the recorder in one process.

:func:`loopback` serves a playback over loopback TCP (virtual NAV350 and MCU), records it with
``record --nav350``, and counts both sides: every good pose-data reply the device put on the
wire (decoded again from the server's transcript) against what the log holds, and the clock
estimate against the device's true clock (same monotonic clock on both sides).
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from lgvtool.devices.recorder import RecordResult
    from lgvtool.sim.emulate.emulator_playback import Playback

__all__ = ["LoopbackResult", "loopback"]


@dataclass
class LoopbackResult:
    """Counts of both sides and the clock errors (ms) of the poses, by time since the first."""

    device_poses: int
    device_landmarks: int
    log_poses: int
    log_landmarks: int
    faults: list[str]
    diagnostics: dict[str, int]
    clock_errors_ms: list[tuple[float, float]] = field(default_factory=list)
    reconnects: int = 0
    record: RecordResult | None = None
    """What the recorder returned (None: it did not finish)."""
    speed_tick_errors_ms: list[float] = field(default_factory=list)
    """Per mNPOSSetSpeed received: its tick minus the device clock on arrival, ms."""
    in_flight: int = 0
    """Pose replies the device sent after the recorder's last read (the recording had
    stopped), not counted on either side."""

    def clock_error_after(self, seconds: float) -> float:
        """Largest |error| (ms) of the poses logged ``seconds`` or more after the first."""
        errs = [abs(e) for t, e in self.clock_errors_ms if t >= seconds]
        return max(errs) if errs else float("nan")


def loopback(playback: Playback, out: Path, *, seconds: float, faults: tuple[str, ...] = (),
             drift_ppm: float = 50.0, offset_ms: int = 4_294_000_000,
             speed_input: bool = False, dialect: str = "binary") -> LoopbackResult:
    """Serve ``playback``, record ``seconds`` s into ``out``, count both sides."""
    from lgvtool.config import default_config
    from lgvtool.devices.layout_plan import LayoutPlan
    from lgvtool.devices.link_worker import LinkTiming
    from lgvtool.devices.nav350.nav350_registration import recorder_settings
    from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
    from lgvtool.devices.recorder import RecordedDevice, Recorder, RecorderSettings
    from lgvtool.log import LogReader, topics
    from lgvtool.sim.emulate.emulator_server import EmulatorServer, parse_fault
    from lgvtool.sim.emulate.nav350.nav350_emulator import VirtualNav350

    server = EmulatorServer(playback, nav=None, mcu="tcp://127.0.0.1:0",
                            nav350=f"tcp://127.0.0.1:0?drift_ppm={drift_ppm}"
                                   f"&offset_ms={offset_ms}",
                            faults=[parse_fault(f) for f in faults], seed=1)
    try:
        config = default_config()
        nav350 = recorder_settings({"nav350_url": server.urls["nav350"], "nav350_cola": dialect},
                                   layout=LayoutPlan(), speed_input=speed_input,
                                   reply_timeout=1.0, config=config)
        assert nav350 is not None  # its URL is given
        settings = RecorderSettings(output=out, devices={"mcu": RecordedDevice(server.urls["mcu"]),
                                                         "nav350": nav350},
                                    duration=seconds, config=config, status=False, fsync=False,
                                    timing=LinkTiming(backoff_max=0.5), overwrite=True)
        recorder = Recorder(settings)
        server.start()
        worker_box: list[Any] = []
        result_box: list[RecordResult] = []

        failed: list[BaseException] = []

        def run() -> None:
            try:
                result_box.append(recorder.run())
            except BaseException as exc:  # handed to the caller below
                failed.append(exc)

        th = threading.Thread(target=run, name="loopback-record")
        th.start()
        while th.is_alive() and not worker_box:
            worker_box.extend(w for w in recorder.workers if w.device == "nav350")
            time.sleep(0.01)
        th.join(seconds + 30.0)
    finally:
        server.stop()
    if failed:
        raise failed[0]
    emulator = server.emulators["nav350"]
    assert isinstance(emulator, VirtualNav350)
    device = emulator.device
    reader = LogReader(out)
    with server._lock:
        sent = [e for e in server.transcript if e.device == "nav350" and e.direction == "sent"]
    cutoff = max((m.log_time_ns for m in reader.messages([topics.NAV350_RX])), default=0)
    log_pose_ticks = {m.data.get("device_time_ms") for m in reader.messages([topics.NAV_POSE])}
    log_scan_ticks = {m.data.get("device_time_ms")
                      for m in reader.messages([topics.NAV_REFLECTORS])}
    dec = Nav350StreamDecoder()
    dev_poses = dev_marks = in_flight = 0
    for entry in sent:
        for t in dec.feed(entry.data):
            if t.name != "mNPOSGetData" or t.kind != "sAN":
                continue
            d = t.value
            pose_tick = None if d.info is None else d.info.timestamp_ms
            scan_tick = d.scans[0].timestamp_ms if d.scans else None
            missing = (d.pose is not None and pose_tick not in log_pose_ticks) or (
                d.landmarks is not None and scan_tick not in log_scan_ticks)
            # a reply sent as the recording stopped (after its last read) never arrived:
            # reported, not counted on either side
            if missing and entry.t_ns >= cutoff - 5_000_000:
                in_flight += 1
                continue
            if d.pose is not None:
                dev_poses += 1
            if d.landmarks is not None:
                dev_marks += sum(1 for m in d.landmarks.landmarks if m.polar is not None)
    log_poses = log_marks = 0
    errors: list[tuple[float, float]] = []
    diags: dict[str, int] = {}
    worker = worker_box[0] if worker_box else None
    first: float | None = None
    start = server._start or 0.0
    for m in reader.messages([topics.NAV_POSE, topics.NAV_REFLECTORS, topics.DIAGNOSTICS]):
        d = m.data
        if m.topic == topics.DIAGNOSTICS:
            diags[d["kind"]] = diags.get(d["kind"], 0) + 1
        elif m.topic == topics.NAV_REFLECTORS:
            log_marks += len(d["observations"])
        else:
            log_poses += 1 if d["valid"] else 0
            if "device_stamp" in d and worker is not None:
                est_mono = (d["device_stamp"]["sec"] * 1e9 + d["device_stamp"]["nsec"]
                            - worker._wall_minus_mono) / 1e9
                rx_mono = (m.log_time_ns - worker._wall_minus_mono) / 1e9
                run_t = (rx_mono - start) * server.speed
                true = start + device.time_of_tick(d["device_time_ms"] + 0.5, run_t) / server.speed
                first = rx_mono if first is None else first
                errors.append((rx_mono - first, (est_mono - true) * 1e3))
    speed = [float((tick - device.tick(t) + 2**31) % 2**32 - 2**31)
             for t, tick, _ in device.speed_inputs]
    return LoopbackResult(dev_poses, dev_marks, log_poses, log_marks,
                          [f"{t:.1f}s {f.kind}:{f.device}" for t, f in server.applied], diags,
                          errors, diags.get("link_up", 0), result_box[0] if result_box else None,
                          speed, in_flight)
