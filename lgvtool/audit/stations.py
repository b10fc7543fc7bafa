"""Stations (``audit.json``'s ``stations``): where the vehicle stands still, and how
repeatably each pose source puts it there.

A **standstill** is found from the odometry alone: the distance and the heading change of O
over a window centred on each motion sample, over the window, below a speed and a turn rate,
for at least a minimum time (:func:`standstills`). A **visit** is one standstill with, per
pose source (the truth where the log has it, the raw laser: the NAV's valid poses moved to O,
and the estimator the audit replays), the mean pose of O over the standstill after a settling
time (the heading a circular mean): :func:`log_visits`. Visits pool over logs; they form
**stations** (:func:`find_stations`) either automatically (visits within a radius and a
heading of a station's running mean join it, a station needs a least number of visits) or by
the named stations of a stations file (each visit to the nearest named one within the same
radius and heading; the rest are reported as unmatched).

Per station and source (:func:`stations_section`): the visits, the mean pose, the standard
deviations of x, y (m) and of the heading (deg) about the mean (n - 1), the 95 % radius (the
95th percentile, numpy's linear interpolation, of the visits' horizontal distances from their
mean), the same standard deviations of the stops alone (the source's own noise over each
stop taken off: :func:`stop_spread`), the worst visit (farthest from the station's pose: the
named pose, else the source's mean), and against a named station's tolerance the visits
within it and pass/fail (every visit within ``tolerance_xy_m`` of the named position and
``tolerance_deg`` of its heading);
where the log has a truth, each source's error against it per visit.

Pure: arrays and trajectories in, visits and JSON out. Positions m, angles rad (deg where a
key says so), times s after the log's first motion or observation message.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import circular_mean, wrap_angle, wrap_scalar
from lgvtool.declared import setting
from lgvtool.json_types import JSON, JSONObject
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]

__all__ = ["ROLES", "NamedStation", "Station", "StationFindings", "StationSettings", "Visit",
           "VisitPose", "find_stations", "log_kpis", "log_visits", "mean_pose", "spread",
           "standstills", "stations_section", "stop_spread", "summary_line"]

ROLES = ("truth", "laser", "estimator")
"""The pose sources of a visit: the log's ground truth, the NAV's own poses (moved to O) and
the estimator the audit replays."""

REFERENCE_ORDER = ("estimator", "laser", "truth")
"""Which source places a visit among the stations: the audit's estimator, else the laser, else
the truth (a real log has no truth; a station must be found the same way on both)."""

PERCENTILE = 95.0
"""The radius reported: this percentile of the visits' distances from their mean, %."""


@dataclass(frozen=True)
class StationSettings:
    """How standstills are found and grouped (``lgvtool audit --set stations.<key>=<value>``)."""

    speed_m_s: float = setting(
        0.01,
        "A standstill: the odometry's distance over the window, divided by it, is below this, "
        "m/s (a vehicle docking creeps at a few cm/s; encoders at rest give 0).",
        unit="m/s", minimum=0.0, min_open=True, maximum=1.0)
    turn_rate_deg_s: float = setting(
        0.5,
        "A standstill also needs the odometry's heading change over the window, divided by "
        "it, below this, deg/s (a gyro at rest reads its noise: the simulated one under 0.2 "
        "deg/s).",
        unit="deg/s", minimum=0.0, min_open=True, maximum=90.0)
    window_s: float = setting(
        0.5,
        "The speed and turn rate are taken over this window centred on each motion sample, s "
        "(several samples: one encoder tick is not a motion).",
        unit="s", minimum=0.0, min_open=True, maximum=10.0)
    min_standstill_s: float = setting(
        2.0,
        "Shortest standstill that is a visit, s: a stop at a station lasts seconds (load "
        "handling); a halt at a turn or a reversal lasts about one.",
        unit="s", minimum=0.0, min_open=True)
    settle_s: float = setting(
        0.25,
        "The first part of a standstill left out of each source's mean pose, s: the vehicle "
        "settles, a NAV reply may still carry a pose measured while moving, a filter still "
        "weighs its last motion. A standstill already starts half a window after the last "
        "motion, so the mean begins 0.5 s after it.",
        unit="s", minimum=0.0)
    max_gap_s: float = setting(
        1.0,
        "Motion samples farther apart than this break a standstill, s: a gap in the log is "
        "not a standstill.",
        unit="s", minimum=0.0, min_open=True)
    group_radius_m: float = setting(
        0.3,
        "A visit belongs to a station whose pose (a named one; else the running mean of its "
        "visits) lies within this distance, m: docking spreads are cm, neighbouring stations "
        "a metre or more apart. With a stations file this is also how far out a visit may "
        "be and still count (and fail) at its station.",
        unit="m", minimum=0.0, min_open=True, maximum=10.0)
    group_heading_deg: float = setting(
        20.0,
        "A visit belongs to a station only when its heading is within this of the station's, "
        "deg: a stop facing the other way is another station.",
        unit="deg", minimum=0.0, min_open=True, maximum=180.0)
    min_visits: int = setting(
        2,
        "Fewest visits of an automatically found station (a single standstill is a halt, "
        "not a station; it is listed as unmatched).",
        unit="", minimum=1, maximum=10**9)


