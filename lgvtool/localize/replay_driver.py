"""The replay driver: run estimators over the motion and observations of a log.

:func:`run_replay` reads what the estimators need from a :class:`lgvtool.log.LogReader`
(:func:`load_log`) and hands it to :func:`replay_data`, which is pure. For each estimator the
driver builds the odometry track its motion settings ask for, the observations its source
settings ask for (NAV poses, reflector scans, de-skewed or not), and then alternates
``predict`` (the exact body-frame motion between consecutive observation times) and ``update``.
Estimates are recorded at every observation time once the estimator is initialised.

Times inside are seconds relative to the first message of the log (``t0_ns``); the
trajectories returned carry absolute log time in s, like :meth:`LogReader.dataframe`.
"""

from __future__ import annotations

import math
import threading
import time
import zlib
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, TypeVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Config, Vehicle, default_config
from lgvtool.declared import JSONScalar
from lgvtool.errors import InputError, MissingDataError
from lgvtool.localize.estimator import Estimator, Motion
from lgvtool.localize.installation import apply_installation
from lgvtool.localize.kernel_choice import ready
from lgvtool.localize.logdata import LazyScans, LogData, load_log, scan_batch
from lgvtool.localize.motion import Deltas, MotionSettings, MotionTrack
from lgvtool.localize.observations import (
    PoseObservation,
    ScanObservation,
    scan_observations,
    sources,
)
from lgvtool.localize.obsstream import ObservationStream, Tail, scan_times, times_of
from lgvtool.localize.params import params_dict
from lgvtool.localize.pose_model import PoseModelParams, prepare_poses, vehicle_states_age
from lgvtool.localize.registry import (
    DEFAULT_ESTIMATORS,
    ESTIMATORS,
    check_names,
    motion_params,
    resolve_params,
    split_settings,
)
from lgvtool.timestamps import seconds_to_ns, seconds_to_ns_array
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.log import LogReader
    from lgvtool.log.reader import Tap

FloatArray = NDArray[np.float64]
_J = TypeVar("_J")
_T = TypeVar("_T")

__all__ = ["LazyScans", "LogData", "ReplayResult", "load_log", "replay_data", "run_replay"]


@dataclass
class ReplayResult:
    """What :func:`run_replay` returns.

    ``estimates``: per estimator its poses of O as a :class:`~lgvtool.trajectory.Trajectory`
    on the replay's clock (``t`` in s after ``t0_ns``, the log's first message; x, y in m;
    heading in rad, wrapped into (-pi, pi]) with the covariance, particle count and ESS of
    each row; ``trajectories``: the same with ``t`` in s since the epoch (the log time
    ``evaluate`` and ``export`` score); ``settings``: ``{name: {param: value}}`` effective
    parameters; ``clouds``: decimated particle clouds ``(t_ns, x, y, heading)``; ``gated``:
    the NAV poses the plausibility gate left out; ``skipped``: estimators that could not run
    on this log, with the reason; ``timings``: seconds per estimator (and ``read``).
    """

    settings: dict[str, dict[str, JSONScalar]]
    estimates: dict[str, Trajectory]
    clouds: dict[str, list[tuple[int, FloatArray, FloatArray, FloatArray]]]
    skipped: dict[str, str]
    timings: dict[str, float]
    t0_ns: int
    seed: int
    #: NAV poses the plausibility gate rejected: (log time ns, text)
    gated: list[tuple[int, str]] = field(default_factory=list)
    #: per estimator, what it did that its rows alone do not tell (its restarts and
    #: re-anchorings, :attr:`lgvtool.localize.estimator.Estimator.events`): (log time ns,
    #: kind, text)
    events: dict[str, list[tuple[int, str, str]]] = field(default_factory=dict)

    @property
    def trajectories(self) -> dict[str, Trajectory]:
        """``{name: Trajectory}`` of :attr:`estimates` with ``t`` in s since the epoch."""
        return {n: tr.on_epoch() for n, tr in self.estimates.items()}


# ---------------------------------------------------------------------------------- running


