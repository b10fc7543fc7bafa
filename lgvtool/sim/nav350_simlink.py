"""The simulator's NAV350 mode: the host side of a simulated run as a NAV350 recording.

With ``--set sim.nav_device=nav350`` the simulated head is a NAV350: the recorder's own host
session (:class:`~lgvtool.devices.nav350.nav350_session.Nav350Session`) talks to the shared device model
(:class:`~lgvtool.devices.nav350.nav350_device.Nav350Device`) over a simulated TCP link, in simulation
time, and the log gets the traffic both ways (/nav350/tx, /nav350/rx) and what the NAV350's
log decoder makes of it (/nav/pose, /nav/reflectors), as ``record --nav350`` writes them.
The host polls with mask 1 (pose and landmarks, no scan: a simulated DIST1 scan carries no
information the estimators use). The device clock runs ``DRIFT_PPM`` fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from lgvtool.devices.nav350 import nav350_telegrams as tg
from lgvtool.devices.nav350.nav350_device import Nav350Device, Observation, Revolution, RevolutionSource
from lgvtool.devices.nav350.nav350_session import Nav350Session, Nav350Settings
from lgvtool.devices.nav350.nav350_stream import Nav350StreamDecoder

if TYPE_CHECKING:
    from lgvtool.sim.simulation import Simulation

__all__ = ["DRIFT_PPM", "LINK_LATENCY", "nav350_traffic"]

#: Device clock error of the simulated NAV350, ppm (fast), and its reading at t = 0, ms.
DRIFT_PPM, OFFSET_MS = 50.0, 987_654
#: One-way delay of the simulated Ethernet link, s, and its rate, bytes/s (100 Mbit/s).
LINK_LATENCY, LINK_RATE = 0.0005, 12.5e6


def _source(sim: Simulation) -> RevolutionSource:
    from lgvtool.sim.event_stream import nav_scans, nav_solutions

    revs = []
    for scan, sol in zip(nav_scans(sim), nav_solutions(sim), strict=True):
        obs = tuple(Observation(o.range, o.bearing, o.time_in_scan, o.id, o.echo)
                    for o in scan.observations)
        revs.append(Revolution(scan.start, scan.period, sol.t, sol.x, sol.y, sol.heading,
                               sol.valid, sol.quality, sol.reflectors_used, obs))
    return RevolutionSource(revs)


def nav350_traffic(sim: Simulation) -> list[tuple[float, str, bytes]]:
    """Every chunk of the simulated NAV350 link: (time s, 'tx' or 'rx', bytes), in order."""
    cfg = sim.config
    layout = {r.id: tg.LayoutLandmark(round(r.x * 1000), round(r.y * 1000), 1, 1,
                                      round(r.radius * 2000), (r.layer,))
              for r in cfg.reflectors if 0 < r.id < 0xFFFF}
    a = cfg.area
    dev = Nav350Device(_source(sim), layout, offset_ms=OFFSET_MS, drift_ppm=DRIFT_PPM,
                       area=(a.x_min, a.y_min, a.x_max, a.y_max))
    session = Nav350Session(Nav350Settings(mask=1))
    requests = Nav350StreamDecoder(deliver_unknown=True)
    out: list[tuple[float, str, bytes]] = []
    inflight: list[tuple[float, bytes]] = []
    end = float(sim.duration)
    t = float(sim.settings.nav.poll_start_s)
    session.link_up(t)

    def deliver(at: float, raw: bytes) -> None:
        inflight.append((at + LINK_LATENCY + len(raw) / LINK_RATE, raw))

    while t <= end:
        req = session.poll(t)
        if req is not None:
            raw = req.encode()
            out.append((t, "tx", raw))
            arrive = t + LINK_LATENCY + len(raw) / LINK_RATE
            for r in requests.feed(raw):
                for rep in dev.handle(r, arrive):
                    deliver(arrive, rep)
        for rep in dev.due(t):
            deliver(t, rep)
        inflight.sort(key=lambda x: x[0])
        while inflight and inflight[0][0] <= t:
            _, rep = inflight.pop(0)
            out.append((t, "rx", rep))
            session.feed(rep, t)
        session.pop_events()
        if req is not None:
            continue
        times = [session.next_deadline(t), *(x[0] for x in inflight[:1])]
        nd = dev.next_due()
        if nd is not None:
            times.append(nd)
        t = max(t + 1e-6, min(times))
    return out