@dataclass(frozen=True)
class NamedStation:
    """A station of a stations file: its ``name``, the pose of O there (``x``, ``y`` m,
    ``heading`` rad) and its tolerance (``tolerance_xy_m`` m, ``tolerance_rad`` rad)."""

    name: str
    x: float
    y: float
    heading: float
    tolerance_xy_m: float
    tolerance_rad: float


@dataclass(frozen=True)
class VisitPose:
    """One source's mean pose of O over a visit: ``x``, ``y`` m, ``heading`` rad (circular
    mean), from ``samples`` poses, and the standard errors of that mean, ``se_x``, ``se_y`` m
    and ``se_heading`` rad: the samples' standard deviation (n - 1) over the square root of
    their number, NaN below two samples (:func:`mean_pose`)."""

    x: float
    y: float
    heading: float
    samples: int
    se_x: float = math.nan
    se_y: float = math.nan
    se_heading: float = math.nan


@dataclass(frozen=True)
class Visit:
    """One standstill of one log: ``log`` (its path), ``start_s`` and ``end_s`` (s on the
    log's audit clock), ``poses`` (role of :data:`ROLES` -> :class:`VisitPose`; a source
    without a pose in the standstill is absent) and ``estimator`` (the name of the
    ``estimator`` role)."""

    log: str
    start_s: float
    end_s: float
    poses: Mapping[str, VisitPose]
    estimator: str

    def reference(self) -> VisitPose | None:
        """The pose that places this visit (:data:`REFERENCE_ORDER`); None: no source."""
        for role in REFERENCE_ORDER:
            if role in self.poses:
                return self.poses[role]
        return None


@dataclass(frozen=True)
class Station:
    """A station with its visits: its ``name``, its pose (``x``, ``y`` m, ``heading`` rad: the
    named pose, or the mean of the visits' reference poses), its tolerance (None: found
    automatically, none) and its ``visits``."""

    name: str
    x: float
    y: float
    heading: float
    tolerance: tuple[float, float] | None
    """(position m, heading rad)."""
    visits: tuple[Visit, ...]


@dataclass(frozen=True)
class StationFindings:
    """The stations and the visits that belong to none."""

    stations: tuple[Station, ...]
    unmatched: tuple[Visit, ...]
    named: bool
    """From a stations file (else found automatically)."""
    visits: int = 0
    """Every visit, matched or not."""
    source_names: Mapping[str, str] = field(default_factory=dict)
    """Role -> the name shown (the estimator's names, comma-separated when logs differ)."""


