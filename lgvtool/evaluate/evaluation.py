"""Evaluate the trajectories of one drive: reference circle, rotations, metrics. Pure: no I/O.

Inputs are trajectories (:class:`lgvtool.trajectory.Trajectory`: t in s, x and y in m, heading
in rad), one per estimator, plus optionally the ground truth, all on one clock.
:func:`evaluate_trajectories` returns an :class:`EvaluationResult`; the command line, the
report and the fleet engine all start there.

Steps (docs/evaluation.md):

1. reference radius ``R = h / tan(delta)``, or a free radius (``free_radius``);
2. a centre per estimator fitted to its own trajectory, or one shared centre fitted to all of
   them with equal weight per estimator (``shared_centre``); a free-radius geometric fit is
   always made too, to show the fitted radius beside the kinematic one;
3. rotations found once on the lap source (the truth if present, else the estimator closest to
   its circle) and applied to all estimators by time; the centres are then fitted again on the
   complete rotations only, the samples that are scored;
4. signed radial errors, per-rotation statistics, the Average row, improvement over ``laser``;
5. where truth exists, position and heading error against the interpolated truth.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from lgvtool.circle import TRIM, Circle, fit_geometric
from lgvtool.errors import InputError
from lgvtool.evaluate.laps import Laps
from lgvtool.evaluate.metrics import (
    RadialStats,
    TruthStats,
    average_stats,
    improvement,
    radial_stats,
    truth_errors,
    truth_stats,
)
from lgvtool.evaluate.quality import DataQuality
from lgvtool.evaluate.reference import (
    MIN_SAMPLES,
    CircleFrom,
    ReferenceInfo,
    circles_and_laps,
    reference_info,
)
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.config import Reflector
    from lgvtool.evaluate.verdict import Verdict
    from lgvtool.json_types import JSONRecord

__all__ = ["BASELINE", "EstimatorEvaluation", "EvaluationResult", "ReferenceInfo", "Rotation",
           "evaluate_trajectories"]

BASELINE = "laser"
"""The estimator that improvements are measured against."""

OFF_CENTRE = 0.5
"""An estimator whose circle centre is further than this fraction of the radius from the
reference centre gets a warning."""


@dataclass(frozen=True)
class Rotation:
    """One complete rotation of one estimator: its time span (s), radial statistics and, with
    ground truth, the RMSE of the true position error in that rotation (m)."""

    number: int
    start: float
    end: float
    stats: RadialStats
    truth_rmse: float | None = None


@dataclass(frozen=True)
class EstimatorEvaluation:
    """Everything computed for one estimator on one drive."""

    name: str
    trajectory: Trajectory
    """The poses scored (cleaned: sorted, finite, one per time): t (s), x, y (m), heading
    (rad)."""
    circle: Circle | None = None
    """The circle the estimator is scored against (None: no circle metrics)."""
    fitted: Circle | None = None
    """Free-radius geometric fit to the scored samples, for comparison with the kinematic R."""
    radial: pd.DataFrame | None = None
    """Columns t (s), error (m, signed radial), rotation (1-based, 0 outside a rotation)."""
    rotations: tuple[Rotation, ...] = ()
    average: RadialStats | None = None
    """Table 1's Average row: mean over rotations (max_abs: the largest of any rotation)."""
    pooled: RadialStats | None = None
    """Statistics over all samples of the complete rotations together."""
    improvement: float | None = None
    """Average RMSE improvement over ``laser``, %."""
    centre_offset: float | None = None
    """Distance of this estimator's circle centre from the reference centre (the truth's, else
    the lap source's), m. The radial error cannot show an estimator that circles in the wrong
    place; this does."""
    truth_error: pd.DataFrame | None = None
    """Columns t (s), position_error (m), heading_error (rad)."""
    truth: TruthStats | None = None