def estimator_rng(seed: int, name: str) -> np.random.Generator:
    """The generator of one estimator: derived from the user's seed and the estimator's name,
    so a filter draws the same numbers whichever other estimators run beside it."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        [int(seed) & 0xFFFFFFFF, zlib.crc32(name.encode())])))


def truth_pose_at(data: LogData, t: float) -> tuple[float, float, float] | None:
    """Ground-truth pose of O interpolated at ``t`` (s after ``t0_ns``), if the log has it."""
    tr = data.truth
    if tr is None or len(tr) == 0:
        return None
    at = tr.interpolate([t])
    return float(at.x[0]), float(at.y[0]), float(at.heading[0])


def _pose_observations(data: LogData, est_cls: type[Estimator[object]], params: object,
                       track: MotionTrack | None = None, vehicle: Vehicle | None = None
                       ) -> list[PoseObservation]:
    """The valid NAV poses, applied at receive time minus the estimator's pose latency; with
    the rotating-head pose model (``pose_model``, and the ``vehicle``) at their reference
    instants, their skew taken off (:func:`lgvtool.localize.pose_model.prepare_poses`)."""
    if data.nav is None or not data.has_poses or not est_cls.uses_poses:
        return []
    nav = data.nav
    lat = float(getattr(params, "pose_latency_s", 0.0))
    usable = nav["valid"]
    if bool(getattr(params, "pose_gate", True)) and "gate" in nav:
        usable = usable & nav["gate"]
    ok = np.nonzero(usable)[0]
    if isinstance(params, PoseModelParams) and params.pose_model == "rotating-head" and \
            vehicle is not None:
        configured = vehicle_states_age(vehicle.nav_time_offset, vehicle.nav_pose_age)
        poses, _ = prepare_poses(nav["t"][ok], nav["x"][ok], nav["y"][ok], nav["heading"][ok],
                                 track, vehicle.nav_x, vehicle.nav_y, params, lat, configured)
        return poses
    ts = (nav["t"][ok] - lat).tolist()
    xs, ys, hs = nav["x"][ok].tolist(), nav["y"][ok].tolist(), nav["heading"][ok].tolist()
    return [PoseObservation(t, x, y, h) for t, x, y, h in zip(ts, xs, ys, hs, strict=True)]


def _observations(data: LogData, est_cls: type[Estimator[object]], params: object,
                  track: MotionTrack | None, vehicle: Vehicle, *, start_poses: bool = True
                  ) -> tuple[Sequence[PoseObservation | ScanObservation],
                             list[PoseObservation]]:
    """The observations an estimator updates with, and NAV poses it may only start from
    (those only with ``start_poses``; see :func:`_start_poses`)."""
    use_scans, use_poses = sources(getattr(params, "observations", "both"),
                                   data.has_scans and est_cls.uses_scans,
                                   data.has_poses and est_cls.uses_poses)
    own: list[PoseObservation] = []
    poses: list[PoseObservation] = []
    if use_poses:
        own = _pose_observations(data, est_cls, params, track, vehicle)
    elif start_poses:
        poses = _pose_observations(data, est_cls, params)
    obs: list[PoseObservation | ScanObservation] = list(own)
    if use_scans:
        deskew = bool(getattr(params, "deskew", False))
        lo = float(getattr(params, "min_range_m", 0.0))
        hi = float(getattr(params, "max_range_m", math.inf))
        chosen = None
        if getattr(params, "scans", "all") == "nav-poll" and data.nav is not None:
            chosen = poll_scans(data.scan_received(), data.nav["t"])
        if isinstance(data.scans, LazyScans):
            return _stream(data.scans, own, chosen, vehicle, track, deskew, lo, hi), poses
        obs.extend(scan_observations(scan_batch(data.scans, chosen), vehicle.nav_x,
                                     vehicle.nav_y, track=track, deskew=deskew, min_range=lo,
                                     max_range=hi))
    obs.sort(key=lambda o: o.t)
    return obs, poses


def _stream(scans: LazyScans, poses: list[PoseObservation], chosen: list[int] | None,
            vehicle: Vehicle, track: MotionTrack | None, deskew: bool, lo: float, hi: float
            ) -> ObservationStream:
    """The poses and the scans ``chosen`` (all if None) as a stream whose scan geometry is
    built block by block (:class:`ObservationStream`)."""
    idx = chosen if chosen is not None else list(range(len(scans)))
    start, period = scans.start_and_period(idx)

    def build(a: int, b: int) -> list[ScanObservation]:
        return scan_observations(scans.batch(idx[a:b]), vehicle.nav_x, vehicle.nav_y,
                                 track=track, deskew=deskew, min_range=lo, max_range=hi)

    return ObservationStream(poses, scan_times(start, period,
                                               deskew=deskew and track is not None), build)


def _start_poses(data: LogData, est_cls: type[Estimator[object]], params: object
                 ) -> list[PoseObservation]:
    """The NAV poses an estimator may only start from: all valid ones when it does not update
    with them."""
    _, use_poses = sources(getattr(params, "observations", "both"),
                           data.has_scans and est_cls.uses_scans,
                           data.has_poses and est_cls.uses_poses)
    return [] if use_poses else _pose_observations(data, est_cls, params)


def poll_scans(received: FloatArray, poll_times: FloatArray) -> list[int]:
    """Indices of the scans the NAV reported at its polls: for each poll time (s), the last
    scan received (complete) before it, each scan at most once."""
    if len(received) == 0 or len(poll_times) == 0:
        return list(range(len(received)))
    k = np.searchsorted(received, np.sort(np.asarray(poll_times)), side="right") - 1
    k = k[k >= 0]
    # sorted already: keep each index once
    return k[np.concatenate(([True], k[1:] != k[:-1]))].tolist() if len(k) else []


def replay_data(data: LogData, names: Sequence[str] | None = None, *,
                config: Config | None = None, seed: int = 0,
                settings: Mapping[str, object] | None = None,
                initial_pose: tuple[float, float, float] | str | None = None,
                progress: Callable[[int], None] | None = None,
                cloud_period_s: float = 2.0, cloud_size: int = 50,
                threads: int | None = None) -> ReplayResult:
    """Run the estimators ``names`` over ``data`` (see :func:`run_replay`) on ``threads``
    threads (default: one per estimator, at most one per CPU, when the compiled kernels are
    used, else one; see :func:`run_side_by_side`): the same result for any count."""
    cfg = config or default_config()
    data = apply_installation(data, cfg.vehicle)
    chosen = check_names(list(names) if names is not None else list(DEFAULT_ESTIMATORS))
    per_name = split_settings(settings)
    idle = [n for n in per_name if n not in chosen]
    if idle:
        raise InputError(f"setting(s) of estimator '{idle[0]}' given, but '{idle[0]}' is not "
                         f"run (running: {', '.join(chosen)})")
    params = {n: resolve_params(n, cfg.estimators, per_name.get(n)) for n in chosen}
    if not (data.has_scans or data.has_poses):
        raise MissingDataError("the log has no observations: neither reflector scans "
                               "(/nav/reflectors with a reflector map) nor valid NAV poses "
                               "(/nav/pose)")
    if not data.has_motion and any(ESTIMATORS[n].uses_motion for n in chosen):
        raise MissingDataError("the log has no motion data (/mcu/frame or /odom/twist)")
    vehicle = cfg.vehicle
    tracks: dict[MotionSettings, MotionTrack] = {}
    result = ReplayResult({}, {}, {}, {}, {}, data.t0_ns, seed)
    result.gated = apply_pose_gate(data, vehicle, tracks)
    runs: list[_Run] = []
    for name in chosen:
        cls = ESTIMATORS[name]
        p = params[name]
        result.settings[name] = params_dict(p)
        track = None
        if cls.uses_motion:
            ms = motion_params(name, p).motion_settings()
            track = tracks.get(ms)
            if track is None:
                track = tracks[ms] = MotionTrack(data.increments(ms, vehicle), ms.step_form)
        if isinstance(data.scans, LazyScans) and data.has_scans and cls.uses_scans:
            data.scans.decoded()  # once, here: the estimators then share the arrays
        runs.append(_Run(name, cls, p, track))
    construct = threading.Lock()

    def run(job: _Run, report: Callable[[int], None] | None) -> _Done | None:
        started = time.perf_counter()
        obs, _ = _observations(data, job.cls, job.params, job.track, vehicle,
                               start_poses=False)
        if not obs:
            return None
        with construct:  # one at a time: a constructor may import the compiled kernels
            est = job.cls(job.params, vehicle=vehicle, reflectors=data.reflectors,
                          area=cfg.area, rng=estimator_rng(seed, job.name),
                          initial_pose=_start_pose(data, initial_pose, obs[0].t))
        todo: Sequence[PoseObservation | ScanObservation | _Mark] = obs
        if not est.initialized:
            start_only = _start_poses(data, job.cls, job.params)
            if start_only:
                todo = _start(est, obs, start_only, job.track)
        table, clouds = _run_one(est, todo, job.track, data.t0_ns, report, cloud_period_s,
                                 cloud_size)
        events = [(data.t0_ns + seconds_to_ns(t), kind, text) for t, kind, text in est.events]
        return table, clouds, time.perf_counter() - started, events

    def prepare() -> bool:
        """Make the estimators' compiled kernels ready; whether there are any."""
        families = dict.fromkeys(r.cls.kernel_family for r in runs if r.cls.kernel_family)
        return any([ready(f) for f in families])  # every family made ready, not the first only

    prepared = threads is None and len(runs) > 1
    if prepared and not prepare():
        # side by side only where the compiled kernels release the interpreter: the numpy
        # path's short array operations hold it, and two threads of them are slower than one
        threads = 1
    costs = [_cost(data, r.cls, r.params) for r in runs]
    done_all = run_side_by_side(runs, run, costs, threads, progress,
                                None if prepared else prepare)
    for job, done in zip(runs, done_all, strict=True):
        if done is None:
            result.skipped[job.name] = f"{job.name} has no usable observations in this log"
            continue
        result.estimates[job.name], clouds, result.timings[job.name], events = done
        if clouds:
            result.clouds[job.name] = clouds
        if events:
            result.events[job.name] = events
    return result


