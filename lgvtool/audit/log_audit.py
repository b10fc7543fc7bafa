"""One log's audit evidence (:func:`log_evidence`): the log read once, replayed with one
estimator (:mod:`lgvtool.localize.replay_driver`), and turned into the reflector evidence
(:mod:`lgvtool.audit.reflector_audit`), the unmapped detections
(:mod:`lgvtool.audit.unmapped_objects`), the coverage along the drive
(:mod:`lgvtool.audit.coverage`), the device's own navigation status
(:mod:`lgvtool.audit.navigation_health`), the errors by segment against the truth
(:mod:`lgvtool.audit.segment_errors`) and the visits of stations: the standstills with each
source's pose there (:mod:`lgvtool.audit.stations`). This is what a worker of the fleet
engine computes per log; what it returns is small (moments, the head track the coverage
needs, the visits) and pools.

Positions m, angles rad, times s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.audit.audit_settings import AuditSettings
from lgvtool.audit.coverage import CoverageSettings, HeadTrack, PoseCoverage, coverage_at_poses
from lgvtool.audit.navigation_health import NavigationHealth, NavigationSettings, NavStatusTap
from lgvtool.audit.reflector_audit import DEVICE_VALUES, ReflectorEvidence, reflector_evidence
from lgvtool.audit.segment_errors import SegmentErrors, SegmentSettings
from lgvtool.audit.stations import StationSettings, Visit
from lgvtool.audit.unmapped_objects import UnmappedEvidence
from lgvtool.audit.visibility import DeviceView
from lgvtool.config import Config, Reflector
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.localize.logdata import LogData
    from lgvtool.log import LogReader
    from lgvtool.log.reader import RawBlock

FloatArray = NDArray[np.float64]

__all__ = ["NO_LANDMARKS", "LogAuditOptions", "LogEvidence", "best_estimator", "log_evidence"]

NO_LANDMARKS = ("reflectors not audited: that needs landmark observations (/nav/reflectors), "
                "which this log does not hold (a NAV200 recording of poses); coverage only")
"""What the audit says of a log without reflector scans."""


@dataclass(frozen=True, slots=True)
class LogAuditOptions:
    """How each log is audited: small and picklable, sent with every log to a worker."""

    estimator: str | None = None
    """Estimator whose replayed pose the audit uses; None: :func:`best_estimator`."""
    config: Config | None = None
    """Configuration used instead of the log's own; None: the log's."""
    seed: int = 0
    """Seed of the estimator's random draws."""
    settings: Mapping[str, object] = field(default_factory=dict)
    """Estimator settings (``pf.particles`` -> 500)."""
    audit: AuditSettings = field(default_factory=AuditSettings)
    """The audit's thresholds."""
    view: Mapping[str, object] = field(default_factory=dict)
    """Overrides of the device's view (:class:`DeviceView` fields)."""
    coverage: CoverageSettings = field(default_factory=CoverageSettings)
    """How the coverage is summarised."""
    navigation: NavigationSettings = field(default_factory=NavigationSettings)
    """The navigation-health thresholds."""
    segments: SegmentSettings = field(default_factory=SegmentSettings)
    """How the errors by segment are binned."""
    stations: StationSettings = field(default_factory=StationSettings)
    """How standstills are found (:mod:`lgvtool.audit.stations`)."""


@dataclass(frozen=True)
class LogEvidence:
    """What one log gave the audit."""

    path: str
    estimator: str
    """The estimator whose pose was used."""
    chosen_because: str
    """Why that one (``"asked for"``, or why it is the best this log allows)."""
    family: str
    """The NAV family of the log: nav350 (landmarks with the device's ids and quality) or
    nav200."""
    duration_s: float
    layout: tuple[Reflector, ...]
    view: DeviceView
    track: HeadTrack
    """The head's replayed poses (s after the log's first message)."""
    coverage: PoseCoverage
    reflectors: ReflectorEvidence | None
    """None: the log holds no landmark observations."""
    unmapped: UnmappedEvidence | None
    note: str | None = None
    """What could not be audited in this log, one line."""
    navigation: NavigationHealth | None = None
    """The device's own navigation status (:mod:`lgvtool.audit.navigation_health`); None:
    the log holds no NAV poses."""
    segments: tuple[SegmentErrors, ...] = ()
    """The errors by segment (:mod:`lgvtool.audit.segment_errors`) of the replayed estimator
    and the laser against the truth, else of the laser against the estimator; empty: nothing
    to compare."""
    visits: tuple[Visit, ...] = ()
    """The log's standstills with each source's pose of O there
    (:func:`lgvtool.audit.stations.log_visits`); they pool into stations over the logs."""
    has_odometry: bool = True
    """Whether the log has motion samples to find standstills in."""