def standstills(t: FloatArray, ds: FloatArray, dth: FloatArray,
                settings: StationSettings) -> list[tuple[float, float]]:
    """The standstills of the odometry: (start s, end s) of each stretch where the distance
    ``|ds|`` (m) and the heading change ``|dth|`` (rad) over ``window_s`` centred on each
    sample (``t`` s, one more than the increments) stay below ``speed_m_s`` and
    ``turn_rate_deg_s``, at least ``min_standstill_s`` long, unbroken by a gap of more than
    ``max_gap_s``."""
    s = settings
    t = np.asarray(t, dtype=np.float64)
    if len(t) < 2 or len(ds) != len(t) - 1:
        return []
    dist = np.concatenate(([0.0], np.cumsum(np.abs(ds))))
    turn = np.concatenate(([0.0], np.cumsum(np.abs(dth))))
    half = 0.5 * s.window_s
    lo = np.clip(t - half, t[0], t[-1])
    hi = np.clip(t + half, t[0], t[-1])
    span = np.maximum(hi - lo, 1e-9)
    speed = (np.interp(hi, t, dist) - np.interp(lo, t, dist)) / span
    rate = (np.interp(hi, t, turn) - np.interp(lo, t, turn)) / span
    still = (speed < s.speed_m_s) & (rate < math.radians(s.turn_rate_deg_s))
    # a run of still samples ends where the next one moves or lies too far away
    gap = np.diff(t) > s.max_gap_s
    before = np.concatenate(([False], still[:-1] & ~gap))
    after = np.concatenate((still[1:] & ~gap, [False]))
    starts = np.flatnonzero(still & ~before)
    ends = np.flatnonzero(still & ~after)
    keep = t[ends] - t[starts] >= s.min_standstill_s
    return [(float(t[a]), float(t[b])) for a, b in zip(starts[keep], ends[keep], strict=True)]


def mean_pose(track: Trajectory, start: float, end: float) -> VisitPose | None:
    """The mean pose of ``track`` (s, m, rad) over ``start <= t <= end`` (s): mean x, y and
    the circular mean heading, with their standard errors (:class:`VisitPose`); None: no pose
    there."""
    part = track.between(start, end)
    n = len(part)
    if n == 0:
        return None
    x = np.asarray(part.x, dtype=np.float64)
    y = np.asarray(part.y, dtype=np.float64)
    heading = np.asarray(part.heading, dtype=np.float64)
    mh = circular_mean(heading)
    if n < 2:
        return VisitPose(float(np.mean(x)), float(np.mean(y)), mh, n)
    dh = wrap_angle(heading - mh)
    root = math.sqrt(n)
    return VisitPose(float(np.mean(x)), float(np.mean(y)), mh, n,
                     float(np.std(x, ddof=1)) / root, float(np.std(y, ddof=1)) / root,
                     math.sqrt(float(np.sum(dh * dh)) / (n - 1)) / root)


def log_visits(log: str, odometry: tuple[FloatArray, FloatArray, FloatArray],
               sources: Mapping[str, Trajectory | None], estimator: str,
               settings: StationSettings) -> tuple[Visit, ...]:
    """One log's visits: its standstills (:func:`standstills` of ``odometry``: sample times s,
    distance m and heading change rad per increment) and each source's mean pose of O over
    each (``sources``: role of :data:`ROLES` -> its poses on the same clock, None: the log has
    none), the first ``settle_s`` left out. ``estimator`` names the ``estimator`` role."""
    t, ds, dth = odometry
    out = []
    for start, end in standstills(t, ds, dth, settings):
        a = start + settings.settle_s
        poses: dict[str, VisitPose] = {}
        for role in ROLES:
            track = sources.get(role)
            if track is None or len(track) == 0:
                continue
            p = mean_pose(track, a, end)
            if p is not None:
                poses[role] = p
        out.append(Visit(log, start, end, poses, estimator))
    return tuple(out)


def _near(p: VisitPose, x: float, y: float, heading: float, s: StationSettings) -> float | None:
    """The distance (m) of ``p`` from the pose (x, y m, heading rad) when within the grouping
    radius and heading, else None."""
    d = math.hypot(p.x - x, p.y - y)
    if d > s.group_radius_m or abs(wrap_scalar(p.heading - heading)) > math.radians(
            s.group_heading_deg):
        return None
    return d


