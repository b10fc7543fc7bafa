"""Helpers of the device tests: a circle drive built in code, logs, bounded subprocesses."""

from __future__ import annotations

import base64
import contextlib
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from lgvtool.config import Vehicle, paper_hall_reflectors
from lgvtool.devices.mcu.mcu_frame import McuFrame
from lgvtool.devices.nav200.nav200_device import PoseFix
from lgvtool.sim.emulate import McuChunk, Playback

REPO = Path(__file__).resolve().parents[2]


def circle_playback(duration: float = 20.0, *, mcu_period: float = 0.1,
                    nav_period: float = 0.125) -> Playback:
    """The paper's drive, made in code: O on a circle of R = h/tan(60 deg) at 0.36 m/s drive
    speed; MCU frames every ``mcu_period`` s, NAV200 head poses every ``nav_period`` s."""
    v_d, delta = 0.36, math.radians(60.0)
    veh = Vehicle()
    v, w = v_d * math.cos(delta), v_d * math.sin(delta) / veh.h
    r = veh.h / math.tan(delta)
    cx, cy = 11.0, 9.0
    k_left, k_right = veh.metres_per_count()
    mcu = []
    for i in range(int(duration / mcu_period) + 1):
        t = i * mcu_period
        left = (v - w * veh.track / 2) * t
        right = (v + w * veh.track / 2) * t
        frame = McuFrame.from_si(seq=i, mcu_time_ms=round(t * 1000) + 5000,
                                 enc_left=round(left / k_left), enc_right=round(right / k_right),
                                 gyro_rate_rad_s=w, steering_rad=delta, drive_speed_m_s=v_d,
                                 status=1)
        mcu.append(McuChunk(t + 0.004, frame.encode()))
    poses = []
    for i in range(int(duration / nav_period) + 1):
        t = i * nav_period
        th = w * t
        x, y = cx + r * math.sin(th), cy - r * math.cos(th)
        poses.append(PoseFix(t + 0.05, x + veh.nav_x * math.cos(th), y + veh.nav_x * math.sin(th),
                             math.atan2(math.sin(th), math.cos(th)), 90, 8, True))
    return Playback(mcu=tuple(mcu), poses=tuple(poses), reflectors=paper_hall_reflectors(),
                    duration=duration, source="test circle")


def raw_stream(log: Path, topic: str) -> bytes:
    """Concatenated raw bytes of ``topic`` in a log (salvaging a cut-off one)."""
    import warnings

    from lgvtool.log import LogReader

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    return b"".join(base64.b64decode(m.data["data"]) for m in reader.messages([topic]))


def messages(log: Path, topic: str) -> list:
    """Messages of ``topic`` (salvaging a cut-off log)."""
    import warnings

    from lgvtool.log import LogReader

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(log)
    return list(reader.messages([topic]))


class Procs:
    """Subprocesses of one test; whatever still runs at the end is killed."""

    def __init__(self) -> None:
        self.started: list[subprocess.Popen[str]] = []

    def lgvtool(self, *args: str, **kw: object) -> subprocess.Popen[str]:
        """Start ``lgvtool ARGS`` (stdout and stderr piped, text)."""
        env = dict(os.environ, PYTHONUNBUFFERED="1")
        p = subprocess.Popen([sys.executable, "-m", "lgvtool", *map(str, args)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             env=env, cwd=REPO, **kw)  # type: ignore[call-overload]
        self.started.append(p)
        return p

    def cleanup(self) -> None:
        for p in self.started:
            if p.poll() is None:
                p.kill()
            with contextlib.suppress(subprocess.TimeoutExpired):
                p.communicate(timeout=5)


def wait_for(predicate, timeout: float, interval: float = 0.05) -> bool:
    """Poll ``predicate`` until it is true or ``timeout`` s pass; its last value."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(interval)
    return bool(predicate())


def stop_process(p: subprocess.Popen[str], sig: int = signal.SIGTERM,
                 timeout: float = 10.0) -> tuple[str, str, float]:
    """Send ``sig``; wait (bounded) for the exit; return stdout, stderr and the seconds it
    took to exit."""
    t0 = time.monotonic()
    p.send_signal(sig)
    out, err = p.communicate(timeout=timeout)
    return out, err, time.monotonic() - t0


def start_emulator(tmp: Path, transport: str = "pty", *, duration: float = 10.0,
                   speed: float = 5.0, faults: tuple[str, ...] = (), **kw: object):
    """A running EmulatorServer (in a thread of the test process) playing the circle drive
    over pseudo-terminals (links in ``tmp/ports``) or loopback TCP. Stop it with ``.stop()``."""
    from lgvtool.sim.emulate import EmulatorServer, parse_fault

    port = "pty" if transport == "pty" else "tcp://127.0.0.1:0"
    link_dir = tmp / "ports"
    link_dir.mkdir(exist_ok=True)
    server = EmulatorServer(circle_playback(duration), nav=port, mcu=port, link_dir=link_dir,
                            speed=speed, faults=[parse_fault(f) for f in faults], seed=1,
                            **kw)  # type: ignore[arg-type]
    return server.start()


def record_args(server, out: Path, *extra: object, speed: float = 5.0) -> list[str]:
    """``lgvtool record`` arguments for the emulator's ports, polling at 0.45 s of run time."""
    urls = server.urls
    return ["record", "--nav", urls["nav200"], "--mcu", urls["mcu"], "-o", str(out),
            "--poll-period", f"{0.45 / speed:.4f}", "--no-status", *map(str, extra)]


def diagnostics(log: Path) -> list[dict]:
    """The /diagnostics messages of a log, as dicts."""
    return [m.data for m in messages(log, "/diagnostics")]