def best_estimator(data: LogData) -> tuple[str, str]:
    """The estimator the audit replays a log with when none is named, and why: ``pf`` on
    reflector scans (it weighs every landmark, and keeps the pose of each revolution), else
    ``ekf`` on NAV poses with odometry, else ``laser`` (the NAV's own poses).

    :raises MissingDataError: the log has neither scans nor valid NAV poses.
    """
    from lgvtool.errors import MissingDataError

    if data.has_scans:
        return "pf", "the best available: the log has reflector scans"
    if data.has_poses and data.has_motion:
        return "ekf", "the best available: NAV poses and odometry, no reflector scans"
    if data.has_poses:
        return "laser", "the best available: NAV poses only"
    raise MissingDataError("the log has no observations to audit: neither reflector scans "
                           "(/nav/reflectors) nor valid NAV poses (/nav/pose)")


class _ScanExtras:
    """A tap of :func:`lgvtool.localize.logdata.load_log`: the NAV350 fields the estimators do
    not read, per observation of /nav/reflectors: the device's values
    (:data:`~lgvtool.audit.reflector_audit.DEVICE_VALUES`, NaN when absent), and whether any
    observation carries a global id (a NAV350's landmarks)."""

    topics = ("/nav/reflectors",)

    def __init__(self) -> None:
        self.log_ns: list[NDArray[np.int64]] = []
        self.counts: list[NDArray[np.int64]] = []
        self.values: list[FloatArray] = []
        self.global_ids = False

    def add(self, block: RawBlock) -> None:
        import orjson

        found = block.get("/nav/reflectors")
        if found is None:
            return
        nan = float("nan")
        counts = []
        values: list[list[float]] = []
        for raw in found[1]:
            obs = orjson.loads(raw).get("observations", [])
            values.extend([float(o[k]) if k in o else nan for k in DEVICE_VALUES] for o in obs)
            if not self.global_ids and any("global_id" in o for o in obs):
                self.global_ids = True
            counts.append(len(obs))
        self.log_ns.append(found[0])
        self.counts.append(np.array(counts, dtype=np.int64))
        self.values.append(np.array(values, dtype=np.float64).reshape(-1, len(DEVICE_VALUES)))

    def per_observation(self) -> FloatArray:
        """The device values of every observation (rows; columns as
        :data:`~lgvtool.audit.reflector_audit.DEVICE_VALUES`), scans in log-time order
        (stable, as the estimators' scans), observations in measurement order."""
        if not self.log_ns:
            return np.zeros((0, len(DEVICE_VALUES)))
        log_ns = np.concatenate(self.log_ns)
        counts = np.concatenate(self.counts)
        values = np.concatenate(self.values)
        if len(log_ns) < 2 or bool(np.all(log_ns[1:] >= log_ns[:-1])):
            return values
        order = np.argsort(log_ns, kind="stable")
        starts = np.concatenate(([0], np.cumsum(counts)))[:-1]
        chosen = counts[order]
        ends = np.cumsum(chosen)
        flat = np.repeat(starts[order] - (ends - chosen), chosen) + np.arange(int(ends[-1]))
        out: FloatArray = values[flat]
        return out


class _Taps:
    """Several taps of :func:`lgvtool.localize.logdata.load_log` as one."""

    def __init__(self, *taps: _ScanExtras | NavStatusTap) -> None:
        self.taps = taps
        self.topics = tuple(dict.fromkeys(t for tap in taps for t in tap.topics))

    def add(self, block: RawBlock) -> None:
        for tap in self.taps:
            tap.add(block)