def find_stations(visits: Sequence[Visit], named: Sequence[NamedStation] | None,
                  settings: StationSettings) -> StationFindings:
    """The ``visits`` (pooled over logs, in order) grouped into stations: to the nearest of
    the ``named`` stations within the grouping radius and heading, or (``named`` None)
    automatically: each visit joins the nearest station whose running mean reference pose
    (:meth:`Visit.reference`) lies within the radius and heading, else starts one; stations
    of fewer than ``min_visits`` visits are dropped and their visits unmatched. Automatic
    stations are named S1, S2, ... in the order of their first visit."""
    s = settings
    unmatched: list[Visit] = []
    stations: list[Station] = []
    if named is not None:
        members: dict[str, list[Visit]] = {n.name: [] for n in named}
        for v in visits:
            p = v.reference()
            best: tuple[float, str] | None = None
            for n in named:
                d = None if p is None else _near(p, n.x, n.y, n.heading, s)
                if d is not None and (best is None or d < best[0]):
                    best = (d, n.name)
            if best is None:
                unmatched.append(v)
            else:
                members[best[1]].append(v)
        stations = [Station(n.name, n.x, n.y, n.heading, (n.tolerance_xy_m, n.tolerance_rad),
                            tuple(members[n.name])) for n in named]
    else:
        groups: list[list[Visit]] = []
        sums: list[list[float]] = []  # sum x, sum y, sum sin, sum cos, count
        for v in visits:
            p = v.reference()
            if p is None:
                unmatched.append(v)
                continue
            choice: tuple[float, int] | None = None
            for k, sm in enumerate(sums):
                d = _near(p, sm[0] / sm[4], sm[1] / sm[4], math.atan2(sm[2], sm[3]), s)
                if d is not None and (choice is None or d < choice[0]):
                    choice = (d, k)
            if choice is None:
                groups.append([v])
                sums.append([p.x, p.y, math.sin(p.heading), math.cos(p.heading), 1.0])
            else:
                k = choice[1]
                groups[k].append(v)
                sm = sums[k]
                sm[0] += p.x
                sm[1] += p.y
                sm[2] += math.sin(p.heading)
                sm[3] += math.cos(p.heading)
                sm[4] += 1.0
        for g, sm in zip(groups, sums, strict=True):
            if len(g) < s.min_visits:
                unmatched.extend(g)
                continue
            stations.append(Station(f"S{len(stations) + 1}", sm[0] / sm[4], sm[1] / sm[4],
                                    math.atan2(sm[2], sm[3]), None, tuple(g)))
        order = {id(v): i for i, v in enumerate(visits)}
        unmatched.sort(key=lambda v: order[id(v)])
    names = {r: r for r in ROLES}
    names["estimator"] = ", ".join(dict.fromkeys(v.estimator for v in visits)) or "estimator"
    return StationFindings(tuple(stations), tuple(unmatched), named is not None, len(visits),
                           names)


def _num(v: float, digits: int = 5) -> float | None:
    return round(v, digits) if math.isfinite(v) else None


@dataclass(frozen=True)
class _Scatter:
    """One source's poses over a station's visits (those with the source)."""

    role: str
    visits: tuple[Visit, ...]
    x: FloatArray
    y: FloatArray
    heading: FloatArray


def _scatter(st: Station, role: str) -> _Scatter:
    have = tuple(v for v in st.visits if role in v.poses)
    return _Scatter(role, have, np.array([v.poses[role].x for v in have], dtype=np.float64),
                    np.array([v.poses[role].y for v in have], dtype=np.float64),
                    np.array([v.poses[role].heading for v in have], dtype=np.float64))


def spread(x: FloatArray, y: FloatArray, heading: FloatArray
           ) -> tuple[float, float, float, float, float, float, float]:
    """The mean pose and scatter of visits' poses (m, m, rad): mean x, mean y, circular mean
    heading, the standard deviations (n - 1) of x, y (m) and of the heading about its mean
    (rad), and the 95 % radius (m: :data:`PERCENTILE` of the distances from the mean); the
    scatter NaN below two visits."""
    n = len(x)
    if n == 0:
        nan = math.nan
        return nan, nan, nan, nan, nan, nan, nan
    mx, my = float(np.mean(x)), float(np.mean(y))
    mh = circular_mean(heading)
    if n < 2:
        return mx, my, mh, math.nan, math.nan, math.nan, math.nan
    dh = wrap_angle(heading - mh)
    r = np.hypot(x - mx, y - my)
    return (mx, my, mh, float(np.std(x, ddof=1)), float(np.std(y, ddof=1)),
            float(np.sqrt(np.sum(dh * dh) / (n - 1))), float(np.percentile(r, PERCENTILE)))


