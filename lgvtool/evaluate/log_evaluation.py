"""Evaluating one log into an :class:`~lgvtool.evaluate.evaluation.EvaluationResult`
(:func:`evaluate_log`): what the fleet engine's sweep tasks and calibration's comparison run,
and the core of the evaluate job's :func:`lgvtool.app.evaluate_job.evaluate_log` (which adds
other tools' trajectories; ``lgvtool evaluate`` runs it).

A log's ``/estimate/<name>/pose`` channels are scored if it has any, else the estimators are
run over it (:mod:`lgvtool.localize`); the figures come from :mod:`lgvtool.evaluate`.
Positions in m, headings in rad, times in s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypedDict

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from lgvtool.config import Config
    from lgvtool.evaluate.evaluation import EvaluationResult
    from lgvtool.evaluate.log_inputs import EvaluationInputs
    from lgvtool.evaluate.quality import DataQuality
    from lgvtool.json_types import JSON, JSONRecord, SettingValue
    from lgvtool.log import LogReader
    from lgvtool.progress import Progress
    from lgvtool.trajectory import Trajectory

class AddTrajectories(Protocol):
    """Adds other tools' trajectories to the log's: ``(trajectories, foreign, truth, *, log)``
    -> the trajectories scored (:func:`lgvtool.interop.foreign_trajectories.add_foreign`)."""

    def __call__(self, trajectories: Mapping[str, Trajectory],
                 foreign: Mapping[str, Trajectory], truth: Trajectory | None = None, *,
                 log: str = "log") -> dict[str, Trajectory]: ...


def _estimates_from_log(
    reader: LogReader, names: Sequence[str] | None, read: EvaluationInputs
) -> dict[str, Trajectory] | None:
    """The log's own estimates of O (t, x, y, heading), read in one pass with what ``read``
    takes (the truth, the steering, the data quality); None when the log holds none."""
    from lgvtool.errors import InputError
    from lgvtool.localize.registry import check_names, in_run_order
    from lgvtool.log import topics
    from lgvtool.trajectory import Trajectory

    present = in_run_order(topics.estimator_names(reader.topic_names()))
    if not present:
        return None
    if names:
        check_names(list(names), also=present)  # a mistyped name: "did you mean ...?"
        missing = [n for n in names if n not in present]
        if missing:
            raise InputError(f"{reader.path}: no estimates of {', '.join(missing)} in the log "
                             f"(it holds {', '.join(present)}); run lgvtool replay first")
        present = list(names)
    tables = reader.dataframes([topics.estimate_pose(n) for n in present], tap=read)
    return {n: Trajectory.from_frame(tables[topics.estimate_pose(n)], name=n) for n in present}


class _ReplayStart(TypedDict, total=False):
    """The keyword arguments of ``run_replay`` that an evaluation gives only when it has
    them: where the estimators start, and the progress callback (count of steps done)."""

    initial_pose: str
    progress: Callable[[int], None]


def _run_estimators(
    reader: LogReader, names: Sequence[str] | None, cfg: Config, seed: int,
    settings: Mapping[str, SettingValue] | None, warnings: list[str],
    start_at_truth: bool = False,
    progress: Progress | None = None, read: EvaluationInputs | None = None,
    threads: int | None = None,
) -> tuple[dict[str, Trajectory], dict[str, JSONRecord]]:
    from lgvtool.localize import DEFAULT_ESTIMATORS, run_replay
    from lgvtool.log import topics

    chosen = list(names) if names else list(DEFAULT_ESTIMATORS)
    start: _ReplayStart = {"initial_pose": "truth"} if start_at_truth else {}
    if progress is not None and progress.enabled:
        # at most every scan and every NAV pose, per estimator
        infos = reader.topics()
        per = sum(infos[t].count for t in (topics.NAV_REFLECTORS, topics.NAV_POSE) if t in infos)
        progress.stage(f"{Path(str(reader.path)).name}: estimators", len(chosen) * per)
        start["progress"] = progress.advance
    out = run_replay(reader, chosen, config=cfg, seed=seed, settings=dict(settings or {}),
                     tap=read, threads=threads, **start)
    for name, reason in (getattr(out, "skipped", None) or {}).items():
        warnings.append(f"estimator '{name}' left out: {reason}")
    return out.trajectories, dict(out.settings)


def evaluate_log(
    path_or_reader: str | Path | LogReader,
    *,
    estimators: Sequence[str] | None = None,
    config: Config | None = None,
    seed: int = 0,
    settings: Mapping[str, SettingValue] | None = None,
    shared_centre: bool = False,
    free_radius: bool = False,
    lap_source: str | None = None,
    start_at_truth: bool = False,
    replay: bool = False,
    trajectories: Mapping[str, Trajectory] | None = None,
    add_trajectories: AddTrajectories | None = None,
    progress: Progress | None = None,
    threads: int | None = 1,
) -> EvaluationResult:
    """Evaluate one log.

    The log's ``/estimate/<name>/pose`` channels are scored if it has any (``estimators``
    picks among them); otherwise the estimators (default: ``DEFAULT_ESTIMATORS`` of
    :mod:`lgvtool.localize`) are run with ``run_replay`` using ``seed`` and ``settings``, and
    with ``start_at_truth`` every estimator starts at the log's ground truth (``/truth/pose``)
    at its first observation instead of initialising itself (a warning when the log's own
    estimates are scored, since nothing is run then).
    ``config`` overrides the configuration stored in the log. The steering angle of the
    reference circle is the median logged steering angle (MCU frames), else
    ``config.reference.steering_angle_deg``, else the reference circle is fitted to the truth;
    a log may name its circle reference (:func:`lgvtool.evaluate.reference.circle_from_log`,
    ``import ros2 --circle-from``). Raises :class:`~lgvtool.errors.InputError` (or a
    subclass) for a log that cannot be evaluated. ``replay=True`` runs the estimators even when
    the log holds estimates of its own (parameter sweeps over logs written by ``replay``).
    ``trajectories`` (name -> poses of O, t in s since the epoch) are scored beside them
    (``--trajectory``), added by ``add_trajectories`` (required with them; the evaluate job
    passes :func:`lgvtool.interop.foreign_trajectories.add_foreign`, a layer above this one).
    ``progress`` (a :class:`lgvtool.progress.Progress`) shows the estimators' progress;
    ``threads``: threads the estimators run on at once (None: one per estimator, at most one
    per CPU; the same results for any count); one by default, as two filters side by side hold
    their working memory at once (docs/performance.md).
    """
    from lgvtool.circle import median_steering
    from lgvtool.evaluate.evaluation import evaluate_trajectories
    from lgvtool.evaluate.log_inputs import EvaluationInputs
    from lgvtool.evaluate.reference import circle_from_log
    from lgvtool.gc_pause import collector_paused
    from lgvtool.log import LogReader, topics

    reader = (path_or_reader if isinstance(path_or_reader, LogReader)
              else LogReader(path_or_reader))
    cfg = config if config is not None else reader.config()
    warnings: list[str] = list(reader.warnings)
    # the truth, the steering and the data quality, taken in the pass that reads the log's
    # estimates or in the estimators' reading
    read = EvaluationInputs(reader)
    trajs = None if replay else _estimates_from_log(reader, estimators, read)
    source = "log"
    used: dict[str, JSONRecord] = {}
    if trajs is None:
        with collector_paused():
            trajs, used = _run_estimators(reader, estimators, cfg, seed, settings, warnings,
                                          start_at_truth, progress, read, threads)
        source = "replay"
    else:
        if start_at_truth:
            warnings.append("--start-at-truth has no effect: the log's own estimates are scored "
                            "(evaluate a log without /estimate/* channels to run the estimators)")
        if settings:
            warnings.append("--set has no effect: the log's own estimates are scored (evaluate a "
                            "log without /estimate/* channels to run the estimators)")
    truth = read.truth()
    if trajectories:
        if add_trajectories is None:
            raise TypeError("evaluate_log: trajectories given without add_trajectories")
        trajs = add_trajectories(trajs, trajectories, truth, log=str(reader.path))
    steering = None
    steering_source = "none"
    drive_speed = None
    if reader.has_topic(topics.MCU_FRAME):
        angles, speeds = read.steering_columns()
        steering = median_steering(angles, speeds)
        steering_source = "log" if steering is not None else "none"
        drive_speed = _median_moving_speed(speeds)
    if steering is None and cfg.reference.steering_angle_deg is not None:
        steering = math.radians(cfg.reference.steering_angle_deg)
        steering_source = "config"
    result = evaluate_trajectories(
        trajs, truth=truth, steering_angle=steering, steering_source=steering_source,
        h=cfg.vehicle.h, shared_centre=shared_centre, free_radius=free_radius,
        name=Path(str(reader.path)).stem, reflectors=reader.reflector_map() or cfg.reflectors,
        lap_source=lap_source, circle_from=circle_from_log(reader.metadata),
    )
    result.path = str(reader.path)
    result.quality = read.quality(result.t0)
    result.source = source
    result.settings = used
    result.drive_speed = drive_speed
    result.observations = _observations_used(
        reader, cfg, list(result.estimators), used, source, set(trajectories or ()),
        start_at_truth and source == "replay", result.quality)
    late = [w for w in reader.warnings if w not in warnings]  # corrupt chunks met in reading
    result.warnings[:0] = warnings + late
    return result


def _median_moving_speed(speeds: ArrayLike) -> float | None:
    """Median |drive-wheel speed| of the MCU frames while moving, m/s (None: never moving)."""
    import numpy as np

    from lgvtool.circle import MOVING_SPEED

    v = np.abs(np.asarray(speeds, dtype=float))
    v = v[np.isfinite(v) & (v > MOVING_SPEED)]
    return float(np.median(v)) if v.size else None


SCAN_KINDS: dict[str, str] = {
    "paper-scans": "NAV200 scans (the paper's setup)",
    "nav350-landmarks": "NAV350 landmarks",
}
"""The simulator's ``observations`` mark (``simulator`` metadata) -> how the verdict, the
tables and the report name a log's reflector observations."""