def _increments(data: LogData, cfg: Config) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """The log's odometry as motion increments (sample times s, distance m and heading change
    rad per increment; the estimators' default fusion), None without motion samples."""
    from lgvtool.localize.motion import MotionSettings

    if not data.has_motion:
        return None
    inc = data.increments(MotionSettings(), cfg.vehicle)
    return (np.asarray(inc.t, dtype=np.float64), np.asarray(inc.ds, dtype=np.float64),
            np.asarray(inc.dth, dtype=np.float64))


def _navigation(status: NavStatusTap, track: Trajectory,
                increments: tuple[FloatArray, FloatArray, FloatArray] | None, cfg: Config,
                settings: NavigationSettings) -> NavigationHealth | None:
    """The log's navigation health (None without NAV poses): dropouts placed on the replayed
    head ``track`` (s, m, rad), steps against the odometry of the log's motion
    ``increments`` (:func:`_increments`)."""
    from lgvtool.audit.navigation_health import navigation_health, odometry_path

    if not status.rows:
        return None
    odometry = None if increments is None else odometry_path(*increments)
    return navigation_health(status.status(track.t0_ns), track=track, odometry=odometry,
                             nav_offset=(cfg.vehicle.nav_x, cfg.vehicle.nav_y),
                             settings=settings)


def _family(reader: LogReader, extras: _ScanExtras) -> str:
    """nav350 when the log holds NAV350 traffic or landmarks with global ids, else nav200."""
    if extras.global_ids or reader.has_topic("/nav350/rx") or reader.has_topic("/nav350/tx"):
        return "nav350"
    return "nav200"


def log_evidence(path: str, options: LogAuditOptions) -> LogEvidence:
    """Read and replay the log at ``path`` and gather its audit evidence (module doc).

    :raises InputError: (or a subclass; exit 2) an unreadable log, a log without a reflector
        layout, an unknown estimator, or one that cannot run on the log.
    """
    import warnings

    from lgvtool.audit.segment_errors import log_segments
    from lgvtool.audit.stations import log_visits
    from lgvtool.errors import MissingDataError
    from lgvtool.gc_pause import collector_paused
    from lgvtool.localize.geometry import o_to_nav
    from lgvtool.localize.installation import apply_installation
    from lgvtool.localize.logdata import LazyScans, load_log, scan_batch
    from lgvtool.localize.registry import check_names
    from lgvtool.localize.replay_driver import replay_data
    from lgvtool.log import LogReader

    o = options
    if o.estimator is not None:
        check_names([o.estimator])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        reader = LogReader(path)
    cfg = o.config if o.config is not None else reader.config()
    layout = cfg.reflectors if o.config is not None or _holds_layout(reader) else ()
    if not layout:
        raise MissingDataError(f"{path}: the log holds no reflector layout (/map/reflectors or "
                               "a stored configuration) and none was given (--config): the "
                               "audit compares the drive against the layout")
    extras = _ScanExtras()
    status = NavStatusTap()
    with collector_paused():
        data = load_log(reader, layout, tap=_Taps(extras, status), decode_scans=True,
                        truth=True)
        name, why = ((o.estimator, "asked for") if o.estimator is not None
                     else best_estimator(data))
        result = replay_data(data, [name], config=cfg, seed=o.seed, settings=dict(o.settings),
                             threads=1)
    if name in result.skipped:
        raise MissingDataError(f"{path}: {result.skipped[name]}")
    est = result.estimates[name]
    family = _family(reader, extras)
    view = DeviceView.for_family(family, o.view)
    t = np.asarray(est.t, dtype=np.float64)
    hx, hy, hth = o_to_nav(est.x, est.y, est.heading, cfg.vehicle.nav_x, cfg.vehicle.nav_y)
    nav = data.nav
    used = None if nav is None else nav.get("used")
    track = HeadTrack.of(t, hx, hy, hth, source=name, name=_log_name(path),
                         reported_t=None if used is None or nav is None else nav["t"],
                         reported_used=used)
    coverage = coverage_at_poses(track, layout, view, o.coverage)
    duration = float(data.end)
    increments = _increments(data, cfg)
    health = _navigation(status, Trajectory(t, hx, hy, hth, data.t0_ns), increments, cfg,
                         o.navigation)
    estimate = Trajectory(t, est.x, est.y, est.heading, data.t0_ns)
    laser = _laser_at_o(data, cfg)
    truth = data.truth if data.truth is not None and len(data.truth) >= 2 else None
    segments = log_segments(estimate, name, laser, truth, o.segments)
    visits = () if increments is None else log_visits(
        path, increments, {"truth": truth, "laser": laser, "estimator": estimate}, name,
        o.stations)
    if not data.has_scans:
        return LogEvidence(path, name, why, family, duration, tuple(layout), view, track,
                           coverage, None, None, NO_LANDMARKS, navigation=health,
                           segments=segments, visits=visits,
                           has_odometry=increments is not None)
    settled = _settled(est.covariance, len(t), o.audit.max_pose_sigma_m)
    corrected = apply_installation(data, cfg.vehicle)
    scans = corrected.scans
    batch = scans.batch() if isinstance(scans, LazyScans) else scan_batch(scans)
    device = extras.per_observation()
    if len(device) != len(batch.ranges):
        device = np.full((len(batch.ranges), len(DEVICE_VALUES)), np.nan)
    refl, unmapped = reflector_evidence(
        layout, est, settled, batch, device, nav_x=cfg.vehicle.nav_x, nav_y=cfg.vehicle.nav_y,
        t0_s=data.t0_ns * 1e-9, view=view, settings=o.audit)
    return LogEvidence(path, name, why, family, duration, tuple(layout), view, track, coverage,
                       refl, unmapped, navigation=health, segments=segments, visits=visits,
                       has_odometry=increments is not None)


