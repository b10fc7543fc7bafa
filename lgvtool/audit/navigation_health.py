"""Navigation health from the NAV's own status (``audit.json``'s ``navigation``).

What the device says of every pose it reports on /nav/pose (NAV200: the quality byte, the
number of reflectors used, ``valid``; NAV350: errorCode, navMode, infoState, meanDev,
reflectors used and its clock tick) turned into: the share of time in navigation, every
dropout (an interval of at least one NAV period without a valid pose), the reflectors used
per pose, the NAV350's meanDev percentiles, pose jumps (the NAV pose's step against the
odometry's step over the same interval), the NAV-to-host latency and the device clock's
jumps, and the same figures in VDA 5050's terms (``positionInitialized``,
``localizationScore``, ``deviationRange``; docs/audit.md gives the mapping).

Pure: :class:`NavStatusTap` collects the pose fields from a log's raw messages (bytes in,
arrays out) and :func:`navigation_health` computes the section from arrays. Times in s after
the log's first motion or observation message (the audit's clock), positions m, angles rad.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.declared import setting
from lgvtool.json_types import JSONObject
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.log.reader import RawBlock

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

__all__ = ["Dropout", "NavStatus", "NavStatusTap", "NavigationHealth", "NavigationSettings",
           "PoseJump", "navigation_health", "navigation_section", "odometry_path"]

#: percentiles reported of every distribution, %
PERCENTILES = (50, 90, 95, 99)

#: the NAV350's device tick counter wraps at 2**32 ms
_TICK_WRAP = 2**32


@dataclass(frozen=True)
class NavigationSettings:
    """The thresholds of the navigation-health section (``--set navigation.<key>=<value>``)."""

    dropout_gap_periods: float = setting(
        1.5,
        "A dropout is a gap between consecutive valid poses longer than this many NAV periods "
        "(the median interval between the device's pose replies): at least one expected pose "
        "was missing or invalid.",
        unit="", minimum=1.0, min_open=True, maximum=100.0)
    min_reflectors: int = setting(
        3,
        "An invalid pose whose reply reports fewer reflectors used than this is put down to "
        "the site (too few reflectors for a position: the NAV200 and NAV350 need three), "
        "not to the device.",
        unit="", minimum=1, maximum=64)
    jump_m: float = setting(
        0.25,
        "A pose jump: the NAV pose's step between consecutive valid poses differs from the "
        "odometry's step over the same interval by more than this, m. A NAV200 reply carries "
        "the newest revolution's pose, up to one revolution (1/8 s) older than its time "
        "stamp: at the simulated drive's speed that alone makes up to 0.15 m on a clean "
        "drive (a NAV350 reports each revolution's pose as it is computed: below 0.07 m).",
        unit="m", minimum=0.0, min_open=True)
    jump_rad: float = setting(
        0.05,
        "A pose jump also when the heading steps differ by more than this, rad (about 3 deg; "
        "a clean simulated drive stays below 0.03 rad).",
        unit="rad", minimum=0.0, min_open=True)
    jump_max_interval_s: float = setting(
        2.0,
        "Steps are compared only between valid poses at most this far apart, s: over a longer "
        "gap the odometry's own drift is not small.",
        unit="s", minimum=0.0, min_open=True)
    clock_jump_s: float = setting(
        0.05,
        "A device clock jump: between consecutive poses the device tick advanced by more than "
        "this more or less than the host clock, s (the host's reception jitter stays below).",
        unit="s", minimum=0.0, min_open=True)


@dataclass(frozen=True)
class NavStatus:
    """The device's pose replies of one log, in time order.

    ``pose``: the head's reported poses (t s on the audit's clock, x, y m, heading rad;
    meaningless where not ``valid``); ``valid``: the log's flag (NAV200: quality not 0xFE/0xFF; NAV350:
    a pose and errorCode 0); ``quality`` (NAV200 0-100, NAV350 0), ``used`` (reflectors used),
    ``error_code`` (NAV350; 0 elsewhere), ``mean_dev`` (NAV350 meanDev as reported, NaN when
    absent), ``nav_mode`` and ``info_state`` (NAV350, -1 when absent), ``device_ms`` (NAV350
    tick, ms, -1 when absent) and ``device_stamp`` (the host time of that tick by the online
    clock estimate, s on the same clock as ``t``, NaN when absent).
    """

    pose: Trajectory
    valid: BoolArray
    quality: IntArray
    used: IntArray
    error_code: IntArray
    mean_dev: FloatArray
    nav_mode: IntArray
    info_state: IntArray
    device_ms: IntArray
    device_stamp: FloatArray
    device_errors: FloatArray = field(default_factory=lambda: np.zeros(0))
    """When the device answered a poll with an error reply that is not on /nav/pose (a
    NAV200's: ``device_error`` on /diagnostics), s on the same clock as ``t``."""

    @property
    def t(self) -> FloatArray:
        """When each reply was received, s."""
        return self.pose.t

    @property
    def x(self) -> FloatArray:
        """The head's x, m."""
        return self.pose.x

    @property
    def y(self) -> FloatArray:
        """The head's y, m."""
        return self.pose.y

    @property
    def heading(self) -> FloatArray:
        """The head's heading, rad."""
        return self.pose.heading

    @property
    def navigating(self) -> BoolArray:
        """A valid pose without an error, per reply."""
        out: BoolArray = self.valid & (self.error_code == 0)
        return out


class NavStatusTap:
    """A tap of :func:`lgvtool.localize.logdata.load_log`: every /nav/pose message's fields
    (:class:`NavStatus`), by the message's own time stamp, and the NAV200's error replies
    (``device_error`` events of source ``nav200`` on /diagnostics, by their time stamp)."""

    topics = ("/nav/pose", "/diagnostics")

    def __init__(self) -> None:
        self.rows: list[tuple[float, ...]] = []
        self.errors_ns: list[int] = []

    def add(self, block: RawBlock) -> None:
        """Collect the /nav/pose messages and the device's error replies of one chunk."""
        import orjson

        events = block.get("/diagnostics")
        if events is not None:
            for log_ns, raw in zip(events[0], events[1], strict=True):
                if b"device_error" not in raw:  # most events are not: no JSON parse
                    continue
                e = orjson.loads(raw)
                if e.get("kind") == "device_error" and e.get("source") == "nav200":
                    ts = e.get("timestamp")
                    self.errors_ns.append(int(ts["sec"]) * 1_000_000_000 + int(ts["nsec"])
                                          if isinstance(ts, dict) else int(log_ns))
        found = block.get("/nav/pose")
        if found is None:
            return
        nan = float("nan")
        for log_ns, raw in zip(found[0], found[1], strict=True):
            d = orjson.loads(raw)
            ts = d.get("timestamp")
            t_ns = (int(ts["sec"]) * 1_000_000_000 + int(ts["nsec"]) if isinstance(ts, dict)
                    else int(log_ns))
            ds = d.get("device_stamp")
            dev_ns = (float(int(ds["sec"]) * 1_000_000_000 + int(ds["nsec"]))
                      if isinstance(ds, dict) else nan)
            self.rows.append((
                float(t_ns), float(d["x"]), float(d["y"]), float(d["heading"]),
                1.0 if d.get("valid") else 0.0, float(d.get("quality", 0)),
                float(d.get("reflectors_used", 0)), float(d.get("error_code", 0)),
                float(d["mean_dev"]) if "mean_dev" in d else nan,
                float(d.get("nav_mode", -1)), float(d.get("info_state", -1)),
                float(d.get("device_time_ms", -1)), dev_ns))

    def status(self, t0_ns: int) -> NavStatus:
        """The collected replies in time order, times s after ``t0_ns`` (ns)."""
        a = np.array(self.rows, dtype=np.float64).reshape(-1, 13)
        a = a[np.argsort(a[:, 0], kind="stable")]
        return NavStatus(
            pose=Trajectory((a[:, 0] - t0_ns) * 1e-9, a[:, 1], a[:, 2], a[:, 3], t0_ns),
            valid=a[:, 4] > 0, quality=a[:, 5].astype(np.int64), used=a[:, 6].astype(np.int64),
            error_code=a[:, 7].astype(np.int64), mean_dev=a[:, 8],
            nav_mode=a[:, 9].astype(np.int64), info_state=a[:, 10].astype(np.int64),
            device_ms=a[:, 11].astype(np.int64), device_stamp=(a[:, 12] - t0_ns) * 1e-9,
            device_errors=np.sort((np.array(self.errors_ns, dtype=np.float64) - t0_ns) * 1e-9))


@dataclass(frozen=True)
class Dropout:
    """An interval without a valid pose: ``start`` s (the first reply that was not a valid pose,
    or, when a reply was missing before it, when that reply was due: one NAV period after the
    last valid pose), ``duration`` s (to the next valid pose, or the end of the log's motion
    data or its last reply, whichever is later), where the replayed head pose was at the start
    (``x``, ``y`` m; NaN unknown),
    ``cause`` (``no_position``: the device said so with enough reflectors; ``few_reflectors``:
    it said so reporting fewer than ``min_reflectors``; ``error``: an error code, or an error
    reply of the device's after the last valid pose (:attr:`NavStatus.device_errors`);
    ``no_reply``: no pose reply at all), ``replies`` (the replies in it) and
    ``used_min`` (fewest reflectors used among them, -1 none)."""

    start: float
    duration: float
    x: float
    y: float
    cause: str
    replies: int
    used_min: int


@dataclass(frozen=True)
class PoseJump:
    """A NAV step that the odometry does not explain: at ``t`` s (the later pose), ``x``, ``y``
    m (that pose), the position difference ``jump_m`` m and the heading difference
    ``jump_rad`` rad (signed)."""

    t: float
    x: float
    y: float
    jump_m: float
    jump_rad: float


@dataclass(frozen=True)
class NavigationHealth:
    """One log's navigation health (:func:`navigation_health`)."""

    period_s: float
    """The NAV period: median interval between pose replies, s (NaN with fewer than two)."""
    span_s: float
    """First to last pose reply, s."""
    replies: int
    navigating: int
    """Replies with a valid pose and no error."""
    errors: int
    """Replies with a non-zero error code (NAV350)."""
    share_in_navigation: float
    """1 - dropout time / span (NaN without replies)."""
    dropouts: tuple[Dropout, ...]
    used_counts: tuple[tuple[int, int], ...]
    """(reflectors used, valid poses reporting it), by count."""
    mean_dev: tuple[float, ...]
    """The NAV350 meanDev at :data:`PERCENTILES` and its maximum (empty: none in the log)."""
    nav_modes: tuple[tuple[int, int], ...]
    """(NAV350 navMode, replies), by mode (empty: none)."""
    info_states: tuple[tuple[int, int], ...]
    """(NAV350 infoState, replies), by value (empty: none)."""
    step_difference_m: tuple[float, ...]
    """The position step difference to the odometry at :data:`PERCENTILES` and its maximum,
    m (empty: no odometry, or no two valid poses close enough)."""
    jumps: tuple[PoseJump, ...]
    latency_s: tuple[float, ...]
    """NAV-to-host latency (reply received minus the host time of its tick) at
    :data:`PERCENTILES` and its maximum, s (empty: no device time stamps)."""
    clock_jumps: tuple[tuple[float, float], ...]
    """(t s, the tick's step minus the host's step s) of each device clock jump."""
    clock_drift_ppm: float
    """Slope of host minus device time (ppm; NaN without device ticks)."""
    scores: tuple[float, ...]
    """VDA 5050 localizationScore (NAV200 quality / 100) at 5, 50 % (empty: no score)."""


def _percentiles(v: FloatArray) -> tuple[float, ...]:
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return ()
    return (*(float(p) for p in np.percentile(v, PERCENTILES)), float(v.max()))


def _counts(v: IntArray) -> tuple[tuple[int, int], ...]:
    values, counts = np.unique(v, return_counts=True)
    return tuple((int(a), int(b)) for a, b in zip(values, counts, strict=True))


def odometry_path(t: FloatArray, ds: FloatArray, dth: FloatArray) -> Trajectory:
    """The dead-reckoned path of O from motion increments (``t`` s, one more than ``ds`` m
    and ``dth`` rad; midpoint heading), from (0, 0, 0); the heading not wrapped."""
    th = np.concatenate(([0.0], np.cumsum(dth)))
    mid = th[:-1] + 0.5 * dth
    x = np.concatenate(([0.0], np.cumsum(ds * np.cos(mid))))
    y = np.concatenate(([0.0], np.cumsum(ds * np.sin(mid))))
    return Trajectory(t, x, y, th)


def _step(xa: FloatArray, ya: FloatArray, tha: FloatArray, xb: FloatArray, yb: FloatArray,
          thb: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The step from poses a to poses b in a's frame: forward m, left m, heading rad."""
    dx, dy = xb - xa, yb - ya
    c, s = np.cos(tha), np.sin(tha)
    return c * dx + s * dy, -s * dx + c * dy, thb - tha


def _jumps(st: NavStatus, ok: BoolArray, odometry: Trajectory | None,
           nav_offset: tuple[float, float], s: NavigationSettings
           ) -> tuple[tuple[float, ...], tuple[PoseJump, ...]]:
    """The step differences' percentiles and the pose jumps (:class:`PoseJump`)."""
    if odometry is None or len(odometry) < 2 or int(ok.sum()) < 2:
        return (), ()
    ot = odometry.t
    idx = np.flatnonzero(ok)
    ta, tb = st.t[idx[:-1]], st.t[idx[1:]]
    keep = ((tb - ta) <= s.jump_max_interval_s) & (ta >= ot[0]) & (tb <= ot[-1])
    a, b = idx[:-1][keep], idx[1:][keep]
    if len(a) == 0:
        return (), ()
    # the NAV head's poses moved to O (lgvtool.localize.geometry.nav_to_o)
    nx, ny = nav_offset
    c, sn = np.cos(st.heading), np.sin(st.heading)
    x_o = st.x - nx * c + ny * sn
    y_o = st.y - nx * sn - ny * c
    f_n, l_n, h_n = _step(x_o[a], y_o[a], st.heading[a], x_o[b], y_o[b], st.heading[b])
    pa, pb = odometry.interpolate(st.t[a]), odometry.interpolate(st.t[b])
    f_o, l_o, h_o = _step(pa.x, pa.y, pa.heading, pb.x, pb.y, pb.heading)
    d_m = np.hypot(f_n - f_o, l_n - l_o)
    d_rad = wrap_angle(h_n - h_o)
    hit = (d_m > s.jump_m) | (np.abs(d_rad) > s.jump_rad)
    jumps = tuple(PoseJump(float(st.t[j]), float(st.x[j]), float(st.y[j]), float(m),
                           float(r))
                  for j, m, r in zip(b[hit], d_m[hit], d_rad[hit], strict=True))
    return _percentiles(d_m), jumps


def _dropouts(st: NavStatus, ok: BoolArray, period: float, track: Trajectory | None,
              s: NavigationSettings, log_end: float) -> tuple[Dropout, ...]:
    """Every interval without a valid pose of at least one NAV period (:class:`Dropout`);
    ``log_end``: when the log's motion data end, s (-inf: unknown), so that replies that stop
    before the log does make a dropout too."""
    n = len(st.t)
    if n == 0 or not math.isfinite(period):
        return ()
    idx = np.flatnonzero(ok)
    # (index of the last valid reply before, index of the next valid reply or None)
    spans: list[tuple[int, int | None]] = []
    if len(idx) == 0:
        spans.append((-1, None))
    else:
        if idx[0] > 0:
            spans.append((-1, int(idx[0])))
        gaps = np.flatnonzero(np.diff(st.t[idx]) > s.dropout_gap_periods * period)
        spans += [(int(idx[k]), int(idx[k + 1])) for k in gaps]
        if idx[-1] < n - 1 or log_end - float(st.t[idx[-1]]) > s.dropout_gap_periods * period:
            spans.append((int(idx[-1]), None))
    out = []
    for before, after in spans:
        lo = before + 1
        hi = n if after is None else after
        inside = np.arange(lo, hi)
        gap = s.dropout_gap_periods * period
        if before >= 0 and (len(inside) == 0 or float(st.t[lo] - st.t[before]) > gap):
            start = float(st.t[before]) + period  # a reply missing first: when it was due
        elif len(inside):
            start = float(st.t[lo])
        else:
            continue
        end = float(st.t[after]) if after is not None else max(float(st.t[-1]), log_end)
        if after is None and end - start < period:
            end = start + period  # the log ends inside the dropout: at least one period
        used = st.used[inside]
        errors = st.error_code[inside] != 0
        # an error reply (not on /nav/pose) after the last valid pose, before the next
        after_valid = float(st.t[before]) if before >= 0 else -math.inf
        replied_error = bool(np.any((st.device_errors > after_valid)
                                    & (st.device_errors < end)))
        if bool(errors.any()) or replied_error:
            cause = "error"
        elif len(inside) == 0:
            cause = "no_reply"
        elif int(used.min()) < s.min_reflectors:
            cause = "few_reflectors"
        else:
            cause = "no_position"
        x = y = float("nan")
        if track is not None and len(track):
            at = track.interpolate([start])
            x, y = float(at.x[0]), float(at.y[0])
        out.append(Dropout(start, end - start, x, y, cause, len(inside),
                           int(used.min()) if len(inside) else -1))
    return tuple(out)


def _clock(st: NavStatus, s: NavigationSettings
           ) -> tuple[tuple[float, ...], tuple[tuple[float, float], ...], float]:
    """Latency percentiles, clock jumps and drift from the NAV350 ticks."""
    has = st.device_ms >= 0
    stamp_ok = np.isfinite(st.device_stamp)
    latency = _percentiles(st.t[stamp_ok] - st.device_stamp[stamp_ok]) if stamp_ok.any() else ()
    if int(has.sum()) < 2:
        return latency, (), float("nan")
    t = st.t[has]
    ticks = st.device_ms[has]
    dev = np.concatenate(([0], np.cumsum(np.mod(np.diff(ticks), _TICK_WRAP)))) * 1e-3
    step = np.diff(dev) - np.diff(t)
    hit = np.flatnonzero(np.abs(step) > s.clock_jump_s)
    jumps = tuple((float(t[k + 1]), float(step[k])) for k in hit)
    # the drift outside the jumps: each jump's step taken out of the device's time
    fixed = dev - np.concatenate(([0.0], np.cumsum(np.where(np.abs(step) > s.clock_jump_s,
                                                              step, 0.0))))
    offset = t - fixed
    drift = (float(np.polyfit(t, offset, 1)[0]) * 1e6
             if float(t[-1] - t[0]) > 0 else float("nan"))
    return latency, jumps, drift


def navigation_health(st: NavStatus, *, track: Trajectory | None,
                      odometry: Trajectory | None, nav_offset: tuple[float, float],
                      settings: NavigationSettings) -> NavigationHealth:
    """One log's navigation health from its pose replies ``st``; ``track``: the replayed head
    poses (s on the same clock, m, rad) that place the dropouts (None: not placed);
    ``odometry``: the dead-reckoned path of O (:func:`odometry_path`; None: no pose jumps),
    whose last sample is where the log ends (replies that stop before it: a dropout);
    ``nav_offset``: the head's mounting (nav_x, nav_y m from O)."""
    s = settings
    ok = st.navigating
    n = len(st.t)
    period = float(np.median(np.diff(st.t))) if n >= 2 else float("nan")
    # the replies' span, to the end of the motion data when they stop before it
    log_end = float(odometry.t[-1]) if odometry is not None and len(odometry) else -math.inf
    span = max(float(st.t[-1]), log_end) - float(st.t[0]) if n else 0.0
    drops = _dropouts(st, ok, period, track, s, log_end)
    lost = sum(d.duration for d in drops)
    share = (max(0.0, 1.0 - lost / span) if span > 0 else
             (float(ok.all()) if n else float("nan")))
    md = st.mean_dev[ok]
    step_pct, jumps = _jumps(st, ok, odometry, nav_offset, s)
    latency, clock_jumps, drift = _clock(st, s)
    has_quality = bool(np.any(st.quality[ok] > 0))
    scores = (tuple(float(v) for v in np.percentile(st.quality[ok] / 100.0, (5, 50)))
              if has_quality else ())
    return NavigationHealth(
        period_s=period, span_s=span, replies=n, navigating=int(ok.sum()),
        errors=int(np.count_nonzero(st.error_code)) + len(st.device_errors),
        share_in_navigation=share,
        dropouts=drops, used_counts=_counts(st.used[ok]),
        mean_dev=_percentiles(md) if np.isfinite(md).any() else (),
        nav_modes=_counts(st.nav_mode[st.nav_mode >= 0]),
        info_states=_counts(st.info_state[st.info_state >= 0]),
        step_difference_m=step_pct, jumps=jumps, latency_s=latency, clock_jumps=clock_jumps,
        clock_drift_ppm=drift, scores=scores)


def _num(v: float, digits: int = 4) -> float | None:
    return round(v, digits) if math.isfinite(v) else None


def _pct(values: Sequence[float], digits: int) -> JSONObject | None:
    """{p50, p90, p95, p99, max} of a :data:`PERCENTILES` tuple, None when empty."""
    if not values:
        return None
    keys = [f"p{p}" for p in PERCENTILES] + ["max"]
    return {k: _num(v, digits) for k, v in zip(keys, values, strict=True)}


def _log_section(path: str, family: str, h: NavigationHealth) -> JSONObject:
    """One log's part of ``navigation`` (docs/audit.md, "Navigation health")."""
    md = _pct(h.mean_dev, 1)
    ok_share = h.navigating / h.replies if h.replies else float("nan")
    return {
        "path": path, "device": family,
        "period_s": _num(h.period_s), "span_s": _num(h.span_s, 3), "replies": h.replies,
        "navigating": h.navigating, "error_replies": h.errors,
        "share_in_navigation": _num(h.share_in_navigation),
        "dropouts": [{"start_s": _num(d.start, 3), "duration_s": _num(d.duration, 3),
                      "x": _num(d.x, 3), "y": _num(d.y, 3), "cause": d.cause,
                      "replies": d.replies, "reflectors_used_min": d.used_min}
                     for d in h.dropouts],
        "dropout_time_s": _num(sum(d.duration for d in h.dropouts), 3),
        "reflectors_used": {str(k): v for k, v in h.used_counts},
        "mean_dev": None if md is None else {**md, "unit": "not documented (mm inferred)"},
        "nav_mode": {str(k): v for k, v in h.nav_modes} or None,
        "info_state": {str(k): v for k, v in h.info_states} or None,
        "step_difference_m": _pct(h.step_difference_m, 4),
        "pose_jumps": [{"t_s": _num(j.t, 3), "x": _num(j.x, 3), "y": _num(j.y, 3),
                        "jump_m": _num(j.jump_m), "jump_rad": _num(j.jump_rad, 5)}
                       for j in h.jumps],
        "latency_s": _pct(h.latency_s, 4),
        "clock_jumps": [{"t_s": _num(t, 3), "step_s": _num(v, 4)} for t, v in h.clock_jumps],
        "clock_drift_ppm": _num(h.clock_drift_ppm, 1),
        "vda5050": {
            "positionInitialized_share": _num(ok_share),
            "localizationScore": (None if not h.scores else
                                  {"p5": _num(h.scores[0], 3), "p50": _num(h.scores[1], 3)}),
            "deviationRange_m": (None if md is None else
                                 {k: (None if not isinstance(v, float) else round(v / 1000, 4))
                                  for k, v in md.items()}),
        },
    }


def navigation_section(logs: Sequence[tuple[str, str, NavigationHealth | None]],
                       settings: NavigationSettings) -> JSONObject:
    """``audit.json``'s ``navigation``: the totals over the logs, each log's part and the
    settings; ``logs``: (path, device family, health; None: the log has no NAV poses)."""
    from lgvtool.declared import as_dict

    parts = [(p, f, h) for p, f, h in logs if h is not None]
    span = sum(h.span_s for _, _, h in parts)
    lost = sum(d.duration for _, _, h in parts for d in h.dropouts)
    causes: dict[str, int] = {}
    for _, _, h in parts:
        for d in h.dropouts:
            causes[d.cause] = causes.get(d.cause, 0) + 1
    out: JSONObject = {
        "share_in_navigation": _num(max(0.0, 1.0 - lost / span)) if span > 0 else None,
        "dropouts": sum(len(h.dropouts) for _, _, h in parts),
        "dropout_causes": dict(sorted(causes.items())),
        "dropout_time_s": _num(lost, 3),
        "pose_jumps": sum(len(h.jumps) for _, _, h in parts),
        "clock_jumps": sum(len(h.clock_jumps) for _, _, h in parts),
        "logs": [_log_section(p, f, h) for p, f, h in parts],
        "without_poses": [p for p, _, h in logs if h is None],
        "settings": as_dict(settings),
    }
    return out