def stop_spread(sigma: float, se: FloatArray) -> tuple[float, float]:
    """The spread of the stops themselves (m or rad) from a source's spread ``sigma`` of its
    visit means (:func:`spread`) and the standard errors ``se`` of those means (one per visit,
    NaN where unknown), and the RMS of the standard errors (the source's own noise over a
    stop).

    A visit's mean is the stop's pose plus the source's noise averaged over the stop, so the
    variance of the means is the stops' variance plus the mean squared standard error; the
    stops' sigma is ``sqrt(max(0, sigma^2 - mean(se^2)))`` (the method-of-moments estimate of
    one-way random effects). It tells a vehicle that stops repeatably, seen through a noisy
    NAV over short stops, from one that does not: a NAV200 at 2.2 Hz gives about six poses
    over a 3 s stop. For poses correlated in time (a filter's output, a NAV's slow drift)
    ``se`` understates the noise of the mean, and less is taken off. NaN when ``sigma`` is
    NaN or no standard error is known."""
    known = se[np.isfinite(se)]
    if not math.isfinite(sigma) or len(known) == 0:
        return math.nan, math.nan
    noise2 = float(np.mean(known * known))
    return math.sqrt(max(0.0, sigma * sigma - noise2)), math.sqrt(noise2)


def _source_entry(st: Station, role: str, name: str) -> JSONObject | None:
    """One source's figures at one station (module doc); None: no visit has the source."""
    sc = _scatter(st, role)
    n = len(sc.visits)
    if n == 0:
        return None
    mx, my, mh, sx, sy, sh, r95 = spread(sc.x, sc.y, sc.heading)
    # the worst visit: farthest from the station's pose (named), else from the mean
    cx, cy, ch = (st.x, st.y, st.heading) if st.tolerance is not None else (mx, my, mh)
    dist = np.hypot(sc.x - cx, sc.y - cy)
    dev = np.abs(wrap_angle(sc.heading - ch))
    k = int(np.argmax(dist))
    out: JSONObject = {
        "role": role, "source": name, "visits": n,
        "mean": {"x": _num(mx), "y": _num(my), "heading_deg": _num(math.degrees(mh), 4)},
        "sigma_x_m": _num(sx, 6), "sigma_y_m": _num(sy, 6),
        "sigma_heading_deg": _num(math.degrees(sh), 5), "radius95_m": _num(r95, 6),
        "stops_alone": _stops_alone(sc, sx, sy, sh),
        "worst": {"log": sc.visits[k].log, "t_s": _num(sc.visits[k].start_s, 3),
                  "distance_m": _num(float(dist[k]), 6),
                  "heading_deg": _num(math.degrees(float(dev[k])), 5)},
        "within_tolerance": None, "pass": None,
    }
    if st.tolerance is not None:
        tol_m, tol_rad = st.tolerance
        within = int(np.count_nonzero((dist <= tol_m) & (dev <= tol_rad)))
        out["within_tolerance"] = within
        out["pass"] = within == n
    if role != "truth":
        both = [v for v in sc.visits if "truth" in v.poses]
        if both:
            ex = np.array([v.poses[role].x - v.poses["truth"].x for v in both])
            ey = np.array([v.poses[role].y - v.poses["truth"].y for v in both])
            eh = wrap_angle(np.array([v.poses[role].heading - v.poses["truth"].heading
                                      for v in both]))
            e = np.hypot(ex, ey)
            out["error_vs_truth"] = {
                "visits": len(both), "rms_m": _num(float(np.sqrt(np.mean(e * e))), 6),
                "max_m": _num(float(e.max()), 6),
                "mean_m": [_num(float(ex.mean()), 6), _num(float(ey.mean()), 6)],
                "heading_rms_deg": _num(math.degrees(float(np.sqrt(np.mean(eh * eh)))), 5)}
        else:
            out["error_vs_truth"] = None
    return out