_Clouds = list[tuple[int, FloatArray, FloatArray, FloatArray]]
#: what one estimator's run gives: its estimates, particle clouds, seconds and events
_Done = tuple[Trajectory, _Clouds, float, list[tuple[int, str, str]]]


@dataclass
class _Run:
    """One estimator to run: its class, parameters and odometry track (None: no motion)."""

    name: str
    cls: type[Estimator[object]]
    params: object
    track: MotionTrack | None


def _cost(data: LogData, cls: type[Estimator[object]], params: object) -> float:
    """Rough work of running ``cls``: the observations it may use times its particles."""
    n = 0
    if cls.uses_scans and data.has_scans:
        n += len(data.scans)
    if cls.uses_poses and data.has_poses and data.nav is not None:
        n += len(data.nav["t"])
    return float(n) * max(1, int(getattr(params, "particles", 1)))


def _start_pose(data: LogData, initial_pose: tuple[float, float, float] | str | None,
                t: float) -> tuple[float, float, float] | None:
    """The start pose ``initial_pose`` asks for at the first observation time ``t`` (s)."""
    if initial_pose == "truth":
        pose = truth_pose_at(data, t)
        if pose is None:
            raise MissingDataError("initial pose 'truth' asked for, but the log has no "
                                   "/truth/pose")
        return pose
    if isinstance(initial_pose, str):
        raise InputError(f"initial pose must be (x, y, heading) or 'truth', "
                         f"got {initial_pose!r}")
    if initial_pose is not None:
        return (float(initial_pose[0]), float(initial_pose[1]), float(initial_pose[2]))
    return None


