"""The NAV200 as a physical device: a rotating head that measures reflectors one by one, and a
pose solver that treats one revolution's measurements as if they were simultaneous.

Per revolution (scan) k, starting at ``t_k`` with the head at ``scan_start`` in the vehicle
frame and turning at ``Omega = 2 pi f`` relative to the vehicle, the beam passes reflector i
when the head angle equals the reflector's bearing in the head frame. Both move (the vehicle
drives and turns during the 125 ms), so the instant is found by fixed-point iteration on

    t_ki = t_k + wrap_2pi(s (alpha_i(t_ki) - scan_start)) / Omega,

where ``alpha_i(t)`` is the bearing of reflector i seen from the head at time t and ``s`` is
+1 for a counter-clockwise head. Range and bearing are those of that instant, as the head sees
the true site (:mod:`lgvtool.sim.site_model`: the reflector's true position and range offset,
the head leaning and tilted on the floor's slope), plus noise.

The device then identifies what it saw (:func:`locate`): it places each observation with its
own predicted pose (its previous solution carried forward by the motion since) and matches it
to the nearest reflector of its stored layout; and it solves the head pose (x, y, heading) by
weighted Gauss-Newton least squares over the matched observations of the scan, with no motion
compensation: this is where the error while turning comes from (``docs/simulator.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import TWO_PI, wrap_angle
from lgvtool.config import Vehicle
from lgvtool.sim.faults import Occlusions
from lgvtool.sim.kinematics import FloatArray, TrueDrive
from lgvtool.sim.settings import NavSettings
from lgvtool.sim.site_model import Floor, Landmarks, Site

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
    """Index of the stored reflector the device matched (a landmark index, whose layout id is
    what the device reports), -1 when unmatched or not seen (:func:`locate`)."""
    hidden: NDArray[np.bool_]
    """In range but hidden by an occlusion stretch."""
    prior: FloatArray
    """Per revolution, the error of the pose the device predicted and matched with: predicted
    minus true head pose (x m, y m, heading rad), shape (scans, 3); zero: the true pose."""

    def __len__(self) -> int:
        return len(self.start)

    def take(self, rows: slice | NDArray[np.intp]) -> Scans:
        """The revolutions ``rows`` (a slice or indices)."""
        return replace(self, start=self.start[rows], seen=self.seen[rows],
                       time_in_scan=self.time_in_scan[rows], range=self.range[rows],
                       bearing=self.bearing[rows], matched=self.matched[rows],
                       hidden=self.hidden[rows], prior=self.prior[rows])


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


def measure(traj: TrueDrive, vehicle: Vehicle, nav: NavSettings, site: Site,
            occl: Occlusions, noise: bool, rng: np.random.Generator) -> Scans:
    """Simulate every revolution of the head over ``traj`` on the true ``site`` (see the module
    docstring): what the head measures, not yet identified (``matched`` all -1; :func:`locate`
    identifies it).

    A landmark's own detection probability (``site.landmarks.detection``: a missing, weak
    or extra object of the site) is a fault, so it holds with the noise off too; a weak
    reflector's still falls off with range, an object not in the layout's does not.

    Random draws (phase, detection, range and bearing noise) are always made, scaled by zero
    when ``noise`` is off, so that switching a mechanism off leaves the other draws unchanged.
    """
    period = 1.0 / nav.rotation_hz
    starts = scan_starts(traj.end, nav, float(rng.random()))
    s, m = len(starts), len(site.landmarks)
    draws = _Draws(u_detect=rng.random((s, m)), n_range=rng.standard_normal((s, m)),
                   n_bearing=rng.standard_normal((s, m)), u_grid=rng.random(s))
    blocks = [_measure_rows(traj, vehicle, nav, site, occl, noise, starts,
                            draws, slice(k, k + ROWS_PER_BLOCK))
              for k in range(0, max(s, 1), ROWS_PER_BLOCK)]
    return Scans(start=starts, period=period, landmark=np.arange(m),
                 matched=np.full((s, m), -1, dtype=np.intp), prior=np.zeros((s, 3)),
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


@dataclass(frozen=True)
class Tilt:
    """The head on the floor's slope, per revolution (arrays of shape (scans,)): how far it
    leans (``lean_x``, ``lean_y`` m, horizontal), the tilt of its scan plane (``tan_tilt``,
    the tangent of the angle between the plane and the horizontal) and the world direction in
    which the plane rises (``uphill``, rad)."""

    lean_x: FloatArray
    lean_y: FloatArray
    tan_tilt: FloatArray
    uphill: FloatArray

    def encoder_angle(self, alpha: FloatArray, heading: FloatArray) -> FloatArray:
        """The head's angle (in its tilted scan plane, from its x axis) of the beam whose
        horizontal direction is ``alpha`` rad from the head's heading (``heading``, rad):
        ``b + atan2(cos(tau) sin(alpha - b), cos(alpha - b))`` with ``b`` the uphill direction
        seen from the head and ``tau`` the tilt, i.e. ``alpha - (tau^2 / 4) sin 2(alpha - b)``
        to second order (rows: revolutions)."""
        b = self.uphill[:, None] - heading
        d = alpha - b
        cos_tau = 1.0 / np.sqrt(1.0 + self.tan_tilt ** 2)
        return b + np.arctan2(cos_tau[:, None] * np.sin(d), np.cos(d))

    def slant(self, alpha: FloatArray, heading: FloatArray) -> FloatArray:
        """The factor ``1 / cos(e)`` by which the beam toward the horizontal direction ``alpha``
        (rad from the head's heading) is longer than its horizontal run to a vertical cylinder:
        the beam's elevation ``e`` has ``tan e = tan(tau) cos(alpha - b)``, so the factor is
        ``sqrt(1 + tan(tau)^2 cos(alpha - b)^2)``, about ``1 + tau^2 cos^2(alpha - b) / 2``."""
        c = self.tan_tilt[:, None] * np.cos(alpha - (self.uphill[:, None] - heading))
        return np.sqrt(1.0 + c * c)


def tilt(traj: TrueDrive, vehicle: Vehicle, floor: Floor, times: FloatArray) -> Tilt:
    """The head's lean and tilt at ``times`` (s), from the floor's slope ``g`` under the head's
    level position: the vehicle's up axis is the floor's normal ``(-g, 1) / |(-g, 1)|``, so the
    head, ``vehicle.nav_height`` up it, leans ``-nav_height g / sqrt(1 + g^2)`` (downhill) and
    its scan plane tilts by ``atan |g|``, rising uphill."""
    hx, hy, _ = traj.point_at(times, vehicle.nav_x, vehicle.nav_y)
    gx, gy = floor.slope(hx, hy)
    steep = np.hypot(gx, gy)
    lean = -vehicle.nav_height / np.sqrt(1.0 + steep * steep)
    return Tilt(lean_x=lean * gx, lean_y=lean * gy, tan_tilt=steep, uphill=np.arctan2(gy, gx))


def _measure_rows(traj: TrueDrive, vehicle: Vehicle, nav: NavSettings, site: Site,
                  occl: Occlusions, noise: bool, all_starts: FloatArray,
                  draws: _Draws, rows: slice) -> dict[str, FloatArray | NDArray[np.bool_]]:
    """The :class:`Scans` fields (but ``start``, ``period``, ``landmark``, ``matched`` and
    ``prior``) of the revolutions ``rows``."""
    period = 1.0 / nav.rotation_hz
    omega_head = TWO_PI * nav.rotation_hz
    sign = -1.0 if nav.clockwise else 1.0
    start_angle = math.radians(nav.scan_start_deg)
    marks = site.landmarks
    starts = all_starts[rows]
    s, m = len(starts), len(marks)
    lx, ly = marks.x[None, :], marks.y[None, :]
    head = None if site.floor.level else tilt(traj, vehicle, site.floor, starts + 0.5 * period)

    def view(times: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """At ``times``: the horizontal range of every landmark, the head's angle of it, its
        horizontal bearing from the head's heading, and that heading."""
        hx, hy, hth = traj.point_at(times, vehicle.nav_x, vehicle.nav_y)
        hth = hth + vehicle.nav_yaw
        if head is not None:
            hx, hy = hx + head.lean_x[:, None], hy + head.lean_y[:, None]
        dx, dy = lx - hx, ly - hy
        alpha = np.arctan2(dy, dx) - hth
        angle = alpha if head is None else head.encoder_angle(alpha, hth)
        return np.hypot(dx, dy), angle, alpha, hth

    t0 = np.broadcast_to(starts[:, None], (s, m))
    if nav.skew:
        t = t0 + 0.5 * period
        for _ in range(4):
            _, angle, _, _ = view(t)
            t = t0 + (sign * (angle - start_angle)) % TWO_PI / omega_head
    else:
        t = t0 + 0.5 * period
    true_range, angle, alpha, heading = view(t)
    scale = 1.0 if noise else 0.0
    grid = draws.u_grid[rows] if noise else np.zeros(s)
    centre_range, centre_bearing, hits = apparent_centre(
        true_range, angle, nav.reflector_radius_mm * 1e-3, math.radians(nav.angle_step_deg),
        grid)
    if head is not None:
        centre_range = centre_range * head.slant(alpha, heading)
    sigma_r = (nav.sigma_range_mm + nav.sigma_range_per_m_mm * true_range) * 1e-3
    meas_range = (centre_range + marks.range_bias[None, :]
                  + scale * sigma_r * draws.n_range[rows])
    meas_bearing = wrap_angle(centre_bearing
                           + scale * math.radians(nav.sigma_bearing_deg) * draws.n_bearing[rows])
    landmark = np.broadcast_to(np.arange(m)[None, :], (s, m))
    in_range = (true_range >= nav.range_min) & (true_range <= nav.range_max)
    hidden = in_range & occl.hidden(landmark, t)
    own = marks.detection[None, :]
    base = np.where(np.isnan(own), nav.detection_probability, own)
    p_real = base * range_falloff(true_range, nav.detection_range_m)
    p_real = p_real if noise else np.broadcast_to(np.where(np.isnan(own), 1.0, own), (s, m))
    p_detect = np.where(marks.is_false[None, :], own, p_real)
    detected = (draws.u_detect[rows] < p_detect) & (hits > 0)
    seen = in_range & ~hidden & detected
    return {"seen": seen, "time_in_scan": t - t0, "range": meas_range, "bearing": meas_bearing,
            "hidden": hidden}


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


def _match(scans: Scans, traj: TrueDrive, vehicle: Vehicle, nav: NavSettings,
           marks: Landmarks) -> NDArray[np.intp]:
    """The device's data association of ``scans``: each observation, placed in the layout
    frame with the pose the device predicted for its instant (the true head pose plus the
    revolution's ``prior`` error), goes to the nearest stored reflector within ``nav.gate``;
    when two observations claim one reflector in a scan, the closer keeps it and the other
    stays unidentified (a shiny object steals a reflector's match when that reflector is
    missed or hidden, or when the object lies closer to where the reflector is expected)."""
    t = scans.start[:, None] + scans.time_in_scan
    hx, hy, hth = traj.point_at(t, vehicle.nav_x, vehicle.nav_y)
    prior = scans.prior
    hx = hx + prior[:, 0:1]
    hy = hy + prior[:, 1:2]
    hth = hth + vehicle.nav_yaw + prior[:, 2:3]
    ox = hx + scans.range * np.cos(hth + scans.bearing)
    oy = hy + scans.range * np.sin(hth + scans.bearing)
    best = np.full(ox.shape, np.inf)
    nearest = np.zeros(ox.shape, dtype=np.intp)
    for j in np.nonzero(~marks.is_false)[0].tolist():  # running nearest stored reflector
        dx = ox - marks.map_x[j]
        d2 = dx * dx
        dx = oy - marks.map_y[j]
        d2 += dx * dx
        closer = d2 < best  # the first of equals, as the layout lists them
        np.copyto(best, d2, where=closer)
        np.copyto(nearest, j, where=closer)
    dist = np.hypot(ox - marks.map_x[nearest], oy - marks.map_y[nearest])
    ok = scans.seen & (dist <= nav.gate)
    matched = np.where(ok, nearest, -1)
    rows, cols = np.nonzero(ok)
    order = np.lexsort((dist[rows, cols], matched[rows, cols], rows))
    rows, cols = rows[order], cols[order]
    target = matched[rows, cols]
    repeat = np.zeros(len(rows), dtype=bool)
    repeat[1:] = (rows[1:] == rows[:-1]) & (target[1:] == target[:-1])
    matched[rows[repeat], cols[repeat]] = -1
    return matched


def _matched_rows(scans: Scans, rows: NDArray[np.intp], traj: TrueDrive, vehicle: Vehicle,
                  nav: NavSettings, marks: Landmarks) -> NDArray[np.intp]:
    """:func:`_match` of the revolutions ``rows``, :data:`ROWS_PER_BLOCK` at a time."""
    parts = [_match(scans.take(rows[k:k + ROWS_PER_BLOCK]), traj, vehicle, nav, marks)
             for k in range(0, len(rows), ROWS_PER_BLOCK)]
    if not parts:
        return np.zeros((0, len(scans.landmark)), dtype=np.intp)
    return np.concatenate(parts)


def locate(scans: Scans, traj: TrueDrive, vehicle: Vehicle, nav: NavSettings,
           marks: Landmarks) -> tuple[Scans, Solutions]:
    """The device's identification and pose fit of every revolution of ``scans``
    (:func:`measure`): the scans with ``matched`` and ``prior`` set, and the solutions.

    With ``nav.identification = "device"`` the device matches revolution k, when it ends, with
    its own prediction of its pose: its newest valid solution by then (of revolution k - 1,
    unless that one had no valid position or ``nav.latency_s`` exceeds a revolution) carried
    forward by the true motion since, i.e. the true head pose plus that solution's error (none
    before its first solution: it was started at its true pose). A wrong match moves the fit,
    whose error moves the next prediction.

    The sequential recursion is solved in vectorised passes: match every revolution with the
    predictions of the previous pass (the true pose in the first) and fit it; then again only
    the revolutions whose prediction changed, refitting those whose matches changed; until no
    prediction changes. Each pass makes at least one more revolution final, so this ends, and
    the result is the sequential device's (its fit depends on its matches only: it starts
    from the true pose, within a few cm of which the least squares has one minimum). In
    practice two passes and a few revolutions.

    With ``"truth"`` (model 1's kind world) every revolution is matched from the true pose:
    the first pass alone.
    """
    n = len(scans)
    prior = np.zeros((n, 3))
    everything = np.arange(n)
    matched = _matched_rows(replace(scans, prior=prior), everything, traj, vehicle, nav, marks)
    solutions = solve(replace(scans, matched=matched, prior=prior), traj, vehicle, nav, marks)
    if nav.identification == "truth" or n == 0:
        return replace(scans, matched=matched, prior=prior), solutions
    mid = scans.start + 0.5 * scans.period
    hx, hy, hth = traj.point_at(mid, vehicle.nav_x, vehicle.nav_y)
    truth = np.stack([hx, hy, hth + vehicle.nav_yaw], axis=1)
    usable = np.searchsorted(solutions.available, scans.start + scans.period, side="right") - 1
    fields_ = {f.name: getattr(solutions, f.name).copy() for f in fields(Solutions)}
    while True:
        predicted = carried_error(fields_["x"], fields_["y"], fields_["heading"],
                                  fields_["valid"], truth, usable)
        dirty = np.nonzero(np.any(predicted != prior, axis=1))[0]
        if len(dirty) == 0:
            break
        prior[dirty] = predicted[dirty]
        again = _matched_rows(replace(scans, prior=prior), dirty, traj, vehicle, nav, marks)
        changed = dirty[np.any(again != matched[dirty], axis=1)]
        matched[dirty] = again
        if len(changed):
            refit = solve(replace(scans, matched=matched, prior=prior).take(changed), traj,
                          vehicle, nav, marks)
            for name, values in fields_.items():
                values[changed] = getattr(refit, name)
    return (replace(scans, matched=matched, prior=prior), Solutions(**fields_))


def carried_error(x: FloatArray, y: FloatArray, heading: FloatArray, valid: NDArray[np.bool_],
                  truth: FloatArray, usable: NDArray[np.intp]) -> FloatArray:
    """Per revolution k, the error (x m, y m, heading rad; shape (n, 3)) of the newest valid
    solution among the solutions 0 .. ``usable[k]`` (those available when revolution k ends:
    earlier revolutions only) against the true head pose ``truth`` (n, 3) at its
    mid-revolution; zero without one."""
    n = len(x)
    err = np.stack([x - truth[:, 0], y - truth[:, 1], wrap_angle(heading - truth[:, 2])],
                   axis=1)
    last = np.maximum.accumulate(np.where(valid, np.arange(n), -1))
    before = np.where(usable >= 0, last[np.clip(usable, 0, max(n - 1, 0))], -1)
    return np.where((before >= 0)[:, None], err[np.maximum(before, 0)], 0.0)


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


def solve(scans: Scans, traj: TrueDrive, vehicle: Vehicle, nav: NavSettings,
          marks: Landmarks) -> Solutions:
    """Weighted Gauss-Newton fit of the head pose for every scan at once, from the matched
    observations and the stored map, as if all were measured at one instant.

    Like the NAV200's PC setting, only the ``nav.max_reflectors`` nearest matched reflectors
    (by measured range) are used; 0 uses all.

    Starts from the true head pose at mid-scan and iterates ``nav.solver_iterations`` times
    (the device starts from its prediction, a few cm off: the least squares has one minimum
    there, so the fit is the same, and it depends on the matches alone, which :func:`locate`
    relies on). A scan is valid with at least ``nav.min_reflectors``
    matched reflectors. Quality falls linearly from 100 to 0 as the RMS position residual
    grows to ``nav.quality_rms_mm``. Computed :data:`ROWS_PER_BLOCK` scans at a time.
    """
    parts = [_solve_rows(scans.take(slice(k, k + ROWS_PER_BLOCK)), traj, vehicle, nav, marks)
             for k in range(0, max(len(scans), 1), ROWS_PER_BLOCK)]
    return Solutions(**{f.name: np.concatenate([getattr(p, f.name) for p in parts])
                        for f in fields(Solutions)})


def _solve_rows(scans: Scans, traj: TrueDrive, vehicle: Vehicle, nav: NavSettings,
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
