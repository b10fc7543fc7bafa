"""The NAV200 as a physical device: a rotating head that measures reflectors one by one, and a
pose solver that treats one revolution's measurements as if they were simultaneous.

Per revolution (scan) k, starting at ``t_k`` with the head at ``scan_start`` in the vehicle
frame and turning at ``Omega = 2 pi f`` relative to the vehicle, the beam passes reflector i
when the head angle equals the reflector's bearing in the head frame. Both move (the vehicle
drives and turns during the 125 ms), so the instant is found by fixed-point iteration on

    t_ki = t_k + wrap_2pi(s (alpha_i(t_ki) - scan_start)) / Omega,

where ``alpha_i(t)`` is the bearing of reflector i seen from the head at time t and ``s`` is
+1 for a counter-clockwise head. Range and bearing are those of that instant plus noise.
The device then matches each observation to its stored map and solves the head pose
(x, y, heading) by weighted Gauss-Newton least squares over all observations of the scan, with
no motion compensation: this is where the error while turning comes from (``docs/simulator.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import TWO_PI, wrap_angle
from lgvtool.config import Vehicle
from lgvtool.sim.faults import Landmarks, Occlusions
from lgvtool.sim.kinematics import FloatArray, Trajectory
from lgvtool.sim.settings import NavSettings

NO_POSITION = 0xFF
"""Quality byte of a scan without a valid position."""

@dataclass(frozen=True)
class Scans:
    """The observations of every revolution, as padded arrays of shape (scans, landmarks).

    Entry [k, j] is landmark j in scan k; ``seen`` says whether the head detected it.
    """

    start: FloatArray
    """Start of each revolution, s."""
    period: float
    """Duration of one revolution, s."""
    seen: NDArray[np.bool_]
    time_in_scan: FloatArray
    """Measurement instant after the scan start, s."""
    range: FloatArray
    """Measured range to the landmark centre, m."""
    bearing: FloatArray
    """Measured bearing in the head frame, CCW from the head's x axis, rad in (-pi, pi]."""
    landmark: NDArray[np.intp]
    """Landmark index of each column (the same for every scan)."""
    matched: NDArray[np.intp]
    """Index of the stored reflector the device matched, -1 when unmatched or not seen."""
    hidden: NDArray[np.bool_]
    """In range but hidden by an occlusion stretch."""

    def __len__(self) -> int:
        return len(self.start)

    def take(self, rows: slice | NDArray[np.intp]) -> Scans:
        """The revolutions ``rows`` (a slice or indices)."""
        return replace(self, start=self.start[rows], seen=self.seen[rows],
                       time_in_scan=self.time_in_scan[rows], range=self.range[rows],
                       bearing=self.bearing[rows], matched=self.matched[rows],
                       hidden=self.hidden[rows])


@dataclass(frozen=True)
class Solutions:
    """The device's pose solution of every revolution (the head's pose)."""

    available: FloatArray
    """Time from which the solution can be reported, s."""
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    """Head heading, rad in (-pi, pi]."""
    used: NDArray[np.int64]
    """Matched reflectors used in the fit."""
    valid: NDArray[np.bool_]
    quality: NDArray[np.int64]
    """Quality byte: 0..100, or 0xFF without a valid position."""
    rms: FloatArray
    """RMS position residual of the fit, m (NaN without a valid position)."""
    false_used: NDArray[np.bool_]
    """The fit used the shiny false reflector."""


def scan_starts(duration: float, nav: NavSettings, phase: float) -> FloatArray:
    """Start times of every complete revolution within [0, duration], s; ``phase`` in [0, 1)."""
    period = 1.0 / nav.rotation_hz
    first = phase * period
    n = max(0, math.floor((duration - first) / period))
    return first + period * np.arange(n, dtype=np.float64)


def measure(traj: Trajectory, vehicle: Vehicle, nav: NavSettings, marks: Landmarks,
            occl: Occlusions, noise: bool, false_detection: float,
            rng: np.random.Generator) -> Scans:
    """Simulate every revolution of the head over ``traj`` (see the module docstring).

    ``false_detection`` is the probability that the head sees a false landmark in a scan
    (a fault, so it holds with the noise off too).

    Random draws (phase, detection, range and bearing noise) are always made, scaled by zero
    when ``noise`` is off, so that switching a mechanism off leaves the other draws unchanged.
    """
    period = 1.0 / nav.rotation_hz
    starts = scan_starts(traj.t[-1], nav, float(rng.random()))
    s, m = len(starts), len(marks)
    draws = _Draws(u_detect=rng.random((s, m)), n_range=rng.standard_normal((s, m)),
                   n_bearing=rng.standard_normal((s, m)), u_grid=rng.random(s))
    blocks = [_measure_rows(traj, vehicle, nav, marks, occl, noise, false_detection, starts,
                            draws, slice(k, k + ROWS_PER_BLOCK))
              for k in range(0, max(s, 1), ROWS_PER_BLOCK)]
    return Scans(start=starts, period=period, landmark=np.arange(m),
                 **{f: np.concatenate([b[f] for b in blocks]) for f in blocks[0]})