class _Stopped(Exception):
    """Raised in a run still going once another has failed (its next progress report)."""


def run_side_by_side(jobs: Sequence[_J], run: Callable[[_J, Callable[[int], None] | None], _T],
                     costs: Sequence[float], threads: int | None = None,
                     progress: Callable[[int], None] | None = None,
                     prepare: Callable[[], object] | None = None) -> list[_T]:
    """``[run(job, progress) for job in jobs]``, on ``threads`` threads (default: one per job,
    at most one per CPU), the costliest jobs started first; ``prepare`` is called before the
    threads start (e.g. to import what every job would import).

    The filters' compiled kernels release the interpreter, so one filter's kernel runs while
    another thread does its Python work. In threads, ``run`` is handed a ``report`` that passes
    counts on to ``progress`` one call at a time; once a job has failed the others stop at
    their next report, and the first failure in job order is raised (after every thread has
    ended). The jobs must not share mutable state.
    """
    import os
    from concurrent.futures import FIRST_EXCEPTION, ThreadPoolExecutor, wait

    n = min(len(jobs), os.cpu_count() or 1) if threads is None else min(int(threads), len(jobs))
    if n <= 1:
        return [run(job, progress) for job in jobs]
    if prepare is not None:
        prepare()
    stop = threading.Event()
    lock = threading.Lock()

    def report(k: int) -> None:
        if stop.is_set():
            raise _Stopped
        if progress is not None:
            with lock:
                progress(k)

    def guarded(job: _J) -> _T:
        try:
            return run(job, report)
        except BaseException:
            stop.set()
            raise

    with ThreadPoolExecutor(n, thread_name_prefix="estimator") as pool:
        futures = {k: pool.submit(guarded, jobs[k])
                   for k in sorted(range(len(jobs)), key=lambda k: -costs[k])}
        try:
            wait(futures.values(), return_when=FIRST_EXCEPTION)
        except BaseException:  # interrupted while waiting: the runs stop at their next report
            stop.set()
            raise
    failures = [futures[k].exception() for k in range(len(jobs))]
    first = next((e for e in failures if e is not None and not isinstance(e, _Stopped)),
                 next((e for e in failures if e is not None), None))
    if first is not None:
        raise first
    return [futures[k].result() for k in range(len(jobs))]


