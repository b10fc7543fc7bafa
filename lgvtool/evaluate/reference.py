"""The reference circle of a drive and its rotations: radius, centres, lap source. Pure.

See :mod:`lgvtool.evaluate.evaluation` for the steps; this module fits the circles and finds
the rotations that the metrics are computed over.
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

if TYPE_CHECKING:
    import pandas as pd

MIN_SAMPLES = 3
"""Fewest samples that make a trajectory usable."""


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


def steering_from_frames(frames: pd.DataFrame | None) -> float | None:
    """:func:`median_steering` of MCU frames (columns steering_angle in rad and, if present,
    drive_speed in m/s)."""
    if frames is None or frames.empty or "steering_angle" not in frames.columns:
        return None
    speed = (frames["drive_speed"].to_numpy(dtype=float) if "drive_speed" in frames.columns
             else None)
    return median_steering(frames["steering_angle"].to_numpy(dtype=float), speed)


def fit_circles(
    trajs: Mapping[str, pd.DataFrame],
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
        return df["x"].to_numpy()[m], df["y"].to_numpy()[m]

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
    trajs: Mapping[str, pd.DataFrame], circles: Mapping[str, Circle], prefer: str | None
) -> str:
    """``prefer`` if it is among ``trajs``, else the trajectory with the smallest radial RMSE
    about its circle (ties broken by name)."""
    if prefer is not None and prefer in trajs:
        return prefer
    scores = {
        n: radial_stats(circles[n].radial_error(df["x"], df["y"])).rmse for n, df in trajs.items()
    }
    return min(scores, key=lambda n: (scores[n], n))


def reference_info(
    steering_angle: float | None, steering_source: str, h: float, free_radius: bool,
    shared_centre: bool, *, has_truth: bool, name: str,
) -> tuple[ReferenceInfo, list[str]]:
    """How the reference circle is built, and warnings; InputError with nothing to compare."""
    warnings: list[str] = []
    kin: float | None = None
    if steering_angle is None:
        if not has_truth:
            raise InputError(
                f"{name or 'log'}: no steering angle in the log (/mcu/frame) and none configured "
                "(reference.steering_angle_deg), and no ground truth: nothing to compare with"
            )
        warnings.append("no steering angle in the log and none configured: no reference "
                        "circle, ground-truth metrics only")
    else:
        kin = kinematic_radius(h, steering_angle)
        if not math.isfinite(kin):
            kin = None
            warnings.append("the steering angle is zero (a straight drive): no reference circle")
    info = ReferenceInfo(steering_angle, steering_source if steering_angle is not None else "none",
                         h, kin, free_radius, shared_centre, circle_drive=kin is not None)
    return info, warnings


def circles_and_laps(
    trajs: dict[str, pd.DataFrame],
    true_df: pd.DataFrame | None,
    radius: float | None,
    shared: bool,
    lap_source: str | None,
) -> tuple[dict[str, Circle], Laps, Circle | None, Circle | None, list[str]]:
    """Circles and rotations of a circle drive: (circle per estimator, rotations, the truth's
    circle, the reference circle (truth's, else the lap source's), warnings). The circles are
    empty when the lap source does not follow a circle."""
    warnings: list[str] = []
    circles = fit_circles(trajs, None, radius, shared)
    truth_circle = None
    candidates = dict(trajs)
    fitted = dict(circles)
    if true_df is not None:
        truth_circle = fit_circle(true_df["x"], true_df["y"], radius, trim=TRIM)
        candidates["truth"] = true_df
        fitted["truth"] = truth_circle
    prefer = lap_source or ("truth" if true_df is not None else None)
    if lap_source is not None and lap_source not in candidates:
        raise InputError(f"lap source '{lap_source}' is not among {', '.join(candidates)}")
    src = choose_lap_source(candidates, fitted, prefer)
    src_df, src_circle = candidates[src], fitted[src]
    spread = radial_stats(src_circle.radial_error(src_df["x"], src_df["y"])).rmse
    if not follows_circle(spread, src_circle.r):
        warnings.append(
            f"the trajectory '{src}' does not follow a circle (radial RMSE {spread * 1e3:.0f} mm "
            f"about a {src_circle.r:.3f} m circle): circle metrics left out")
        return {}, Laps(source=src), None, None, warnings
    laps = segment_laps(src_df["t"], src_df["x"], src_df["y"], src_circle, source=src)
    if laps.complete == 0:
        warnings.append(
            f"fewer than one full rotation ({np.degrees(laps.swept):.0f} deg about the centre "
            f"of '{src}'): circle metrics left out")
        return circles, laps, truth_circle, src_circle, warnings
    masks = {n: laps.index(df["t"]) > 0 for n, df in trajs.items()}
    circles = fit_circles(trajs, masks, radius, shared, circles)
    if true_df is not None:
        m = laps.index(true_df["t"]) > 0
        truth_circle = fit_circle(true_df["x"][m], true_df["y"][m], radius, trim=TRIM,
                                  start=truth_circle)
    ref = truth_circle if truth_circle is not None else circles.get(src)
    return circles, laps, truth_circle, ref, warnings