def _laser_at_o(data: LogData, cfg: Config) -> Trajectory | None:
    """The NAV's valid poses moved from the head to O (s, m, rad; the errors by segment and
    the stations' raw laser); None: no valid NAV pose."""
    from lgvtool.localize.geometry import nav_to_o

    nav = data.nav
    if nav is None or not bool(np.any(nav["valid"])):
        return None
    ok = np.asarray(nav["valid"], dtype=bool)
    x, y, th = nav_to_o(nav["x"][ok], nav["y"][ok], nav["heading"][ok], cfg.vehicle.nav_x,
                        cfg.vehicle.nav_y)
    return Trajectory.cleaned(nav["t"][ok], x, y, th, data.t0_ns)


def _holds_layout(reader: LogReader) -> bool:
    """Whether the log holds its own reflector layout (/map/reflectors, or reflectors in its
    stored configuration), not only the defaults a configuration falls back on."""
    if reader.has_topic("/map/reflectors"):
        return True
    stored = reader.metadata.get("config")
    return isinstance(stored, dict) and bool(stored.get("reflectors"))


def _settled(covariance: FloatArray | None, n: int, max_sigma: float) -> NDArray[np.bool_]:
    """Per pose: its position 1-sigma (root of the covariance's x and y variances' sum, m)
    within ``max_sigma`` (all, without a covariance)."""
    if covariance is None:
        return np.ones(n, dtype=bool)
    cov = np.asarray(covariance, dtype=np.float64)
    var = cov[:, 0] + cov[:, 4]
    out: NDArray[np.bool_] = ~(var > max_sigma * max_sigma)
    return out


def _log_name(path: str) -> str:
    """The log's file name without its folder."""
    from pathlib import Path

    return Path(path).name


def same_layout(parts: Sequence[LogEvidence]) -> bool:
    """Whether every log's layout is the same (ids, and positions within 1 mm)."""
    first = parts[0].layout
    for p in parts[1:]:
        if len(p.layout) != len(first):
            return False
        for a, b in zip(first, p.layout, strict=True):
            if a.id != b.id or abs(a.x - b.x) > 1e-3 or abs(a.y - b.y) > 1e-3:
                return False
    return True
