"""The reference circle of a drive and its rotations: radius, centres, lap source. Pure.

See :mod:`lgvtool.evaluate.evaluation` for the steps; this module fits the circles and finds
the rotations that the metrics are computed over.

Where the circle comes from (:attr:`ReferenceInfo.circle_source`):

- ``kinematic``: the radius ``R = h / tan(delta)`` of the logged (else configured) steering
  angle, the centre fitted to each estimator (or shared): the paper's reference;
- ``truth``: without a steering angle, the circle (centre and radius) fitted to the ground
  truth, and every estimator is scored against that one circle;
- ``estimator``: the circle fitted to a named estimator's trajectory, which is then left out
  of the circle figures (never scored against a circle fitted to itself); the others are
  scored against it;
- ``topic``: a circle fitted at import to a named pose topic of a ROS 2 bag, stored in the log
  (:func:`circle_from_log`); every estimator is scored against it;
- ``none``: no reference circle (ground-truth metrics only), always said in a warning.

A log names its reference in the importer's metadata record (``circle_reference``, written by
``lgvtool import ros2 --circle-from``); otherwise the order is: steering angle, ground truth,
nothing.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from lgvtool.circle import (
    TRIM,
    Circle,
    fit_circle,
    follows_circle,
    kinematic_radius,
    median_steering,
)
from lgvtool.errors import InputError
from lgvtool.evaluate.laps import Laps, segment_laps
from lgvtool.evaluate.metrics import radial_stats
from lgvtool.json_types import JSONRecord, as_float

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.trajectory import Trajectory

MIN_SAMPLES = 3
"""Fewest samples that make a trajectory usable."""

REFERENCE_SPREAD = 0.1
"""A trajectory a reference circle is fitted to (truth, named estimator or topic) must lie
within this fraction of the fitted radius (radial RMSE, and at least
:data:`REFERENCE_SPREAD_FLOOR`), and sweep a full turn about its centre: a free-radius fit
bends to any path, so the test is stricter than :func:`lgvtool.circle.follows_circle`."""
REFERENCE_SPREAD_FLOOR = 0.02
"""Smallest radial RMSE a reference trajectory may always have, m."""

CIRCLE_SOURCES = ("kinematic", "truth", "estimator", "topic", "none")
"""Where a reference circle can come from (:attr:`ReferenceInfo.circle_source`)."""
FITTED_SOURCES = ("truth", "estimator", "topic")
"""The sources whose circle (centre and radius) is fitted to a reference and scores every
estimator as it is."""


@dataclass(frozen=True)
class ReferenceInfo:
    """How the reference circle was built."""

    steering_angle: float | None
    """Steering angle delta used, rad (None: no kinematic reference)."""
    steering_source: str
    """'log' (median of the logged steering angle), 'config', or 'none'."""
    h: float
    """Distance from O to the drive wheel, m."""
    kinematic_radius: float | None
    """R = h / tan(delta), m."""
    free_radius: bool
    shared_centre: bool
    circle_drive: bool
    """False when the drive is not a circle (or has no reference): no circle metrics."""
    circle_source: str = "kinematic"
    """One of :data:`CIRCLE_SOURCES`: what the reference circle comes from."""
    circle_reference: str | None = None
    """What the circle is fitted to: 'truth', the estimator's name or the bag topic (None for
    the kinematic circle and for none)."""
    given_circle: Circle | None = None
    """The circle stored in the log (``topic``), m."""

    @property
    def fixed_circle(self) -> bool:
        """True when every estimator is scored against the one reference circle (fitted to a
        reference), not against a circle whose centre is fitted to the estimator itself."""
        return self.circle_source in FITTED_SOURCES


@dataclass(frozen=True)
class CircleFrom:
    """What a log names as the reference of its circle (the importer's ``--circle-from``)."""

    kind: str
    """'auto' (steering angle, else truth), 'truth', 'estimator', 'topic' or 'none'."""
    name: str = ""
    """The estimator, or the topic the stored circle was fitted to."""
    circle: Circle | None = None
    """The stored circle (``topic``)."""
    how: str = ""
    """How the log came to name it, for the messages (e.g. 'import ros2 --circle-from')."""


def circle_from_log(metadata: Mapping[str, JSONRecord]) -> CircleFrom | None:
    """The reference a log names (the ``circle_reference`` entry of its ``importer`` metadata
    record), or None (the default order) when it names none or leaves the choice to the
    evaluation (``option`` 'auto').

    :raises InputError: an entry that names an unknown source or a circle without numbers.
    """
    record = (metadata.get("importer") or {}).get("circle_reference")
    if not isinstance(record, Mapping) or record.get("option", "auto") == "auto":
        return None
    kind = str(record.get("source", ""))
    how = f"import {metadata.get('importer', {}).get('importer', '')} --circle-from".replace(
        "  ", " ")
    if kind == "topic":
        try:
            circle = Circle(as_float(record["centre_x_m"]), as_float(record["centre_y_m"]),
                            as_float(record["radius_m"]))
        except (KeyError, TypeError, ValueError):
            raise InputError("the log's circle_reference names a topic's circle without its "
                             "centre_x_m, centre_y_m and radius_m") from None
        if not (math.isfinite(circle.cx) and math.isfinite(circle.cy) and circle.r > 0):
            raise InputError("the log's circle_reference holds a circle that is not finite")
        return CircleFrom("topic", str(record.get("name", "")), circle, how)
    if kind in ("truth", "estimator", "none"):
        return CircleFrom(kind, str(record.get("name", "")), None, how)
    raise InputError(f"the log's circle_reference names an unknown source '{kind}' "
                     f"(one of truth, estimator, topic, none)")


@dataclass(frozen=True)
class ReferenceFit:
    """A circle fitted to a reference trajectory (:func:`fit_reference_circle`)."""

    circle: Circle | None
    """Fitted to the complete rotations (None: the trajectory is no circle drive)."""
    laps: Laps
    spread: float
    """Radial RMSE of the trajectory about its first fit, m (nan if no fit)."""
    problem: str | None = None
    """Why there is no circle, a sentence fragment (None: there is one)."""


def fit_reference_circle(t: np.ndarray, x: np.ndarray, y: np.ndarray, name: str
                         ) -> ReferenceFit:
    """The circle (centre and radius) of the trajectory ``name`` (t s, x and y m) when it
    drives one: within :data:`REFERENCE_SPREAD` of the radius and one full turn at least about
    the centre; fitted to all samples (robust trim), the turns found about that circle, and
    fitted again to the complete turns."""
    t, x, y = (np.asarray(a, dtype=float) for a in (t, x, y))
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(y)
    t, x, y = t[ok], x[ok], y[ok]
    if t.size < MIN_SAMPLES:
        return ReferenceFit(None, Laps(source=name), math.nan,
                            f"'{name}' has {t.size} usable pose(s)")
    try:
        first = fit_circle(x, y, None, trim=TRIM)
    except InputError as exc:
        return ReferenceFit(None, Laps(source=name), math.nan, f"'{name}' fits no circle ({exc})")
    spread = radial_stats(first.radial_error(x, y)).rmse
    if not spread <= max(REFERENCE_SPREAD * first.r, REFERENCE_SPREAD_FLOOR):
        return ReferenceFit(None, Laps(source=name), spread,
                            f"'{name}' does not drive a circle (radial RMSE {spread * 1e3:.0f} "
                            f"mm about its fitted {first.r:.3f} m circle)")
    laps = segment_laps(t, x, y, first, source=name)
    if laps.complete == 0:
        return ReferenceFit(None, laps, spread,
                            f"'{name}' does not drive a full circle "
                            f"({np.degrees(laps.swept):.0f} deg about its fitted centre)")
    m = laps.index(t) > 0
    circle = fit_circle(x[m], y[m], None, trim=TRIM, start=first)
    return ReferenceFit(circle, laps, spread)


def describe_circle(c: Circle) -> str:
    """``radius 0.6930 m, centre (1.234, 5.678) m``."""
    return f"radius {c.r:.4f} m, centre ({c.cx:.3f}, {c.cy:.3f}) m"


def steering_from_frames(frames: pd.DataFrame | None) -> float | None:
    """:func:`median_steering` of MCU frames (columns steering_angle in rad and, if present,
    drive_speed in m/s)."""
    if frames is None or frames.empty or "steering_angle" not in frames.columns:
        return None
    speed = (frames["drive_speed"].to_numpy(dtype=float) if "drive_speed" in frames.columns
             else None)
    return median_steering(frames["steering_angle"].to_numpy(dtype=float), speed)


def fit_circles(
    trajs: Mapping[str, Trajectory],
    masks: Mapping[str, np.ndarray] | None,
    radius: float | None,
    shared: bool,
    start: Mapping[str, Circle] | None = None,
) -> dict[str, Circle]:
    """The circle of each trajectory (x, y in m), of the given ``radius`` (m; None: free),
    fitted to the samples selected by ``masks`` (all if None or too few), each from its own
    ``start`` circle if given. ``shared``: one circle fitted to all, each trajectory weighted
    equally whatever its length."""
    def pts(name: str) -> tuple[np.ndarray, np.ndarray]:
        df = trajs[name]
        m = np.ones(len(df), bool) if masks is None else masks[name]
        if m.sum() < MIN_SAMPLES:
            m = np.ones(len(df), bool)
        return df.x[m], df.y[m]

    def first(name: str) -> Circle | None:
        return None if start is None else start.get(name)

    if not shared:
        return {n: fit_circle(*pts(n), radius, trim=TRIM, start=first(n)) for n in trajs}
    xs, ys, ws = [], [], []
    for n in trajs:
        x, y = pts(n)
        xs.append(x)
        ys.append(y)
        ws.append(np.full(x.size, 1.0 / x.size))
    c = fit_circle(np.concatenate(xs), np.concatenate(ys), radius,
                   weights=np.concatenate(ws), trim=TRIM, start=first(next(iter(trajs))))
    return dict.fromkeys(trajs, c)


def choose_lap_source(
    trajs: Mapping[str, Trajectory], circles: Mapping[str, Circle], prefer: str | None
) -> str:
    """``prefer`` if it is among ``trajs``, else the trajectory with the smallest radial RMSE
    about its circle (ties broken by name)."""
    if prefer is not None and prefer in trajs:
        return prefer
    scores = {
        n: radial_stats(circles[n].radial_error(df.x, df.y)).rmse for n, df in trajs.items()
    }
    return min(scores, key=lambda n: (scores[n], n))


def reference_info(
    steering_angle: float | None, steering_source: str, h: float, free_radius: bool,
    shared_centre: bool, *, has_truth: bool, name: str, circle_from: CircleFrom | None = None,
) -> tuple[ReferenceInfo, list[str]]:
    """How the reference circle is built, and warnings (every circle that is not the
    kinematic one is said in a warning); InputError with nothing to compare.

    ``circle_from``: the reference the log names (:func:`circle_from_log`); None or 'auto':
    the steering angle, else the ground truth, else nothing."""
    warnings: list[str] = []
    who = name or "log"
    cf = circle_from if circle_from is not None else CircleFrom("auto")
    source = steering_source if steering_angle is not None else "none"

    def info(circle_source: str, reference: str | None = None, kin: float | None = None,
             circle: Circle | None = None) -> ReferenceInfo:
        fitted = circle_source in FITTED_SOURCES
        if fitted and (free_radius or shared_centre):
            flags = " and ".join(f for f, on in (("--free-radius", free_radius),
                                                 ("--shared-centre", shared_centre)) if on)
            warnings.append(f"{flags}: no effect, every estimator is scored against the one "
                            f"reference circle")
        return ReferenceInfo(steering_angle, source, h, kin, free_radius, shared_centre,
                             circle_drive=kin is not None or fitted, circle_source=circle_source,
                             circle_reference=reference, given_circle=circle)

    def nothing(why: str) -> InputError:
        return InputError(f"{who}: {why}, and no ground truth: nothing to compare with")

    named = f" (named by {cf.how})" if cf.how else ""
    unused = (f"; the steering angle {math.degrees(steering_angle):.1f} deg ({steering_source}) "
              f"is not used" if steering_angle is not None else "")
    if cf.kind == "auto":
        if steering_angle is None:
            if not has_truth:
                raise nothing("no steering angle in the log (/mcu/frame) and none configured "
                              "(reference.steering_angle_deg), no circle reference named "
                              "(import ros2 --circle-from)")
            warnings.append("no steering angle in the log and none configured: the reference "
                            "circle is the circle fitted to the ground truth (centre and "
                            "radius), and every estimator is scored against it")
            return info("truth", "truth"), warnings
        kin: float | None = kinematic_radius(h, steering_angle)
        if kin is None or not math.isfinite(kin):
            kin = None
            warnings.append("the steering angle is zero (a straight drive): no reference circle")
            return info("none", kin=kin), warnings
        return info("kinematic", kin=kin), warnings
    if cf.kind == "none":
        if not has_truth:
            raise nothing(f"no circle reference{named}")
        warnings.append(f"no circle reference{named}: ground-truth metrics only")
        return info("none"), warnings
    if cf.kind == "truth":
        if not has_truth:
            raise nothing(f"the circle reference is the ground truth{named}")
        warnings.append(f"the reference circle is the circle fitted to the ground truth{named}"
                        f"{unused}; every estimator is scored against it")
        return info("truth", "truth"), warnings
    if cf.kind == "estimator":
        warnings.append(f"the reference circle is the circle fitted to estimator '{cf.name}'"
                        f"{named}{unused}; the other estimators are scored against it, "
                        f"'{cf.name}' itself has no circle figures")
        return info("estimator", cf.name), warnings
    if cf.kind == "topic" and cf.circle is not None:
        warnings.append(f"the reference circle is the circle fitted to the bag topic {cf.name} "
                        f"at import{named}: {describe_circle(cf.circle)}{unused}; every "
                        f"estimator is scored against it")
        return info("topic", cf.name, circle=cf.circle), warnings
    raise InputError(f"{who}: an unknown circle reference '{cf.kind}'")


def _laps_about(name: str, df: Trajectory, circle: Circle, what: str,
                warnings: list[str]) -> Laps | None:
    """The laps of trajectory ``name`` (t s, x, y m) about ``circle`` (``what``: how the
    warning names it); None, with a warning, when the trajectory does not follow it."""
    spread = radial_stats(circle.radial_error(df.x, df.y)).rmse
    if not follows_circle(spread, circle.r):
        warnings.append(
            f"the trajectory '{name}' does not follow {what} (radial RMSE {spread * 1e3:.0f} mm "
            f"about a {circle.r:.3f} m circle): circle metrics left out")
        return None
    return segment_laps(df.t, df.x, df.y, circle, source=name)


def circles_and_laps(
    trajs: dict[str, Trajectory],
    true_df: Trajectory | None,
    radius: float | None,
    shared: bool,
    lap_source: str | None,
    info: ReferenceInfo | None = None,
) -> tuple[dict[str, Circle], Laps, Circle | None, Circle | None, list[str]]:
    """Circles and rotations of a circle drive: (circle per estimator, rotations, the truth's
    circle, the reference circle (truth's, else the lap source's), warnings). The circles are
    empty when the lap source does not follow a circle. With an ``info`` whose circle is
    fitted to a reference (:attr:`ReferenceInfo.fixed_circle`), :func:`reference_circles`."""
    if info is not None and info.fixed_circle:
        return reference_circles(info, trajs, true_df, lap_source)
    warnings: list[str] = []
    circles = fit_circles(trajs, None, radius, shared)
    truth_circle = None
    candidates = dict(trajs)
    fitted = dict(circles)
    if true_df is not None:
        truth_circle = fit_circle(true_df.x, true_df.y, radius, trim=TRIM)
        candidates["truth"] = true_df
        fitted["truth"] = truth_circle
    prefer = lap_source or ("truth" if true_df is not None else None)
    if lap_source is not None and lap_source not in candidates:
        raise InputError(f"lap source '{lap_source}' is not among {', '.join(candidates)}")
    src = choose_lap_source(candidates, fitted, prefer)
    src_df, src_circle = candidates[src], fitted[src]
    found = _laps_about(src, src_df, src_circle, "a circle", warnings)
    if found is None:
        return {}, Laps(source=src), None, None, warnings
    laps = found
    if laps.complete == 0:
        warnings.append(
            f"fewer than one full rotation ({np.degrees(laps.swept):.0f} deg about the centre "
            f"of '{src}'): circle metrics left out")
        return circles, laps, truth_circle, src_circle, warnings
    masks = {n: laps.index(df.t) > 0 for n, df in trajs.items()}
    circles = fit_circles(trajs, masks, radius, shared, circles)
    if true_df is not None:
        m = laps.index(true_df.t) > 0
        truth_circle = fit_circle(true_df.x[m], true_df.y[m], radius, trim=TRIM,
                                  start=truth_circle)
    ref = truth_circle if truth_circle is not None else circles.get(src)
    return circles, laps, truth_circle, ref, warnings


def reference_circles(
    info: ReferenceInfo,
    trajs: dict[str, Trajectory],
    true_df: Trajectory | None,
    lap_source: str | None,
) -> tuple[dict[str, Circle], Laps, Circle | None, Circle | None, list[str]]:
    """:func:`circles_and_laps` for a circle fitted to a reference (truth, a named estimator, a
    stored topic's circle): every estimator but the reference itself gets that one circle
    (never a circle fitted to the estimator it scores). The rotations are found on
    ``lap_source`` if given, else the truth, else the named estimator, else the estimator
    closest to the circle. The circles are empty when the reference is no circle drive."""
    warnings: list[str] = []
    fits: dict[str, ReferenceFit] = {}
    ref_name = info.circle_reference or ""
    if info.circle_source == "topic":
        ref = info.given_circle
    else:
        df = true_df if info.circle_source == "truth" else trajs.get(ref_name)
        what = "the ground truth" if info.circle_source == "truth" else f"estimator '{ref_name}'"
        if df is None:
            warnings.append(f"the circle reference, {what}, is not among the trajectories "
                            f"evaluated ({', '.join(trajs)}): no reference circle, circle "
                            f"metrics left out")
            return {}, Laps(), None, None, warnings
        key = "truth" if info.circle_source == "truth" else ref_name
        fits[key] = fit_reference_circle(df.t, df.x, df.y, key)
        ref = fits[key].circle
        if ref is None:
            warnings.append(f"no reference circle: {fits[key].problem}; circle metrics left "
                            f"out")
            return {}, fits[key].laps, None, None, warnings
    assert ref is not None
    scored = {n: df for n, df in trajs.items()
              if not (info.circle_source == "estimator" and n == ref_name)}
    candidates = dict(trajs)
    if true_df is not None:
        candidates["truth"] = true_df
    if lap_source is not None and lap_source not in candidates:
        raise InputError(f"lap source '{lap_source}' is not among {', '.join(candidates)}")
    src = lap_source or ("truth" if true_df is not None else
                         ref_name if info.circle_source == "estimator" else
                         choose_lap_source(trajs, dict.fromkeys(trajs, ref), None))
    if src in fits:
        laps = fits[src].laps
    else:
        found = _laps_about(src, candidates[src], ref, "the reference circle", warnings)
        if found is None:
            return {}, Laps(source=src), None, None, warnings
        laps = found
    circles = dict.fromkeys(scored, ref)
    if not scored:
        warnings.append(f"estimator '{ref_name}' is the circle reference and the only "
                        f"trajectory: no circle figures")
    if laps.complete == 0:
        warnings.append(
            f"fewer than one full rotation ({np.degrees(laps.swept):.0f} deg about the centre "
            f"of the reference circle, on '{src}'): circle metrics left out")
        return circles, laps, None, ref, warnings
    truth_circle = ref if info.circle_source == "truth" else None
    if truth_circle is None and true_df is not None:
        m = laps.index(true_df.t) > 0
        if m.sum() >= MIN_SAMPLES:
            truth_circle = fit_circle(true_df.x[m], true_df.y[m], None, trim=TRIM)
    return circles, laps, truth_circle, ref, warnings