ROWS_PER_BLOCK = 2048
"""Revolutions the head model computes at once: its temporaries are (revolutions, landmarks)
arrays, so a long run is computed a block at a time (the same numbers, row by row)."""


@dataclass(frozen=True)
class _Draws:
    """The random numbers of every revolution, drawn at once (shapes (scans, landmarks), the
    grid phase (scans,)): uniform detection draws, standard normal range and bearing noise."""

    u_detect: FloatArray
    n_range: FloatArray
    n_bearing: FloatArray
    u_grid: FloatArray


def _measure_rows(traj: Trajectory, vehicle: Vehicle, nav: NavSettings, marks: Landmarks,
                  occl: Occlusions, noise: bool, false_detection: float, all_starts: FloatArray,
                  draws: _Draws, rows: slice) -> dict[str, Any]:
    """The :class:`Scans` fields (but ``start``, ``period`` and ``landmark``) of the
    revolutions ``rows``."""
    period = 1.0 / nav.rotation_hz
    omega_head = TWO_PI * nav.rotation_hz
    sign = -1.0 if nav.clockwise else 1.0
    start_angle = math.radians(nav.scan_start_deg)
    starts = all_starts[rows]
    s, m = len(starts), len(marks)
    lx, ly = marks.x[None, :], marks.y[None, :]

    def bearing_at(times: FloatArray) -> tuple[FloatArray, FloatArray]:
        hx, hy, hth = traj.point_at(times, vehicle.nav_x, vehicle.nav_y)
        dx, dy = lx - hx, ly - hy
        return np.hypot(dx, dy), np.arctan2(dy, dx) - (hth + vehicle.nav_yaw)

    t0 = np.broadcast_to(starts[:, None], (s, m))
    if nav.skew:
        t = t0 + 0.5 * period
        for _ in range(4):
            _, alpha = bearing_at(t)
            t = t0 + (sign * (alpha - start_angle)) % TWO_PI / omega_head
    else:
        t = t0 + 0.5 * period
    true_range, alpha = bearing_at(t)
    scale = 1.0 if noise else 0.0
    grid = draws.u_grid[rows] if noise else np.zeros(s)
    centre_range, centre_bearing, hits = apparent_centre(
        true_range, alpha, nav.reflector_radius_mm * 1e-3, math.radians(nav.angle_step_deg),
        grid)
    sigma_r = (nav.sigma_range_mm + nav.sigma_range_per_m_mm * true_range) * 1e-3
    meas_range = centre_range + scale * sigma_r * draws.n_range[rows]
    meas_bearing = wrap_angle(centre_bearing
                           + scale * math.radians(nav.sigma_bearing_deg) * draws.n_bearing[rows])
    landmark = np.broadcast_to(np.arange(m)[None, :], (s, m))
    in_range = (true_range >= nav.range_min) & (true_range <= nav.range_max)
    hidden = in_range & occl.hidden(landmark, t)
    p_real = nav.detection_probability * range_falloff(true_range, nav.detection_range_m)
    p_real = p_real if noise else np.ones((s, m))
    p_detect = np.where(marks.is_false[None, :], false_detection, p_real)
    detected = (draws.u_detect[rows] < p_detect) & (hits > 0)
    seen = in_range & ~hidden & detected
    matched = _match(traj, vehicle, nav, marks, t, meas_range, meas_bearing, seen)
    return {"seen": seen, "time_in_scan": t - t0, "range": meas_range, "bearing": meas_bearing,
            "matched": matched, "hidden": hidden}


def range_falloff(r: FloatArray, full_range: float) -> FloatArray:
    """Factor on the detection probability at range ``r`` (m): 1 up to ``full_range`` m, then
    ``(full_range / r)^2``: the echo energy of a reflector narrower than the beam falls with
    the square of the range, and ever more echoes stay below the detection threshold (0: no
    fall-off)."""
    if full_range <= 0.0:
        return np.ones_like(r)
    return np.minimum(1.0, (full_range / np.maximum(r, 1e-9)) ** 2)


