"""The virtual NAV350 of ``lgvtool simulate serve``: a played run behind the NAV350 protocol.

:class:`VirtualNav350` decodes the host's bytes (both dialects), lets the shared device model
(:class:`~lgvtool.devices.nav350.nav350_device.Nav350Device`) answer, and injects the NAV350's own
faults (``sFA`` replies, error codes, bad checksums) on top of those of the link. The port spec
may carry the device clock: ``tcp://127.0.0.1:2112?drift_ppm=50&offset_ms=987654``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING
from urllib.parse import parse_qs

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_device import Nav350Device, Observation, Revolution, RevolutionSource
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder
from lgvtool.errors import InputError

if TYPE_CHECKING:
    from lgvtool.sim.emulate.emulator_playback import Playback
    from lgvtool.sim.emulate.endpoints import Endpoint

__all__ = ["CLOCK_KEYS", "VirtualNav350", "revolutions_of", "split_port_spec"]

#: Device-clock parameters a port spec may carry.
CLOCK_KEYS = ("drift_ppm", "offset_ms")
#: Landmark reply faults the emulator accepts (server fault kinds).
FAULT_KINDS = ("sfa", "error", "badsum")


def split_port_spec(spec: str) -> tuple[str, dict[str, float]]:
    """``tcp://H:P?drift_ppm=50`` -> (``tcp://H:P``, {"drift_ppm": 50.0}); InputError if bad."""
    base, _, query = spec.partition("?")
    out: dict[str, float] = {}
    if query:
        for key, values in parse_qs(query, keep_blank_values=True).items():
            if key not in CLOCK_KEYS:
                raise InputError(f"nav350: unknown port parameter {key!r} "
                                 f"(known: {', '.join(CLOCK_KEYS)})")
            try:
                value = float(values[-1])
            except ValueError:
                value = math.nan
            if not math.isfinite(value) or abs(value) > (1e5 if key == "drift_ppm" else 2**32):
                raise InputError(f"nav350: {key} must be a number, got {values[-1]!r}")
            out[key] = value
    return base, out


def revolutions_of(playback: Playback) -> RevolutionSource:
    """The revolutions of a :class:`~lgvtool.sim.emulate.emulator_playback.Playback`: its pose
    solutions with the reflectors of their revolution (none for a log's poses)."""
    revs = []
    scans = playback.scans
    for k, fix in enumerate(playback.poses):
        scan = scans[k] if k < len(scans) else None
        obs = () if scan is None else tuple(
            Observation(o.range, o.bearing, o.time_in_scan, o.id, o.echo)
            for o in scan.observations)
        start = fix.t if scan is None else scan.start
        period = 0.125 if scan is None else scan.period
        revs.append(Revolution(start, period, fix.t, fix.x, fix.y, fix.heading, fix.valid,
                               int(fix.quality), int(fix.reflectors_used), obs))
    resolve = None
    if playback.resolve is not None:
        pb_resolve = playback.resolve

        def resolve(k: int, vx: float, vy: float, omega: float
                    ) -> tuple[float, float, float, bool, int, int]:
            f = pb_resolve(k, vx, vy, omega)
            return f.x, f.y, f.heading, f.valid, int(f.quality), int(f.reflectors_used)

    return RevolutionSource(revs, resolve)


class VirtualNav350:
    """A :class:`Nav350Device` fed from a playback, with a request decoder and faults.

    :param playback: the run to play.
    :param drift_ppm: the device clock runs fast by this much, ppm.
    :param offset_ms: the device clock at run time 0, ms.
    """

    #: the device faults of ``simulate serve`` it takes (:meth:`apply_fault`)
    FAULT_KINDS: tuple[str, ...] = ("reset", "sfa", "error", "badsum")

    def __init__(self, playback: Playback, *, drift_ppm: float = 50.0,
                 offset_ms: int = 987_654) -> None:
        layout = {r.id: tg.LayoutLandmark(round(r.x * 1000), round(r.y * 1000), 1, 1,
                                          round(r.radius * 2000), (r.layer,))
                  for r in playback.reflectors if 0 < r.id < 0xFFFF}
        area = (-25.0, -25.0, 25.0, 25.0)
        if playback.reflectors:
            xs = [r.x for r in playback.reflectors]
            ys = [r.y for r in playback.reflectors]
            area = (min(xs) - 0.5, min(ys) - 0.5, max(xs) + 0.5, max(ys) + 0.5)
        self.device = Nav350Device(revolutions_of(playback), layout, offset_ms=int(offset_ms),
                                   drift_ppm=drift_ppm, area=area)
        self._decoder = Nav350StreamDecoder(deliver_unknown=True)

    def feed(self, data: bytes, t: float) -> list[bytes]:
        """Host bytes received at run time ``t`` s in, the replies due at once out."""
        out: list[bytes] = []
        for request in self._decoder.feed(data):
            out.extend(self.device.handle(request, t))
        return out

    def due(self, t: float) -> list[bytes]:
        """Replies that have become due by run time ``t`` s."""
        return self.device.due(t)

    def serve(self, ep: Endpoint | None, now: float, t: float | None,
              log: Callable[[str, bytes], None], silent: Callable[[], bool]) -> None:
        """One turn of ``simulate serve``: answer what the host sent on ``ep`` (None: not
        served) and send what has become due, at host time ``now`` s and run time ``t`` s
        (None: the clock has not started, run as at 0); ``log(direction, data)`` records the
        traffic, ``silent()`` keeps the replies in (they are dropped)."""
        if ep is None:
            return
        rt = 0.0 if t is None else t
        for _ in range(8):
            data = ep.read()
            if not data:
                break
            log("received", data)
            if not silent():
                for reply in self.feed(data, rt):
                    if ep.write(reply, now):
                        log("sent", reply)
        for reply in self.due(rt):
            if not silent() and ep.write(reply, now):
                log("sent", reply)

    def apply_fault(self, kind: str, t: float, arg: float, code: int) -> None:
        """A fault of :data:`FAULT_KINDS` at run time ``t`` s: ``reset`` power cycles it, the
        others go to :meth:`fault`."""
        if kind == "reset":
            self.reset()
        elif kind in self.FAULT_KINDS:
            self.fault(kind, t, arg, code)

    def reset(self) -> None:
        """Power cycle the device."""
        self.device.reset()
        self._decoder = Nav350StreamDecoder(deliver_unknown=True)

    def fault(self, kind: str, t: float, arg: float, code: int = 0) -> None:
        """Inject at run time ``t`` s: ``sfa`` (the next request is answered ``sFA arg``,
        default 13 'method server busy'), ``error`` (pose replies carry errorCode ``code``,
        default 7, for ``arg`` s) or ``badsum`` (the next ``arg`` replies have a bad checksum)."""
        f = self.device.faults
        if kind == "sfa":
            f.sfa_count, f.sfa_code = 1, int(arg) if arg >= 1 else 13
        elif kind == "error":
            f.error_code, f.error_until = (code if 1 <= code <= 7 else 7), t + arg
        elif kind == "badsum":
            f.bad_checksums += int(arg)