def apply_pose_gate(data: LogData, vehicle: Vehicle,
                    tracks: dict[MotionSettings, MotionTrack] | None = None
                    ) -> list[tuple[int, str]]:
    """Judge the log's valid NAV poses with the plausibility gate
    (:func:`lgvtool.localize.gate.gate_poses`, on the default motion settings' odometry) and
    keep the verdict in ``data.nav["gate"]``; returns ``(log time ns, text)`` per rejected
    pose, for /diagnostics."""
    from lgvtool.localize.gate import gate_poses

    nav = data.nav
    if nav is None or not data.has_poses:
        return []
    odometry = None
    if data.has_motion:
        ms = MotionSettings()
        if tracks is not None and ms in tracks:
            track = tracks[ms]
        else:
            track = MotionTrack(data.increments(ms, vehicle), ms.step_form)
            if tracks is not None:
                tracks[ms] = track
        odometry = track.poses_at(nav["t"])
    verdict = gate_poses(nav["t"], nav["x"], nav["y"], nav["heading"], nav["valid"], odometry,
                         vehicle.nav_x, vehicle.nav_y)
    nav["gate"] = verdict.accepted | ~nav["valid"]
    t_ns = data.t0_ns + seconds_to_ns_array(nav["t"])
    return [(int(t_ns[k]), f"NAV pose ({nav['x'][k]:.3f}, {nav['y'][k]:.3f}) m left out: "
             f"{dpos:.3f} m and {math.degrees(dh):.2f} deg from the odometry's prediction "
             f"(allowed {tol_p:.3f} m, {math.degrees(tol_h):.2f} deg)")
            for k, dpos, dh, tol_p, tol_h in verdict.rejected]


def _start(est: Estimator[object], obs: Sequence[PoseObservation | ScanObservation],
           start_only: list[PoseObservation], track: MotionTrack | None
           ) -> Sequence[PoseObservation | ScanObservation | _Mark]:
    """Feed observations and start-only NAV poses in time order until the estimator has a
    pose; return the observations still to process, beginning with a zero-motion marker at the
    start time so that the motion from there on is not lost."""
    # the observations and start-only poses merged by time, stably (observations first)
    n_obs = len(obs)
    keys = np.concatenate([times_of(obs), times_of(start_only)])
    prev: float | None = None
    used = 0  # observations fed so far
    for j in np.argsort(keys, kind="stable").tolist():
        t = float(keys[j])
        if prev is not None and track is not None and est.uses_motion:
            d = track.deltas(np.array([prev]), np.array([t]))
            est.predict(Motion(float(d.dx[0]), float(d.dy[0]), float(d.dth[0]),
                               float(d.dist[0]), float(d.rot[0])))
        prev = t
        if j < n_obs:
            o: PoseObservation | ScanObservation = obs[j]
            used += 1
        else:
            o = start_only[j - n_obs]
        est.update(o)
        if est.initialized:
            return Tail(_Mark(t), t, obs, used)
    return []


class _Mark:
    """A time at which the driver only moves the estimator (no observation)."""

    __slots__ = ("t",)

    def __init__(self, t: float) -> None:
        self.t = t