def apparent_centre(r: FloatArray, alpha: FloatArray, radius: float, step: float,
                    phase: FloatArray) -> tuple[FloatArray, FloatArray, NDArray[np.int64]]:
    """Where the head puts a cylinder of ``radius`` m whose centre is at range ``r`` (m) and
    bearing ``alpha`` (rad), when its pulses leave every ``step`` rad at the head angles
    ``(k + phase) step`` (``phase`` in [0, 1) per revolution, one per row).

    The pulses that hit the cylinder are those within its angular half width
    ``w = asin(radius / r)`` of the centre. The bearing is the middle of the first and the last
    of them (the edges of the return, quantised to the pulse grid); the range is the mean
    distance to the surface each of them hits, plus ``radius``: the apparent centre lies behind
    the true one, by about ``radius (1 - pi/4)`` (11 mm for the paper's cylinders) where many
    pulses hit, and by 0 to ``radius`` depending on where the few pulses fall at long range.
    Returns (range m, bearing rad, number of pulses that hit). With ``step`` 0 the centre
    itself (every cylinder hit).
    """
    if step <= 0.0 or radius <= 0.0:
        return r, alpha, np.ones(r.shape, dtype=np.int64)
    ph = phase[:, None]
    w = np.arcsin(np.minimum(radius / np.maximum(r, radius), 1.0))
    first = np.ceil((alpha - w) / step - ph)
    last = np.floor((alpha + w) / step - ph)
    hits = np.maximum(last - first + 1.0, 0.0).astype(np.int64)
    bearing = np.where(hits > 0, 0.5 * (first + last + 2.0 * ph) * step, alpha)
    total = np.zeros(r.shape)
    for k in range(int(hits.max(initial=0))):
        beta = (first + k + ph) * step - alpha
        on = k < hits
        p = r * np.sin(beta)
        surface = r * np.cos(beta) - np.sqrt(np.maximum(radius * radius - p * p, 0.0))
        total += np.where(on, surface, 0.0)
    rng = np.where(hits > 0, total / np.maximum(hits, 1) + radius, r)
    return rng, bearing, hits


def _match(traj: Trajectory, vehicle: Vehicle, nav: NavSettings, marks: Landmarks,
           t: FloatArray, meas_range: FloatArray, meas_bearing: FloatArray,
           seen: NDArray[np.bool_]) -> NDArray[np.intp]:
    """The device's data association: each observation, placed in the map with the head pose
    at its instant (a device that tracks its motion predicts it well), goes to the nearest
    stored reflector within ``nav.gate``; when two observations claim one reflector in a scan,
    the closer keeps it (a shiny object steals a reflector's match only when that reflector is
    missed or hidden, or when the object lies closer to where the reflector is expected)."""
    hx, hy, hth = traj.point_at(t, vehicle.nav_x, vehicle.nav_y)
    hth = hth + vehicle.nav_yaw
    ox = hx + meas_range * np.cos(hth + meas_bearing)
    oy = hy + meas_range * np.sin(hth + meas_bearing)
    real = np.nonzero(~marks.is_false)[0]
    dist = np.full(ox.shape, np.inf)
    nearest = np.zeros(ox.shape, dtype=np.intp)
    for j in real:  # running nearest stored reflector, memory of one (scans, landmarks) array
        d = np.hypot(ox - marks.map_x[j], oy - marks.map_y[j])
        closer = d < dist
        dist = np.where(closer, d, dist)
        nearest = np.where(closer, j, nearest)
    ok = seen & (dist <= nav.gate)
    matched = np.where(ok, nearest, -1)
    rows, cols = np.nonzero(ok)
    order = np.lexsort((dist[rows, cols], matched[rows, cols], rows))
    rows, cols = rows[order], cols[order]
    target = matched[rows, cols]
    repeat = np.zeros(len(rows), dtype=bool)
    repeat[1:] = (rows[1:] == rows[:-1]) & (target[1:] == target[:-1])
    matched[rows[repeat], cols[repeat]] = -1
    return matched


def compensate(scans: Scans, rows: NDArray[np.intp], vx: float, vy: float, omega: float
               ) -> Scans:
    """The revolutions ``rows`` of ``scans`` as a device that compensates its motion sees them.

    Given the velocity of the head (``vx``, ``vy`` in m/s along the vehicle's axes, ``omega`` in
    rad/s, as the host sends it with Pv/Pw/PV), each observation, measured ``dt`` s from
    mid-revolution, is moved into the head frame at mid-revolution: the point ``r (cos b, sin b)``
    becomes ``(vx dt, vy dt) + R(omega dt) r (cos b, sin b)`` (constant velocity, first order).
    With the true velocity this removes the skew; with a wrong one it leaves or adds some.
    """
    dt = scans.time_in_scan[rows] - 0.5 * scans.period
    turned = scans.bearing[rows] + omega * dt
    px = vx * dt + scans.range[rows] * np.cos(turned)
    py = vy * dt + scans.range[rows] * np.sin(turned)
    return replace(scans.take(rows), range=np.hypot(px, py),
                   bearing=wrap_angle(np.arctan2(py, px)))