def _stops_alone(sc: _Scatter, sx: float, sy: float, sh: float) -> JSONObject:
    """A source's sigma x, y (m) and heading (deg) of the stops themselves, its own noise
    over each stop taken off (:func:`stop_spread`), and that noise (the RMS standard error of
    a visit's mean: ``noise_x_m``, ``noise_y_m``, ``noise_heading_deg``)."""
    out: JSONObject = {}
    for key, sigma, se, deg in (
            ("x", sx, [v.poses[sc.role].se_x for v in sc.visits], False),
            ("y", sy, [v.poses[sc.role].se_y for v in sc.visits], False),
            ("heading", sh, [v.poses[sc.role].se_heading for v in sc.visits], True)):
        stops, noise = stop_spread(sigma, np.array(se, dtype=np.float64))
        if deg:
            out["sigma_heading_deg"] = _num(math.degrees(stops), 5)
            out["noise_heading_deg"] = _num(math.degrees(noise), 5)
        else:
            out[f"sigma_{key}_m"] = _num(stops, 6)
            out[f"noise_{key}_m"] = _num(noise, 6)
    return out


def _visit_entry(v: Visit) -> JSONObject:
    """A visit as listed: its log, start s, duration s, each source's pose [x m, y m,
    heading rad] and the standard errors of that mean pose [m, m, rad] (null: one sample)."""
    return {"log": v.log, "t_s": _num(v.start_s, 3), "duration_s": _num(v.end_s - v.start_s, 3),
            "poses": {r: [_num(p.x, 6), _num(p.y, 6), _num(p.heading, 7)]
                      for r, p in v.poses.items()},
            "standard_errors": {r: [_num(p.se_x, 7), _num(p.se_y, 7), _num(p.se_heading, 8)]
                                for r, p in v.poses.items()}}


def _summary(entries: Sequence[JSONObject], named: bool) -> JSONObject:
    """Per role over the stations: stations and visits, the largest sigma x, y (m), sigma
    heading (deg) and 95 % radius (m), the largest sigma of the stops alone (the source's own
    noise over each stop taken off, :func:`stop_spread`), and (named stations) how many
    passed and failed."""

    def most(key: str, part: str | None = None) -> float | None:
        held = [e.get(part) if part else e for e in entries]
        vals = [float(v) for d in held
                if isinstance(d, dict) and isinstance(v := d.get(key), int | float)]
        return max(vals) if vals else None

    passes = [e.get("pass") for e in entries]
    return {
        "stations": len(entries),
        "visits": sum(int(v) for e in entries if isinstance(v := e.get("visits"), int)),
        "sigma_x_max_m": most("sigma_x_m"), "sigma_y_max_m": most("sigma_y_m"),
        "sigma_heading_max_deg": most("sigma_heading_deg"),
        "radius95_max_m": most("radius95_m"),
        "stops_alone_sigma_x_max_m": most("sigma_x_m", "stops_alone"),
        "stops_alone_sigma_y_max_m": most("sigma_y_m", "stops_alone"),
        "stops_alone_sigma_heading_max_deg": most("sigma_heading_deg", "stops_alone"),
        "passed": sum(p is True for p in passes) if named else None,
        "failed": sum(p is False for p in passes) if named else None,
    }


