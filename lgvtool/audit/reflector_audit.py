"""The reflector audit: each layout reflector's evidence in a drive, and its status.

Pure: arrays in, values out (positions m, angles rad, times s). For one log,
:func:`reflector_evidence` takes the replayed pose of O, the reflector scans (range, bearing,
time in the revolution and the device's id of each observation) and the layout, and gathers
per reflector (layout order):

- its *chances*: the revolutions in which the head (the replayed pose carried to the head)
  could see it (:func:`lgvtool.audit.visibility.expected_visibility`), per range bin, and the
  *hits* among them (a revolution with an observation matched to it);
- its *sightings*: the observations matched to it. An observation is matched by the device's
  id when its placement (replayed pose, range, bearing: a map point) lies within
  ``match_tolerance_m`` of that reflector, else (no id, an id not in the layout, or too far)
  to the nearest reflector within the tolerance, unambiguously
  (:func:`lgvtool.localize.association.associate_points`); an observation matched to nothing
  is an unmapped detection (:mod:`lgvtool.audit.unmapped_objects`);
- its *offset*: where each sighting puts it minus its layout position, with the head pose of
  that revolution refitted to the revolution's other matched reflectors (leave one out: the
  sighting's own residual after a least-squares fit of the pose correction to all of them,
  divided by one minus its leverage), so that a moved reflector does not pull the pose it is
  judged by; kept as moments, and as moments of the means of ``block_s`` time blocks. Before
  that, the range offset common to all reflectors at a range is taken out
  (:func:`range_offsets`); of two observations of one revolution matched to one reflector
  the nearer keeps it (the other is unmapped); an offset far from the reflector's median
  (``offset_outlier_m``) is left out;
- its range and bearing residuals against the replayed pose, and the values the device
  reports of each observation (:data:`DEVICE_VALUES`; NAV350: its quality and mean echo)
  against time.

A long log is gathered a block of revolutions at a time and pooled the same way. The
evidence of several logs pools exactly (:meth:`ReflectorEvidence.merged`), then :func:`judge`
decides each reflector's status from the pooled evidence, its shift by :func:`shifts`
(docs/audit.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.audit.audit_moments import Moments, block_moments, standard_error
from lgvtool.audit.audit_settings import AuditSettings
from lgvtool.audit.unmapped_objects import UnmappedEvidence, pooled_unmapped, unmapped_evidence
from lgvtool.audit.visibility import DeviceView, expected_visibility
from lgvtool.config import Reflector
from lgvtool.localize.association import NONE, associate_points
from lgvtool.localize.geometry import o_to_nav
from lgvtool.localize.observations import ScanBatch
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

__all__ = ["DEVICE_VALUES", "MAX_RANGE_M", "STATUSES", "ReflectorEvidence", "ReflectorVerdict",
           "Trend", "ambiguous_pairs", "judge", "pooled", "poses_at", "reflector_evidence"]

STATUSES = ("ok", "missing", "moved", "weak", "ambiguous")
"""Every status a reflector can get."""

MAX_RANGE_M = 100.0
"""The range bins reach this far, m (beyond every NAV's reach)."""

SECONDS_PER_DAY = 86400.0

TREND_MIN_SPREAD_DAYS = 1.0 / 24.0
"""A trend of a device value is given only when its sightings' times spread (standard
deviation) over at least this, days (an hour): within one drive the quality and the echo
follow the range, not the reflector's ageing."""

DEVICE_VALUES = ("quality", "mean_echo")
"""The values a device reports of each landmark it measures (as /nav/reflectors names them;
NAV350: its quality, dimensionless, and the mean echo of its hits, device units) whose mean
and trend against time the audit gives per reflector, in this order."""

#: observations associated at a time (bounds the observation x reflector distance matrix)
_ASSOCIATE_BLOCK = 20000


def poses_at(track: Trajectory, settled: BoolArray, t: FloatArray
             ) -> tuple[FloatArray, FloatArray, FloatArray, BoolArray]:
    """The pose of O (m, m, rad) of the replayed ``track`` at the times ``t`` (s on its clock,
    in any order; :meth:`Trajectory.interpolate`), and whether it is usable there: inside the
    track and between two ``settled`` poses (those whose position 1-sigma is within the
    audit's limit)."""
    n = len(t)
    if len(track) == 0 or n == 0:
        z = np.zeros(n)
        return z, z, z, np.zeros(n, dtype=bool)
    order = np.argsort(t, kind="stable")
    at = track.interpolate(t[order])
    x, y, h = np.empty(n), np.empty(n), np.empty(n)
    x[order], y[order], h[order] = at.x, at.y, at.heading
    ok = (t >= track.t[0]) & (t <= track.t[-1])
    ok &= np.interp(t, track.t, settled.astype(np.float64)) > 1.0 - 1e-9
    return x, y, h, ok


@dataclass(frozen=True)
class Trend:
    """A device value (:data:`DEVICE_VALUES`) of a reflector's sightings: its ``mean`` (NaN:
    the device reports none) and ``per_day``, its slope against time, in its unit per day
    (NaN: the sightings' times spread over less than :data:`TREND_MIN_SPREAD_DAYS`)."""

    mean: float
    per_day: float

    @classmethod
    def of(cls, moments: Moments, i: int) -> Trend:
        """The trend of group ``i`` of the moments of (time in days, value)."""
        n = moments.n[i]
        mean = float(moments.mean[i, 1]) if n > 0 else float("nan")
        var_t = moments.m2[i, 0, 0]
        long_enough = n >= 2 and var_t / n >= TREND_MIN_SPREAD_DAYS ** 2
        return cls(mean, float(moments.m2[i, 0, 1] / var_t) if long_enough else float("nan"))


@dataclass(frozen=True)
class ReflectorEvidence:
    """What logs showed of each layout reflector (layout order; see the module doc), as
    sufficient statistics that pool over logs."""

    ids: IntArray
    """Layout ids."""
    chances: IntArray
    """(reflectors, range bins): revolutions in which it could be seen, per range bin."""
    hits: IntArray
    """(reflectors, range bins): those of the chances in which it was seen."""
    sightings: IntArray
    """Observations matched to it (in any revolution with a usable pose)."""
    offsets: Moments
    """Its sightings' offsets from its layout position (dx, dy m; leave-one-out fit) with
    their lines of sight (the unit vector from the head: ux, uy)."""
    offset_blocks: Moments
    """The same offsets' means per time block."""
    residuals: Moments
    """Range (m) and bearing (rad) residuals of its sightings against the replayed pose."""
    device: Mapping[str, Moments]
    """Per name of :data:`DEVICE_VALUES`: (time in days since the epoch, that value) of its
    sightings that carry one."""
    revolutions: int
    """Revolutions (scans) with a usable pose."""

    def merged(self, other: ReflectorEvidence) -> ReflectorEvidence:
        """The evidence of both (the same layout), pooled."""
        if not np.array_equal(self.ids, other.ids):
            raise ValueError("evidence of different layouts cannot be pooled")
        return ReflectorEvidence(
            self.ids, self.chances + other.chances, self.hits + other.hits,
            self.sightings + other.sightings, self.offsets.merged(other.offsets),
            self.offset_blocks.merged(other.offset_blocks),
            self.residuals.merged(other.residuals),
            {k: v.merged(other.device[k]) for k, v in self.device.items()},
            self.revolutions + other.revolutions)


def range_bins(settings: AuditSettings) -> int:
    """Range bins of ``settings.range_bin_m`` up to :data:`MAX_RANGE_M`."""
    return math.ceil(MAX_RANGE_M / settings.range_bin_m)


def _layout(reflectors: Sequence[Reflector]) -> tuple[IntArray, FloatArray, FloatArray]:
    ids = np.fromiter((r.id for r in reflectors), np.int64, len(reflectors))
    x = np.fromiter((r.x for r in reflectors), np.float64, len(reflectors))
    y = np.fromiter((r.y for r in reflectors), np.float64, len(reflectors))
    return ids, x, y


def _layout_index(ids: IntArray, obs_ids: IntArray) -> IntArray:
    """Per observation the layout index of its id (-1: no id, or not in the layout)."""
    order = np.argsort(ids, kind="stable")
    pos = np.searchsorted(ids[order], obs_ids)
    pos = np.minimum(pos, max(len(ids) - 1, 0))
    if len(ids) == 0:
        return np.full(len(obs_ids), -1, dtype=np.int64)
    found = ids[order][pos] == obs_ids
    return np.where(found & (obs_ids >= 0), order[pos], -1).astype(np.int64)


def _associate(px: FloatArray, py: FloatArray, known: IntArray, lx: FloatArray, ly: FloatArray,
               settings: AuditSettings) -> IntArray:
    """Layout index per placed observation (-1: none; see the module doc)."""
    layout = lx + 1j * ly
    out = np.full(len(px), -1, dtype=np.int64)
    how = np.full(len(px), NONE, dtype=np.int8)
    for a in range(0, len(px), _ASSOCIATE_BLOCK):
        s = slice(a, a + _ASSOCIATE_BLOCK)
        out[s], how[s] = associate_points(px[s] + 1j * py[s], layout, known[s],
                                          settings.match_tolerance_m, settings.ambiguity_ratio)
    # an ambiguous observation is neither a sighting nor unmapped
    out[(out < 0) & (how != NONE)] = -2
    return out


def _one_per_revolution(j: IntArray, scan: IntArray, px: FloatArray, py: FloatArray,
                        lx: FloatArray, ly: FloatArray) -> None:
    """Keep, of the observations of one revolution matched to one reflector (``j``, in
    place), the one placed nearest to it; the others match nothing (-1: a reflective object
    beside the reflector, as the device itself decides)."""
    k = np.nonzero(j >= 0)[0]
    if len(k) < 2:
        return
    d = np.hypot(px[k] - lx[j[k]], py[k] - ly[j[k]])
    order = np.lexsort((d, j[k], scan[k]))
    ks = k[order]
    again = np.zeros(len(ks), dtype=bool)
    again[1:] = (scan[ks[1:]] == scan[ks[:-1]]) & (j[ks[1:]] == j[ks[:-1]])
    j[ks[again]] = -1


def _near_median(group: IntArray, ex: FloatArray, ey: FloatArray, usable: BoolArray,
                 groups: int, reach: float) -> BoolArray:
    """Per offset: whether it lies within ``reach`` (m) of its group's median offset (per
    axis), of the ``usable`` ones. An observation of something else inside the matching
    tolerance (a reflective object beside the reflector, taken for it when the reflector
    itself is missed) lies far from the reflector's own sightings."""
    out = np.zeros(len(group), dtype=bool)
    idx = np.nonzero(usable)[0]
    if len(idx) == 0:
        return out
    order = idx[np.argsort(group[idx], kind="stable")]
    edges = np.searchsorted(group[order], np.arange(groups + 1))
    for g in range(groups):
        part = order[edges[g]:edges[g + 1]]
        if len(part) == 0:
            continue
        mx, my = float(np.median(ex[part])), float(np.median(ey[part]))
        out[part] = np.hypot(ex[part] - mx, ey[part] - my) <= reach
    return out


def _leave_one_out(scan: IntArray, ex: FloatArray, ey: FloatArray, ux: FloatArray,
                   uy: FloatArray, scans: int, min_fit: int) -> tuple[FloatArray, FloatArray,
                                                                     BoolArray]:
    """Leave-one-out offsets of matched observations: per revolution, the head pose
    correction (dx, dy m, dtheta rad) that best fits the offsets ``(ex, ey)`` (m) of its
    observations (levers ``(ux, uy)``: observation minus head, m), and each observation's
    residual as the fit of the others leaves it. Only revolutions with ``min_fit``
    observations or more, and observations whose leverage leaves a well-posed residual."""
    n = np.bincount(scan, minlength=scans)
    use = n[scan] >= min_fit
    # normal matrix and gradient of the linear model e + J d, J = [[1, 0, -uy], [0, 1, ux]]
    terms = {(0, 0): np.ones(len(scan)), (1, 1): np.ones(len(scan)), (0, 2): -uy, (1, 2): ux,
             (2, 2): ux * ux + uy * uy}
    normal = np.zeros((scans, 3, 3))
    for (a, b), w in terms.items():
        normal[:, a, b] = normal[:, b, a] = np.bincount(scan, weights=w * use, minlength=scans)
    grad = np.stack([np.bincount(scan, weights=ex * use, minlength=scans),
                     np.bincount(scan, weights=ey * use, minlength=scans),
                     np.bincount(scan, weights=(ux * ey - uy * ex) * use, minlength=scans)],
                    axis=1)
    fit = n >= min_fit
    inv = np.zeros((scans, 3, 3))
    det = np.linalg.det(normal[fit])
    good = np.abs(det) > 1e-9
    rows = np.nonzero(fit)[0][good]
    inv[rows] = np.linalg.inv(normal[rows])
    usable = use & np.isin(scan, rows)
    delta = -np.einsum("sij,sj->si", inv, grad)
    d = delta[scan]
    rx = ex + d[:, 0] - uy * d[:, 2]
    ry = ey + d[:, 1] + ux * d[:, 2]
    jac = np.zeros((len(scan), 2, 3))
    jac[:, 0, 0] = jac[:, 1, 1] = 1.0
    jac[:, 0, 2] = -uy
    jac[:, 1, 2] = ux
    hat = np.einsum("nij,njk,nlk->nil", jac, inv[scan], jac)
    a11, a12, a21, a22 = 1.0 - hat[:, 0, 0], -hat[:, 0, 1], -hat[:, 1, 0], 1.0 - hat[:, 1, 1]
    det2 = a11 * a22 - a12 * a21
    usable &= det2 > 0.05  # at least ~0.2 of each direction left to the others
    safe = np.where(usable, det2, 1.0)
    lx = (a22 * rx - a12 * ry) / safe
    ly = (a11 * ry - a21 * rx) / safe
    return lx, ly, usable


def range_offsets(ranges: FloatArray, bx: FloatArray, by: FloatArray, matched: IntArray,
                  jm: IntArray, lx: FloatArray, ly: FloatArray, settings: AuditSettings
                  ) -> FloatArray:
    """Per observation (``ranges`` m; the head at ``bx``, ``by`` m; ``matched`` the indices of
    those matched to the layout indices ``jm``, of the layout at ``lx``, ``ly`` m) the range
    offset common to all reflectors at its range (m): in each
    range bin, the median over the matched observations of the measured range minus the
    distance from the head to the layout position (0 in a bin with fewer than 20). A single
    reflector's own offset, or its survey error, moves the median of a bin that holds many
    reflectors little."""
    bins = range_bins(settings)
    rb = np.minimum((ranges / settings.range_bin_m).astype(np.int64), bins - 1)
    dr = ranges[matched] - np.hypot(lx[jm] - bx[matched], ly[jm] - by[matched])
    per_bin = np.zeros(bins)
    mb = rb[matched]
    order = np.argsort(mb, kind="stable")
    edges = np.searchsorted(mb[order], np.arange(bins + 1))
    for b in range(bins):
        part = dr[order[edges[b]:edges[b + 1]]]
        if len(part) >= 20:
            per_bin[b] = float(np.median(part))
    out: FloatArray = per_bin[rb]
    return out


def reflector_evidence(reflectors: Sequence[Reflector], track: Trajectory, settled: BoolArray,
                       scans: ScanBatch, device: FloatArray, *, nav_x: float, nav_y: float,
                       t0_s: float, view: DeviceView, settings: AuditSettings
                       ) -> tuple[ReflectorEvidence, UnmappedEvidence]:
    """One log's evidence of every layout reflector, and the clusters of its detections that
    matched none (see the module doc), gathered :data:`BLOCK_OBSERVATIONS` observations (whole
    revolutions) at a time and pooled, so that memory stays bounded however long the log (the
    common range offsets and the median offsets are those of each block: some 15 minutes of
    drive).

    :param reflectors: the layout (its order is the evidence's).
    :param track: the replayed pose of O (times s after the log's t0).
    :param settled: per pose of ``track``, whether it may be used (its position 1-sigma
        within ``settings.max_pose_sigma_m``).
    :param scans: the reflector scans (starts s after t0, periods s; per observation range m,
        bearing rad in the head frame, time in the revolution s and the device's id, -1:
        none), the installation's corrections applied.
    :param device: per observation (rows) the values of :data:`DEVICE_VALUES` (columns,
        in that order; NaN: none).
    :param nav_x: head position in the vehicle frame, x (m); ``nav_y`` y (m).
    :param t0_s: the log's t0 in s since the epoch (time blocks and the trends of the device values).
    :param view: what the head can see (range limits).
    :param settings: the audit's thresholds.
    """
    offsets = np.concatenate(([0], np.cumsum(scans.counts))).astype(np.int64)
    parts: list[ReflectorEvidence] = []
    loose: list[UnmappedEvidence] = []
    start, n = 0, len(scans)
    while start < n or not parts:
        end = int(np.searchsorted(offsets, offsets[start] + BLOCK_OBSERVATIONS, side="right")) - 1
        end = min(max(end, start + 1), n) if n else 0
        a, b = int(offsets[start]), int(offsets[end])
        block = ScanBatch(scans.t[start:end], scans.period[start:end], scans.counts[start:end],
                          scans.ranges[a:b], scans.bearings[a:b], scans.times[a:b],
                          scans.ids[a:b])
        ev, un = _block_evidence(reflectors, track, settled, block, device[a:b], nav_x=nav_x,
                                 nav_y=nav_y, t0_s=t0_s, view=view, settings=settings)
        parts.append(ev)
        loose.append(un)
        start = end
    return pooled(parts), pooled_unmapped(loose, settings) if len(loose) > 1 else loose[0]


#: observations gathered at a time (whole revolutions): about 15 min of a NAV350 (8 Hz) seeing
#: 15 reflectors a revolution; the temporaries of a block take some 50 MB
BLOCK_OBSERVATIONS = 100_000


def _block_evidence(reflectors: Sequence[Reflector], track: Trajectory, settled: BoolArray,
                    scans: ScanBatch, device: FloatArray, *, nav_x: float, nav_y: float,
                    t0_s: float, view: DeviceView, settings: AuditSettings
                    ) -> tuple[ReflectorEvidence, UnmappedEvidence]:
    """:func:`reflector_evidence` of one block of revolutions."""
    ids, lx, ly = _layout(reflectors)
    m, bins = len(ids), range_bins(settings)
    s_count = len(scans)
    counts = np.asarray(scans.counts, dtype=np.int64)
    scan_of = np.repeat(np.arange(s_count), counts)
    # the head at mid revolution: the chances
    t_mid = scans.t + 0.5 * scans.period
    ox, oy, oh, ok_scan = poses_at(track, settled, t_mid)
    hx, hy, hth = o_to_nav(ox, oy, oh, nav_x, nav_y)
    rows = np.nonzero(ok_scan)[0]
    visible = expected_visibility(hx[rows], hy[rows], hth[rows], reflectors, view)
    dist = np.hypot(lx[None, :] - hx[rows, None], ly[None, :] - hy[rows, None])
    rbin = np.minimum((dist / settings.range_bin_m).astype(np.int64), bins - 1)
    # every observation placed in the map with the head pose of its own instant
    t_obs = scans.t[scan_of] + scans.times
    ox_o, oy_o, oh_o, ok_obs = poses_at(track, settled, t_obs)
    ok_obs &= ok_scan[scan_of]
    bx, by, bth = o_to_nav(ox_o, oy_o, oh_o, nav_x, nav_y)
    ang = bth + scans.bearings
    px = bx + scans.ranges * np.cos(ang)
    py = by + scans.ranges * np.sin(ang)
    k = np.nonzero(ok_obs)[0]
    j = np.full(len(scan_of), -1, dtype=np.int64)
    j[k] = _associate(px[k], py[k], _layout_index(ids, scans.ids[k]), lx, ly, settings)
    j[~ok_obs] = -2
    _one_per_revolution(j, scan_of, px, py, lx, ly)
    matched = np.nonzero(j >= 0)[0]
    jm = j[matched]
    # the device's range offset common to every reflector (a cylinder's apparent centre lies
    # behind its centre, by an amount that depends on the range), per range bin, taken out
    ranges = scans.ranges - range_offsets(scans.ranges, bx, by, matched, jm, lx, ly, settings)
    px = bx + ranges * np.cos(ang)
    py = by + ranges * np.sin(ang)
    # chances and hits per range bin
    seen = np.zeros((s_count, m), dtype=bool)
    seen[scan_of[matched], jm] = True
    seen_rows = seen[rows]
    col = np.broadcast_to(np.arange(m)[None, :], visible.shape)
    flat = col * bins + rbin
    chances = np.bincount(flat[visible], minlength=m * bins).reshape(m, bins)
    hit = visible & seen_rows
    hits = np.bincount(flat[hit], minlength=m * bins).reshape(m, bins)
    sightings = np.bincount(jm, minlength=m)
    block = np.floor((t0_s + t_obs) / settings.block_s).astype(np.int64)
    # offsets, leave one out per revolution
    ex, ey = px[matched] - lx[jm], py[matched] - ly[jm]
    loo_x, loo_y, usable = _leave_one_out(scan_of[matched], ex, ey, px[matched] - bx[matched],
                                          py[matched] - by[matched], s_count,
                                          settings.min_fit_reflectors)
    usable &= _near_median(jm, loo_x, loo_y, usable, m, settings.offset_outlier_m)
    lever_x, lever_y = px[matched] - bx[matched], py[matched] - by[matched]
    reach = np.maximum(np.hypot(lever_x, lever_y), 1e-9)
    off = np.stack([loo_x[usable], loo_y[usable]], axis=1)
    off_group = jm[usable]
    offsets = Moments.of(off_group, np.stack([loo_x[usable], loo_y[usable],
                                              (lever_x / reach)[usable],
                                              (lever_y / reach)[usable]], axis=1), m)
    offset_blocks = block_moments(off_group, off, block[matched][usable], m)
    # range and bearing residuals against the replayed pose
    dx, dy = lx[jm] - bx[matched], ly[jm] - by[matched]
    dr = ranges[matched] - np.hypot(dx, dy)
    db = wrap_angle(scans.bearings[matched] - (np.arctan2(dy, dx) - bth[matched]))
    residuals = Moments.of(jm, np.stack([dr, db], axis=1), m)
    days = (t0_s + t_obs[matched]) / SECONDS_PER_DAY
    values = np.asarray(device, dtype=np.float64).reshape(-1, len(DEVICE_VALUES))[matched]
    trends = {name: _against_time(jm, days, values[:, c], m)
              for c, name in enumerate(DEVICE_VALUES)}
    loose = np.nonzero(j == -1)[0]
    unmapped = unmapped_evidence(px[loose], py[loose], block[loose], settings)
    return ReflectorEvidence(ids, chances.astype(np.int64), hits.astype(np.int64),
                             sightings.astype(np.int64), offsets, offset_blocks, residuals,
                             trends, len(rows)), unmapped


def _against_time(group: IntArray, days: FloatArray, values: FloatArray, m: int) -> Moments:
    """Moments of (time in days, value) per reflector ``group`` (of ``m``) of the sightings
    whose value is finite (a device value the device reported)."""
    has = np.isfinite(values)
    return Moments.of(group[has], np.stack([days[has], values[has]], axis=1), m)


def pooled(parts: Sequence[ReflectorEvidence]) -> ReflectorEvidence:
    """The evidence of several logs of one layout pooled (at least one)."""
    out = parts[0]
    for p in parts[1:]:
        out = out.merged(p)
    return out


def ambiguous_pairs(reflectors: Sequence[Reflector], tolerance_m: float
                    ) -> dict[int, list[int]]:
    """Layout id -> the ids of the other layout reflectors within ``tolerance_m`` (m) of it
    (only ids that have such a neighbour)."""
    ids, x, y = _layout(reflectors)
    d = np.hypot(x[:, None] - x[None, :], y[:, None] - y[None, :])
    near = (d <= tolerance_m) & ~np.eye(len(ids), dtype=bool)
    return {int(ids[i]): [int(v) for v in ids[np.nonzero(near[i])[0]]]
            for i in range(len(ids)) if near[i].any()}


@dataclass(frozen=True)
class ReflectorVerdict:
    """One layout reflector's audit (m, rad; NaN where there is no evidence)."""

    id: int
    x: float
    y: float
    status: str
    expected_sightings: int
    """Revolutions in which it could be seen."""
    sightings: int
    """Observations matched to it."""
    detection_share: float
    """Its hits over what the other reflectors' detection rate at the same ranges predicts
    (1: as the others; NaN without chances)."""
    shortfall_sigmas: float
    """How many Poisson standard deviations its hits fall short of that prediction."""
    residual_m: float
    """RMS distance of its sightings (leave-one-out placement) from its layout position, m."""
    shift_m: tuple[float, float]
    """Mean offset of its sightings from its layout position (dx, dy), m."""
    shift_sigma_m: tuple[float, float]
    """1-sigma of that offset per axis, m."""
    shift_sigmas: float
    """Length of the offset in its own standard deviations (per axis, in quadrature)."""
    range_offset_m: float
    """Its own range offset (m) fitted beside the shift (:func:`shifts`)."""
    range_residual_m: tuple[float, float]
    """Mean and RMS of its range residuals against the replayed pose, m."""
    bearing_residual_rad: tuple[float, float]
    """Mean and RMS of its bearing residuals, rad."""
    device: Mapping[str, Trend]
    """Per name of :data:`DEVICE_VALUES` (quality, mean echo), that value's mean over its
    sightings and its trend."""
    near: tuple[int, ...] = ()
    """Ambiguous: the layout ids within the matching tolerance."""


def _detection_shares(ev: ReflectorEvidence, exclude: BoolArray
                      ) -> tuple[FloatArray, FloatArray]:
    """Per reflector: the hits the others' (not ``exclude``d) detection rate per range bin
    predicts for its chances, and its hits over that."""
    use = ~exclude
    hits_all = (ev.hits * use[:, None]).sum(axis=0).astype(np.float64)
    chances_all = (ev.chances * use[:, None]).sum(axis=0).astype(np.float64)
    # each reflector against the others: its own counts taken out when it is among them
    own_h = ev.hits * use[:, None]
    own_c = ev.chances * use[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = (hits_all[None, :] - own_h) / (chances_all[None, :] - own_c)
    rate = np.where(np.isfinite(rate), rate, 0.0)
    predicted = (ev.chances * rate).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(predicted > 0, ev.hits.sum(axis=1) / predicted, np.nan)
    return predicted, share


def _planar(m: Moments) -> Moments:
    """The (dx, dy) part of offset moments that also hold the line of sight."""
    return Moments(m.n, m.mean[:, :2], m.m2[:, :2, :2])


def shifts(offsets: Moments, blocks: Moments, own_sigma: float
           ) -> tuple[FloatArray, FloatArray]:
    """Per reflector its shift (dx, dy m) and its own range offset (m), from the moments of
    its sightings' offsets ``e`` and lines of sight ``u`` (unit vectors from the head):
    ``e = shift + b u`` in least squares, with a prior of ``own_sigma`` m on ``b`` (ridge;
    the sightings' scatter over the number of time blocks weighs the data, as their errors are
    shared within a block). A range offset shows along each line of sight, a shift the same
    in every one: seen from several directions they part; seen from one, the prior keeps the
    range offset near zero and the shift takes the offset."""
    n = offsets.n
    e_mean, u_mean = offsets.mean[:, :2], offsets.mean[:, 2:]
    c = offsets.m2
    s_ue = c[:, 0, 2] + c[:, 1, 3]
    s_uu = c[:, 2, 2] + c[:, 3, 3]
    var_e = (c[:, 0, 0] + c[:, 1, 1]) / np.maximum(2.0 * n, 1.0)
    shared = n / np.maximum(blocks.n, 1.0)
    ridge = shared * var_e / max(own_sigma, 1e-6) ** 2
    b = np.where(s_uu + ridge > 0, s_ue / np.maximum(s_uu + ridge, 1e-300), 0.0)
    out: FloatArray = e_mean - b[:, None] * u_mean
    return out, b


def judge(ev: ReflectorEvidence, reflectors: Sequence[Reflector], settings: AuditSettings
          ) -> list[ReflectorVerdict]:
    """Each layout reflector's status from the (pooled) evidence (docs/audit.md):
    ``ambiguous`` (another layout reflector within the matching tolerance: its sightings
    cannot be told apart), else ``missing`` (expected at least ``min_chances`` times, seen on
    at most ``missing_max_share`` of the predicted hits), ``moved`` (offset at least
    ``moved_min_shift_m`` and ``moved_sigmas`` of its own sigma), ``weak`` (at most
    ``weak_max_share`` of the predicted hits and ``weak_sigmas`` short), else ``ok``. The
    detection rates per range bin come from the reflectors not missing or weak by a first
    pass."""
    _, lx, ly = _layout(reflectors)
    chances = ev.chances.sum(axis=1)
    hits = ev.hits.sum(axis=1)
    enough = chances >= settings.min_chances
    exclude = np.zeros(len(ev.ids), dtype=bool)
    for _ in range(2):
        predicted, share = _detection_shares(ev, exclude)
        with np.errstate(invalid="ignore", divide="ignore"):
            short = (predicted - hits) / np.sqrt(np.maximum(predicted, 1e-12))
        missing = enough & (predicted > 0) & (hits <= settings.missing_max_share * predicted)
        weak = (enough & ~missing & (share <= settings.weak_max_share)
                & (short >= settings.weak_sigmas))
        exclude = missing | weak
    shift, own_range = shifts(ev.offsets, ev.offset_blocks, settings.shift_floor_m)
    sigma = np.hypot(standard_error(_planar(ev.offsets), ev.offset_blocks),
                     settings.shift_floor_m)
    near = ambiguous_pairs(reflectors, settings.match_tolerance_m)
    out = []
    for i, rid in enumerate(ev.ids.tolist()):
        n_off = ev.offsets.n[i]
        s = shift[i] if n_off > 0 else np.array([np.nan, np.nan])
        maha = float("nan")
        if n_off >= 2 and np.all(sigma[i] > 0):
            maha = float(np.hypot(*(s / sigma[i])))
        moved = (n_off >= 2 and math.hypot(*s) >= settings.moved_min_shift_m
                 and math.isfinite(maha) and maha >= settings.moved_sigmas)
        if rid in near:
            status = "ambiguous"
        elif missing[i]:
            status = "missing"
        elif moved:
            status = "moved"
        elif weak[i]:
            status = "weak"
        else:
            status = "ok"
        e_mean = ev.offsets.mean[i, :2]
        rms = (float(math.sqrt((ev.offsets.m2[i, 0, 0] + ev.offsets.m2[i, 1, 1]) / n_off
                               + float(e_mean @ e_mean))) if n_off > 0 else float("nan"))
        nr = ev.residuals.n[i]
        res_mean = ev.residuals.mean[i]
        res_rms = (np.sqrt(np.diagonal(ev.residuals.m2[i]) / nr + res_mean ** 2) if nr > 0
                   else np.array([np.nan, np.nan]))
        if nr == 0:
            res_mean = np.array([np.nan, np.nan])
        out.append(ReflectorVerdict(
            id=int(rid), x=float(lx[i]), y=float(ly[i]), status=status,
            expected_sightings=int(chances[i]), sightings=int(ev.sightings[i]),
            detection_share=float(share[i]), shortfall_sigmas=float(short[i]),
            residual_m=rms, shift_m=(float(s[0]), float(s[1])),
            shift_sigma_m=(float(sigma[i, 0]), float(sigma[i, 1])), shift_sigmas=maha,
            range_offset_m=float(own_range[i]) if n_off > 0 else float("nan"),
            range_residual_m=(float(res_mean[0]), float(res_rms[0])),
            bearing_residual_rad=(float(res_mean[1]), float(res_rms[1])),
            device={name: Trend.of(mom, i) for name, mom in ev.device.items()},
            near=tuple(near.get(int(rid), ()))))
    return out