@dataclass
class EvaluationResult:
    """The evaluation of one drive (one log)."""

    name: str
    estimators: dict[str, EstimatorEvaluation]
    reference: ReferenceInfo
    laps: Laps
    truth: Trajectory | None = None
    """The ground truth (cleaned), on the estimators' clock."""
    truth_path: RadialStats | None = None
    """Radial statistics of the true path about the lap source's circle, over the complete
    rotations: how far the real drive is from the ideal circle."""
    truth_circle: Circle | None = None
    reference_circle: Circle | None = None
    """The circle of the truth if given, else of the lap source (drawn in the plots)."""
    reflectors: tuple[Reflector, ...] = ()
    """Reflector map (objects with id, x, y in m) for the plots."""
    warnings: list[str] = field(default_factory=list)
    path: str | None = None
    source: str = "log"
    """'log': estimates read from the log; 'replay': estimators run by evaluate."""
    settings: dict[str, JSONRecord] = field(default_factory=dict)
    """Each estimator run's settings as it ran (name -> {setting: value})."""
    t0: float = 0.0
    """Start of the drive, s (plots show time since t0)."""
    quality: DataQuality | None = None
    """The log's data quality when it was gathered while the log was read (else the report
    reads it: :func:`lgvtool.evaluate.quality.quality_of_log`)."""
    observations: dict[str, str] = field(default_factory=dict)
    """Estimator name -> what it updated with ("reflector scans", "NAV poses", "odometry
    only", ...), as :func:`lgvtool.evaluate.log_evaluation.evaluate_log` finds it (empty: unknown)."""
    drive_speed: float | None = None
    """Median drive-wheel speed of the MCU frames while moving, m/s (None: no MCU frames);
    tells the paper's experiment (:func:`lgvtool.evaluate.verdict.is_paper_experiment`)."""
    verdict: Verdict | None = None
    """The verdict on this log with the paths written (:mod:`lgvtool.evaluate.verdict`), set
    by :func:`lgvtool.app.evaluate_job.evaluate_logs`; None until then."""

    @property
    def has_truth(self) -> bool:
        """True when the drive has ground truth."""
        return self.truth is not None and len(self.truth) > 0


def evaluate_trajectories(
    trajectories: Mapping[str, Trajectory | pd.DataFrame],
    *,
    truth: Trajectory | pd.DataFrame | None = None,
    steering_angle: float | None,
    steering_source: str = "config",
    h: float,
    shared_centre: bool = False,
    free_radius: bool = False,
    name: str = "",
    reflectors: Sequence[Reflector] = (),
    lap_source: str | None = None,
    circle_from: CircleFrom | None = None,
) -> EvaluationResult:
    """Evaluate the ``trajectories`` (name -> poses of O: t in s, x, y in m, heading in rad)
    of one drive against the reference circle and, if given, the ``truth``. Each is cleaned
    first (:meth:`~lgvtool.trajectory.Trajectory.clean`: sorted, finite, one pose per time);
    trajectories counted from different origins are all put on the epoch's clock. A DataFrame
    (columns t s since the epoch, x, y m, heading rad) is taken as its trajectory
    (:meth:`~lgvtool.trajectory.Trajectory.of`).

    ``steering_angle`` (rad) and ``h`` (m) give the kinematic radius; ``None`` means no
    reference circle (ground-truth metrics only). ``lap_source`` names the trajectory whose
    angle about the centre defines the rotations (default: the truth if given, else the
    estimator with the smallest radial RMSE). ``circle_from``: the circle reference the log
    names (:func:`lgvtool.evaluate.reference.circle_from_log`); without one and without a
    steering angle the circle is fitted to the truth. Raises
    :class:`~lgvtool.errors.InputError` when there is no usable trajectory, or neither a
    reference circle nor ground truth.
    """
    warnings: list[str] = []
    given = {n: Trajectory.of(v, n) for n, v in trajectories.items()}
    true_given = None if truth is None else Trajectory.of(truth, "truth")
    origins = {tr.t0_ns for tr in (*given.values(), *([] if true_given is None else [true_given]))}
    epoch = len(origins) > 1  # put them all on one clock, the epoch's

    def cleaned(tr: Trajectory) -> Trajectory:
        return (tr.on_epoch() if epoch else tr).clean()

    trajs: dict[str, Trajectory] = {}
    for est, tr in given.items():
        clean = cleaned(tr)
        if len(clean) < MIN_SAMPLES:
            warnings.append(f"estimator '{est}' has {len(clean)} usable pose(s): left out")
            continue
        trajs[est] = clean
    if not trajs:
        raise InputError(f"{name or 'log'}: no usable trajectory (no estimator produced poses)")
    true_df = cleaned(true_given) if true_given is not None else None
    if true_df is not None and len(true_df) < 2:
        warnings.append("the ground truth has fewer than 2 poses: left out")
        true_df = None
    t0 = min(float(tr.t[0]) for tr in trajs.values())

    info, warn = reference_info(steering_angle, steering_source, h, free_radius, shared_centre,
                            has_truth=true_df is not None, name=name,
                            circle_from=circle_from)
    warnings.extend(warn)
    radius = None if free_radius else info.kinematic_radius

    circles: dict[str, Circle] = {}
    laps = Laps()
    truth_circle: Circle | None = None
    ref_circle: Circle | None = None
    if info.circle_drive:
        circles, laps, truth_circle, ref_circle, warnings_c = circles_and_laps(
            trajs, true_df, radius, shared_centre, lap_source, info)
        warnings.extend(warnings_c)
        if not circles:
            info = replace(info, circle_drive=False)

    free = radius is None and not info.fixed_circle
    evaluations = {n: _evaluate_one(n, df, circles.get(n), laps, true_df, free)
                   for n, df in trajs.items()}
    if ref_circle is not None:
        warnings.extend(_centre_offsets(evaluations, ref_circle, laps.source,
                                        has_truth=true_df is not None, shared=shared_centre,
                                        own_fit=info.fixed_circle))
    base = evaluations.get(BASELINE)
    if base is not None and base.average is not None:
        for n, ev in evaluations.items():
            if ev.average is not None:
                evaluations[n] = replace(ev, improvement=improvement(ev.average.rmse,
                                                                     base.average.rmse))
    truth_path = None
    if true_df is not None and truth_circle is not None and laps.complete:
        inside = laps.index(true_df.t) > 0
        truth_path = radial_stats(truth_circle.radial_error(true_df.x[inside],
                                                            true_df.y[inside]))
    return EvaluationResult(
        name=name, estimators=evaluations, reference=info, laps=laps, truth=true_df,
        truth_path=truth_path, truth_circle=truth_circle, reference_circle=ref_circle,
        reflectors=tuple(reflectors),
        warnings=warnings, t0=t0,
    )