def _run_one(est: Estimator[object], obs: Sequence[PoseObservation | ScanObservation | _Mark],
             track: MotionTrack | None, t0_ns: int, progress: Callable[[int], None] | None,
             cloud_period_s: float, cloud_size: int
             ) -> tuple[Trajectory, list[tuple[int, FloatArray, FloatArray, FloatArray]]]:
    times = times_of(obs)
    steps = _deltas(track, times) if track is not None and len(obs) > 1 else None
    if isinstance(obs, Tail):
        todo: Sequence[PoseObservation | ScanObservation | None] = obs.with_first(None)
    elif isinstance(obs, ObservationStream):
        todo = obs
    else:
        todo = [None if isinstance(o, _Mark) else o for o in obs]
    rows = est.run(times, todo, steps,
                   progress=progress, cloud_period_s=cloud_period_s, cloud_size=cloud_size)
    table = replace(rows.poses, t0_ns=t0_ns).wrapped()
    clouds = [(t0_ns + seconds_to_ns(t), x, y, h) for t, x, y, h in rows.clouds]
    return table, clouds


#: motions between observation times computed at a time (bounds the temporary arrays)
_DELTA_BLOCK = 16384


def _deltas(track: MotionTrack, times: FloatArray) -> Deltas:
    """``track.deltas(times[:-1], times[1:])``, computed a block at a time (the same values:
    each motion depends on its own two times only)."""
    n = len(times) - 1  # motions
    parts = [track.deltas(times[a:min(a + _DELTA_BLOCK, n)],
                          times[a + 1:min(a + _DELTA_BLOCK, n) + 1])
             for a in range(0, n, _DELTA_BLOCK)]
    if len(parts) == 1:
        return parts[0]
    return Deltas(*(np.concatenate([getattr(p, f) for p in parts])
                    for f in ("dx", "dy", "dth", "dist", "rot")))


def run_replay(reader: LogReader, names: Sequence[str] | None = None, *,
               config: Config | None = None, seed: int = 0,
               settings: Mapping[str, object] | None = None,
               initial_pose: tuple[float, float, float] | str | None = None,
               progress: Callable[[int], None] | None = None,
               cloud_period_s: float = 2.0, cloud_size: int = 50,
               tap: Tap | None = None, threads: int | None = None) -> ReplayResult:
    """Run estimators over a log.

    :param reader: an open :class:`lgvtool.log.LogReader`.
    :param names: estimator names (default :data:`DEFAULT_ESTIMATORS`); estimators that have
        no usable observation in this log are listed in ``result.skipped``.
    :param config: vehicle, area, reflectors and ``[estimators.*]`` settings (default: the
        log's stored configuration).
    :param seed: seed of every random draw; the same seed gives identical results.
    :param settings: ``{"<estimator>.<param>": value}`` overrides (``--set``).
    :param initial_pose: ``(x, y, heading)`` of O (m, rad) or ``"truth"`` (the log's ground
        truth at the first observation) to start every estimator there.
    :param progress: called with the number of observations processed since the last call.
    :param cloud_period_s: keep one particle cloud per this many seconds, s.
    :param cloud_size: at most this many particles per kept cloud (0: none).
    :param tap: handed the log's chunks as they are read
        (:func:`lgvtool.localize.logdata.load_log`), for a caller that takes more from them.
    :param threads: threads the estimators run on at once (default: one per estimator, at
        most one per CPU, when the compiled kernels are used, else one); the results are the
        same for any count.
    :raises MissingDataError: no motion data, or no observation source.
    :raises InputError: an unknown estimator or parameter.
    """
    started = time.perf_counter()
    cfg = config if config is not None else reader.config()
    chosen = list(names) if names is not None else list(DEFAULT_ESTIMATORS)
    data = load_log(reader, cfg.reflectors or None, truth=initial_pose == "truth", tap=tap,
                    decode_scans=any(getattr(ESTIMATORS.get(n), "uses_scans", False)
                                     for n in chosen))
    read_s = time.perf_counter() - started
    result = replay_data(data, names, config=cfg, seed=seed, settings=settings,
                         initial_pose=initial_pose, progress=progress,
                         cloud_period_s=cloud_period_s, cloud_size=cloud_size, threads=threads)
    result.timings["read"] = read_s
    return result