def stations_section(found: StationFindings, settings: StationSettings, *,
                     file: str | None = None, without_odometry: Sequence[str] = ()
                     ) -> JSONObject:
    """``audit.json``'s ``stations``: how they were found (``mode``: ``automatic`` or
    ``named``, the stations ``file``), ``reference_point``, ``visits`` (all), per station
    (``per_station``) its name, pose (x, y m, heading deg), tolerance (null: automatic),
    visits, per source (:data:`ROLES` present) the figures of the module doc and the visits
    themselves; ``unmatched`` (visits of no station), ``summary`` per role
    (:func:`_summary`), ``without_odometry`` (logs where no standstill could be looked for)
    and the settings."""
    from lgvtool.declared import as_dict

    per_station: list[JSON] = []
    by_role: dict[str, list[JSONObject]] = {r: [] for r in ROLES}
    for st in found.stations:
        sources: list[JSON] = []
        for role in ROLES:
            entry = _source_entry(st, role, found.source_names.get(role, role))
            if entry is not None:
                sources.append(entry)
                by_role[role].append(entry)
        per_station.append({
            "name": st.name, "x": _num(st.x), "y": _num(st.y),
            "heading_deg": _num(math.degrees(st.heading), 4),
            "tolerance_xy_m": None if st.tolerance is None else st.tolerance[0],
            "tolerance_deg": (None if st.tolerance is None
                              else _num(math.degrees(st.tolerance[1]), 6)),
            "visits": len(st.visits), "sources": sources,
            "visit_list": [_visit_entry(v) for v in st.visits]})
    return {
        "mode": "named" if found.named else "automatic",
        "file": file,
        "reference_point": "O, the vehicle's reference point (the rotation centre)",
        "sources": {r: found.source_names.get(r, r) for r in ROLES},
        "visits": found.visits,
        "per_station": per_station,
        "unmatched": [_visit_entry(v) for v in found.unmatched],
        "summary": {r: _summary(by_role[r], found.named) for r in ROLES if by_role[r]},
        "without_odometry": list(without_odometry),
        "settings": as_dict(settings),
    }


def log_kpis(found: StationFindings, log: str) -> dict[str, float]:
    """One log's station KPIs (``kpis.csv``): ``station_visits`` (its standstills at a
    station), ``station_visits_outside`` (of them, those whose estimator pose lies outside
    the named station's tolerance; NaN without a stations file) and
    ``station_deviation_rms_m`` (RMS distance, m, of the estimator's visit poses from their
    station's pose; NaN without such a visit)."""
    d2: list[float] = []
    outside = 0
    count = 0
    for st in found.stations:
        for v in st.visits:
            if v.log != log:
                continue
            count += 1
            p = v.poses.get("estimator")
            if p is None:
                continue
            d = math.hypot(p.x - st.x, p.y - st.y)
            d2.append(d * d)
            if st.tolerance is not None and (
                    d > st.tolerance[0]
                    or abs(wrap_scalar(p.heading - st.heading)) > st.tolerance[1]):
                outside += 1
    return {"station_visits": float(count),
            "station_visits_outside": float(outside) if found.named else math.nan,
            "station_deviation_rms_m": math.sqrt(sum(d2) / len(d2)) if d2 else math.nan}


def _mm(v: JSON) -> str:
    return f"{v * 1000:.1f}" if isinstance(v, int | float) else "-"


def summary_line(section: JSONObject) -> str | None:
    """The text summary's line of a ``stations`` section; None when no log could be looked
    at (no section)."""
    if not section or "per_station" not in section:
        return None
    listed = section.get("per_station")
    per = [p for p in listed if isinstance(p, dict)] if isinstance(listed, list) else []
    visits = section.get("visits")
    unmatched = section.get("unmatched")
    n_un = len(unmatched) if isinstance(unmatched, list) else 0
    named = section.get("mode") == "named"
    head = (f"stations: {len(per)} named ({section.get('file')})" if named
            else f"stations: {len(per)} found")
    head += f", {visits} standstill{'s' if visits != 1 else ''} ({n_un} at no station)"
    summ = section.get("summary")
    parts = []
    if isinstance(summ, dict):
        for role in ROLES:
            r = summ.get(role)
            if not isinstance(r, dict):
                continue
            src = section.get("sources")
            name = src.get(role, role) if isinstance(src, dict) else role
            text = (f"{name} worst sigma x {_mm(r.get('sigma_x_max_m'))}, y "
                    f"{_mm(r.get('sigma_y_max_m'))} mm (stops alone "
                    f"{_mm(r.get('stops_alone_sigma_x_max_m'))}, "
                    f"{_mm(r.get('stops_alone_sigma_y_max_m'))}), 95 % radius "
                    f"{_mm(r.get('radius95_max_m'))} mm")
            if named:
                text += f", {r.get('passed')} passed, {r.get('failed')} failed"
            parts.append(text)
    blind = section.get("without_odometry")
    if isinstance(blind, list) and blind:
        parts.append(f"{len(blind)} log{'s' if len(blind) != 1 else ''} without odometry "
                     "(no standstill looked for)")
    return head + ("; " + "; ".join(parts) if parts else "")