def _centre_offsets(
    evaluations: dict[str, EstimatorEvaluation], ref: Circle, source: str, *,
    has_truth: bool, shared: bool, own_fit: bool = False,
) -> list[str]:
    """Set each estimator's centre offset from ``ref`` (m); warnings for the far ones.
    ``own_fit``: measure it from the estimator's own free-radius fit (its circle is ``ref``)."""
    warnings: list[str] = []
    far = max(OFF_CENTRE * ref.r, 0.05)
    for n, ev in evaluations.items():
        own = ev.fitted if own_fit else ev.circle
        if ev.circle is None or own is None:
            continue
        off = math.hypot(own.cx - ref.cx, own.cy - ref.cy)
        evaluations[n] = replace(ev, centre_offset=off)
        if off > far and not shared and not own_fit:  # own_fit: the figures show it
            whose = "the true one" if has_truth else f"that of '{source}'"
            see = "the ground-truth figures" if has_truth else "--shared-centre"
            warnings.append(f"estimator '{n}' circles about a centre {off:.2f} m away from "
                            f"{whose}: its circle figures do not show that offset (see {see})")
    return warnings


def _by_group(keys: NDArray[np.int64], values: ArrayLike, n: int) -> list[NDArray[np.float64]]:
    """``values[keys == k]`` for every ``k`` in ``0..n`` (each in its original order), in
    time linear in the samples (plus a sort)."""
    v = np.asarray(values, dtype=np.float64)
    order = np.argsort(keys, kind="stable")
    sk = keys[order]
    sv = v[order]
    ks = np.arange(n + 1)
    lo = np.searchsorted(sk, ks, side="left").tolist()
    hi = np.searchsorted(sk, ks, side="right").tolist()
    return [sv[a:b] for a, b in zip(lo, hi, strict=True)]


def _evaluate_one(
    name: str,
    df: Trajectory,
    circle: Circle | None,
    laps: Laps,
    true_df: Trajectory | None,
    free: bool,
) -> EstimatorEvaluation:
    terr = tstats = None
    if true_df is not None:
        terr = truth_errors(df, true_df)
        tstats = truth_stats(terr["position_error"], terr["heading_error"])
        if tstats.samples == 0:
            terr = tstats = None
    if circle is None:
        return EstimatorEvaluation(name, df, truth_error=terr, truth=tstats)
    t = df.t
    err = circle.radial_error(df.x, df.y)
    rot = laps.index(t)
    radial = pd.DataFrame({"t": t, "error": err, "rotation": rot})
    scored = rot > 0
    fitted = None
    if scored.sum() >= MIN_SAMPLES:
        fitted = circle if free else fit_geometric(df.x[scored], df.y[scored], trim=TRIM,
                                                   start=circle)
    rows = []
    # each rotation's samples in their order, found by one sort (not one pass per rotation)
    by_rot = _by_group(rot, err, laps.complete)
    by_truth = (_by_group(laps.index(terr["t"]), terr["position_error"].to_numpy(),
                          laps.complete) if terr is not None else None)
    for k in range(1, laps.complete + 1):
        sel = by_rot[k]
        if not sel.size:
            continue
        trmse = None
        if by_truth is not None:
            pe = by_truth[k]
            trmse = float(np.sqrt(np.mean(pe * pe))) if pe.size else None
        rows.append(Rotation(k, laps.boundaries[k - 1], laps.boundaries[k],
                             radial_stats(sel), trmse))
    average = average_stats([r.stats for r in rows]) if rows else None
    pooled = radial_stats(err[scored]) if rows else None
    return EstimatorEvaluation(
        name, df, circle=circle, fitted=fitted, radial=radial, rotations=tuple(rows),
        average=average, pooled=pooled, truth_error=terr, truth=tstats,
    )
