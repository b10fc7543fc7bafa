"""A simulation as one time-ordered stream of device-side events.

This is what a device emulator plays in real time, and what the log writer consumes along
with the host side (:mod:`lgvtool.sim.logfile`): the true pose of O, each MCU frame when the MCU
sends it (and the bytes the link delivers), each completed revolution of the NAV200 head with
its reflector observations (each with the id the device gave it, never its true identity), and
each pose solution from the moment the device can report it.
Times are simulation seconds (0 = start of the run).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

if TYPE_CHECKING:
    from lgvtool.sim.simulation import Simulation


@dataclass(frozen=True, slots=True)
class TruthSample:
    """True pose of O at ``t``: x, y in m, heading in rad (wrapped to (-pi, pi])."""

    t: float
    x: float
    y: float
    heading: float


@dataclass(frozen=True, slots=True)
class McuSend:
    """The MCU starts sending frame ``seq`` at ``t``; ``delivered`` is what the link passes on
    (None when lost, different from ``data`` when corrupted)."""

    t: float
    seq: int
    data: bytes
    delivered: bytes | None


NO_ID = -1
"""The id of an observation the device did not identify (as /nav/reflectors writes it; the
NAV350's global id 0xFFFF)."""


@dataclass(frozen=True, slots=True)
class Observation:
    """One reflector measured during a revolution: range m, bearing rad in the head frame,
    time after the revolution start s, and the id the device gives it: the stored-layout id of
    the reflector it matched, :data:`NO_ID` where it matched none (never the true identity,
    which stays in :class:`~lgvtool.sim.simulation.Simulation`; see :func:`device_ids`)."""

    range: float
    bearing: float
    time_in_scan: float
    id: int
    echo: float = 1.0
    """Strength of its echo relative to a clean reflector within full range, 0..1
    (:func:`echo_levels`)."""


@dataclass(frozen=True, slots=True)
class NavScan:
    """A completed revolution of the head: it ended at ``t`` and started at ``start``."""

    t: float
    start: float
    period: float
    observations: tuple[Observation, ...]


@dataclass(frozen=True, slots=True)
class NavSolution:
    """The device's pose of its head from revolution ``index``, reportable from ``t`` on."""

    t: float
    index: int
    x: float
    y: float
    heading: float
    quality: int
    reflectors_used: int
    valid: bool


Event = TruthSample | McuSend | NavScan | NavSolution


def truth_samples(sim: Simulation, rate_hz: float) -> Iterator[TruthSample]:
    """The true pose of O every 1/``rate_hz`` s from 0 to the end of the run."""
    n = int(np.floor(sim.duration * rate_hz + 1e-9)) + 1
    t = np.arange(n, dtype=np.float64) / rate_hz
    truth = sim.truth.sampled(t).wrapped()
    x, y, th = truth.x, truth.y, truth.heading
    for i in range(n):
        yield TruthSample(float(t[i]), float(x[i]), float(y[i]), float(th[i]))


def mcu_sends(sim: Simulation) -> Iterator[McuSend]:
    """Every MCU frame at the time the MCU sends it."""
    out = sim.mcu
    for i in range(len(out)):
        yield McuSend(float(out.t[i]), out.frames[i].seq, out.data[i],
                      sim.mcu_traffic.delivered[i])


def device_ids(sim: Simulation, rows: slice | None = None) -> NDArray[np.int64]:
    """The id the device reports for each entry of ``sim.scans`` (revolutions ``rows``, shape
    (revolutions, landmarks)): the stored-layout id of the reflector it matched, :data:`NO_ID`
    where it matched none (or did not see the landmark). With ``nav.identification = "truth"``
    (model 1's kind world) the true id instead: the reflector's own, :data:`NO_ID` for the
    shiny object."""
    sc = sim.scans
    rows = slice(None) if rows is None else rows
    marks = sim.landmarks
    if sim.settings.nav.identification == "truth":
        true_ids = np.where(marks.is_false, NO_ID, marks.ids)
        return np.broadcast_to(true_ids[None, :], sc.seen[rows].shape)
    layout_ids = np.append(marks.ids, NO_ID)  # index -1 (unmatched): NO_ID
    return layout_ids[sc.matched[rows]]


def echo_levels(sim: Simulation, rows: slice | None = None) -> NDArray[np.float64]:
    """The echo strength of each entry of ``sim.scans`` (revolutions ``rows``, shape
    (revolutions, landmarks)) relative to a clean reflector within full range, 0..1: the
    head model's own detection model read as an echo, the landmark's detection probability
    (a weak reflector's own, an object not in the layout its own) over that of a clean one
    (``nav.detection_probability``), times the fall-off with the measured range (m)
    (:func:`~lgvtool.sim.nav_model.range_falloff`)."""
    from lgvtool.sim.nav_model import range_falloff

    sc = sim.scans
    rows = slice(None) if rows is None else rows
    nav = sim.settings.nav
    own = sim.landmarks.detection
    clean = nav.detection_probability
    strength = np.where(np.isnan(own), 1.0, own / clean if clean > 0.0 else own)
    level: NDArray[np.float64] = (np.clip(strength, 0.0, 1.0)[None, :]
                                  * range_falloff(np.abs(sc.range[rows]), nav.detection_range_m))
    return level


def nav_scans(sim: Simulation, block: int = 1024) -> Iterator[NavScan]:
    """Every revolution at its end, with the reflectors the head detected in it, in the order
    it measured them, each with the device's id (:func:`device_ids`; made ``block``
    revolutions at a time, so a long run is never held as objects)."""
    sc = sim.scans
    for k0 in range(0, len(sc), block):
        rows = slice(k0, k0 + block)
        order = np.argsort(np.where(sc.seen[rows], sc.time_in_scan[rows], np.inf), axis=1,
                           kind="stable")
        counts = sc.seen[rows].sum(axis=1).tolist()
        ranges = np.take_along_axis(sc.range[rows], order, axis=1).tolist()
        bearings = np.take_along_axis(sc.bearing[rows], order, axis=1).tolist()
        times = np.take_along_axis(sc.time_in_scan[rows], order, axis=1).tolist()
        ids = np.take_along_axis(device_ids(sim, rows), order, axis=1).tolist()
        echoes = np.take_along_axis(echo_levels(sim, rows), order, axis=1).tolist()
        starts = sc.start[rows].tolist()
        for k, start in enumerate(starts):
            obs = tuple(Observation(ranges[k][i], bearings[k][i], times[k][i], ids[k][i],
                                    echoes[k][i])
                        for i in range(counts[k]))
            yield NavScan(start + sc.period, start, sc.period, obs)


def nav_solutions(sim: Simulation) -> Iterator[NavSolution]:
    """Every pose solution at the time it becomes reportable."""
    s = sim.solutions
    for k in range(len(s.available)):
        yield NavSolution(float(s.available[k]), k, float(s.x[k]), float(s.y[k]),
                          float(s.heading[k]), int(s.quality[k]), int(s.used[k]),
                          bool(s.valid[k]))


def stream(sim: Simulation, truth_rate_hz: float | None = None) -> Iterator[Event]:
    """All device-side events of ``sim`` in time order (ties: truth, MCU, scans, solutions).

    ``truth_rate_hz`` defaults to the run's ``sim.truth_rate_hz``.
    """
    rate = truth_rate_hz if truth_rate_hz is not None else sim.settings.sim.truth_rate_hz
    sources = (truth_samples(sim, rate), mcu_sends(sim), nav_scans(sim), nav_solutions(sim))
    return heapq.merge(*sources, key=lambda e: e.t)