def solve(scans: Scans, traj: Trajectory, vehicle: Vehicle, nav: NavSettings,
          marks: Landmarks) -> Solutions:
    """Weighted Gauss-Newton fit of the head pose for every scan at once, from the matched
    observations and the stored map, as if all were measured at one instant.

    Like the NAV200's PC setting, only the ``nav.max_reflectors`` nearest matched reflectors
    (by measured range) are used; 0 uses all.

    Starts from the true head pose at mid-scan (the device's tracked estimate) and iterates
    ``nav.solver_iterations`` times. A scan is valid with at least ``nav.min_reflectors``
    matched reflectors. Quality falls linearly from 100 to 0 as the RMS position residual
    grows to ``nav.quality_rms_mm``. Computed :data:`ROWS_PER_BLOCK` scans at a time.
    """
    parts = [_solve_rows(scans.take(slice(k, k + ROWS_PER_BLOCK)), traj, vehicle, nav, marks)
             for k in range(0, max(len(scans), 1), ROWS_PER_BLOCK)]
    return Solutions(**{f.name: np.concatenate([getattr(p, f.name) for p in parts])
                        for f in fields(Solutions)})


def _solve_rows(scans: Scans, traj: Trajectory, vehicle: Vehicle, nav: NavSettings,
                marks: Landmarks) -> Solutions:
    """:func:`solve` of the scans ``scans`` at once."""
    use = scans.matched >= 0
    if nav.max_reflectors > 0:
        ranked = np.argsort(np.where(use, scans.range, np.inf), axis=1, kind="stable")
        rank = np.empty_like(ranked)
        np.put_along_axis(rank, ranked, np.arange(ranked.shape[1])[None, :], axis=1)
        use = use & (rank < nav.max_reflectors)
    idx = np.where(use, scans.matched, 0)
    mx = np.where(use, marks.map_x[idx], 0.0)
    my = np.where(use, marks.map_y[idx], 0.0)
    n_used = use.sum(axis=1)
    valid = n_used >= nav.min_reflectors
    mid = scans.start + 0.5 * scans.period
    x, y, th = traj.point_at(mid, vehicle.nav_x, vehicle.nav_y)
    x, y, th = x.copy(), y.copy(), th + vehicle.nav_yaw
    wr = 1.0 / (nav.solver_sigma_range_mm * 1e-3) ** 2
    wb = 1.0 / math.radians(nav.solver_sigma_bearing_deg) ** 2
    w = use.astype(np.float64)
    eye = np.eye(3)[None, :, :]
    for _ in range(nav.solver_iterations):
        dx, dy = mx - x[:, None], my - y[:, None]
        q = np.where(use, dx * dx + dy * dy, 1.0)
        r = np.sqrt(q)
        res_r = np.where(use, scans.range - r, 0.0)
        res_b = np.where(use, wrap_angle(scans.bearing - (np.arctan2(dy, dx) - th[:, None])), 0.0)
        jr = np.stack([-dx / r, -dy / r, np.zeros_like(r)], axis=-1)
        jb = np.stack([dy / q, -dx / q, -np.ones_like(r)], axis=-1)
        wr_j = (w * wr)[:, :, None]
        wb_j = (w * wb)[:, :, None]
        h = (np.einsum("sji,sjk->sik", jr * wr_j, jr) + np.einsum("sji,sjk->sik", jb * wb_j, jb))
        g = (np.einsum("sji,sj->si", jr * wr_j, res_r) + np.einsum("sji,sj->si", jb * wb_j, res_b))
        h = np.where(valid[:, None, None], h, eye)
        g = np.where(valid[:, None], g, 0.0)
        step = np.linalg.solve(h, g[:, :, None])[:, :, 0]
        x, y, th = x + step[:, 0], y + step[:, 1], th + step[:, 2]
    dx, dy = mx - x[:, None], my - y[:, None]
    r = np.hypot(dx, dy)
    res_r = np.where(use, scans.range - r, 0.0)
    res_b = np.where(use, wrap_angle(scans.bearing - (np.arctan2(dy, dx) - th[:, None])), 0.0)
    sq = res_r ** 2 + (r * res_b) ** 2
    rms = np.sqrt(sq.sum(axis=1) / np.maximum(n_used, 1))
    quality = np.clip(np.round(100.0 * (1.0 - rms / (nav.quality_rms_mm * 1e-3))), 0, 100)
    quality = np.where(valid, quality, NO_POSITION).astype(np.int64)
    false_used = (use & marks.is_false[None, :]).any(axis=1) & valid
    return Solutions(available=scans.start + scans.period + nav.latency_s,
                     x=x, y=y, heading=wrap_angle(th), used=n_used.astype(np.int64),
                     valid=valid, quality=quality, rms=np.where(valid, rms, np.nan),
                     false_used=false_used)