def scan_kind(metadata: Mapping[str, JSONRecord]) -> str:
    """What a log's reflector observations (``/nav/reflectors``) are, in words: the NAV200's
    scans of the paper's setup (a simulated log made with ``sim.paper_scans``), a NAV350's
    landmarks (a NAV350 recording, simulated or real), else "reflector scans"."""
    sim = metadata.get("simulator")
    mark = sim.get("observations") if isinstance(sim, Mapping) else None
    if isinstance(mark, str) and mark in SCAN_KINDS:
        return SCAN_KINDS[mark]
    if "device.nav350" in metadata:  # a NAV350 recording (lgvtool record)
        return SCAN_KINDS["nav350-landmarks"]
    return "reflector scans"


def _observations_used(
    reader: LogReader, cfg: Config, names: Sequence[str], used: Mapping[str, JSONRecord],
    source: str, foreign: set[str], from_truth: bool, quality: DataQuality | None,
) -> dict[str, str]:
    """What each estimator updated with, from its class, its settings (those evaluate ran it
    with, else those ``replay`` stored in the log's metadata) and what the log holds, as the
    replay driver chooses them (:func:`lgvtool.localize.observations.sources`)."""
    from lgvtool.log import topics

    try:
        from lgvtool.localize.observations import sources
        from lgvtool.localize.registry import ESTIMATORS
    except ImportError:  # estimators stood in for (lgvtool.localize replaced by a module)
        return dict.fromkeys(names, "unknown")
    settings: Mapping[str, JSONRecord | JSON] = used
    if source == "log":
        stored = (reader.metadata.get("replay") or {}).get("settings")
        settings = stored if isinstance(stored, Mapping) else {}
    has_scans = reader.has_topic(topics.NAV_REFLECTORS) and bool(cfg.reflectors)
    scans_are = scan_kind(reader.metadata)
    has_poses = reader.has_topic(topics.NAV_POSE) and (
        quality is None or quality.nav_replies > quality.nav_no_position)
    out: dict[str, str] = {}
    for n in names:
        params = settings.get(n)
        if n in foreign:
            out[n] = "unknown (another tool's trajectory)"
            continue
        if n not in ESTIMATORS or not isinstance(params, Mapping):
            out[n] = "unknown (estimates read from the log)"
            continue
        try:
            cls = ESTIMATORS[n]
        except ImportError:  # as above
            out[n] = "unknown"
            continue
        if not cls.uses_motion and not cls.uses_scans:
            out[n] = "NAV poses (the laser itself)"
            continue
        if not getattr(cls, "corrects", True):
            out[n] = "odometry only, from the truth" if from_truth else "odometry only"
            continue
        scans, poses = sources(str(params.get("observations", "both")),
                               has_scans and cls.uses_scans, has_poses and cls.uses_poses)
        what = []
        if scans:
            what.append(scans_are + (" at NAV polls" if params.get("scans") == "nav-poll"
                                     else ""))
        if poses:
            what.append("NAV poses")
        out[n] = " and ".join(what) if what else "none"
    return out


