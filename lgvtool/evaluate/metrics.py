"""Error metrics: radial error about the reference circle, and error against ground truth.

Radial statistics of a set of signed errors e (m):

- RMSE = sqrt(mean(e^2)), m;
- variance = mean((e - mean(e))^2), m^2 (population variance, so RMSE^2 = mean^2 + variance
  holds exactly and splits the error into bias and spread);
- mean (the bias), m; max |e|, m.

Ground truth is associated with an estimate by linear interpolation of the truth at the
estimate's time (heading interpolated on the unwrapped angle); estimates outside the truth's
time span, or inside a gap of the truth (longer than ``max_gap`` and than 5 times its median
sampling interval), are left out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from lgvtool.angles import wrap_angle
from lgvtool.trajectory import SYNC_MAX_GAP

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.trajectory import Trajectory

TRUTH_MAX_GAP = SYNC_MAX_GAP
"""Longest gap between two truth samples that interpolation always bridges, s. Longer
intervals are bridged too as long as they are within 5 times the truth's median interval."""


@dataclass(frozen=True)
class RadialStats:
    """Statistics of signed radial errors: rmse, mean, max_abs in m, variance in m^2."""

    rmse: float
    variance: float
    mean: float
    max_abs: float
    samples: int


def radial_stats(err: ArrayLike) -> RadialStats:
    """:class:`RadialStats` of the finite values of ``err`` (m); NaN figures if there are none."""
    e = np.asarray(err, dtype=float)
    e = e[np.isfinite(e)]
    if e.size == 0:
        nan = math.nan
        return RadialStats(nan, nan, nan, nan, 0)
    mean = float(np.mean(e))
    return RadialStats(
        rmse=float(np.sqrt(np.mean(e * e))),
        variance=float(np.mean((e - mean) ** 2)),
        mean=mean,
        max_abs=float(np.max(np.abs(e))),
        samples=int(e.size),
    )


def average_stats(rows: Sequence[RadialStats]) -> RadialStats:
    """The Average row of Table 1: the mean over rotations of RMSE, variance and bias (as the
    paper averages its rows), and the largest max |error| of any rotation. Samples are summed."""
    if not rows:
        nan = math.nan
        return RadialStats(nan, nan, nan, nan, 0)
    return RadialStats(
        rmse=float(np.mean([r.rmse for r in rows])),
        variance=float(np.mean([r.variance for r in rows])),
        mean=float(np.mean([r.mean for r in rows])),
        max_abs=float(np.max([r.max_abs for r in rows])),
        samples=int(sum(r.samples for r in rows)),
    )


def improvement(value: float, reference: float) -> float:
    """Improvement of ``value`` over ``reference`` in %: 100 (1 - value / reference)."""
    if not (math.isfinite(value) and math.isfinite(reference)) or reference == 0:
        return math.nan
    return 100.0 * (1.0 - value / reference)


# --------------------------------------------------------------------------- ground truth


def associate_truth(
    estimate: Trajectory | pd.DataFrame, truth: Trajectory | pd.DataFrame, *,
    max_gap: float = TRUTH_MAX_GAP
) -> pd.DataFrame:
    """The truth interpolated at the estimate's times (:meth:`Trajectory.sync`: times in s,
    x, y in m, heading in rad, both on one clock).

    Returns the estimate rows that can be associated with columns t, x, y, heading, x_true,
    y_true, heading_true.
    """
    import pandas as pd

    from lgvtool.trajectory import Trajectory

    mine, true = Trajectory.of(estimate, "estimate").sync(Trajectory.of(truth, "truth"),
                                                         max_gap=max_gap)
    return pd.DataFrame({"t": mine.t, "x": mine.x, "y": mine.y, "heading": mine.heading,
                         "x_true": true.x, "y_true": true.y, "heading_true": true.heading})


def truth_errors(estimate: Trajectory | pd.DataFrame, truth: Trajectory | pd.DataFrame, *,
                 max_gap: float = TRUTH_MAX_GAP) -> pd.DataFrame:
    """Per-sample errors against the interpolated truth: columns t (s), position_error (m,
    Euclidean), heading_error (rad, wrapped, estimate minus truth)."""
    import pandas as pd

    from lgvtool.trajectory import Trajectory

    mine, true = Trajectory.of(estimate, "estimate").sync(Trajectory.of(truth, "truth"),
                                                         max_gap=max_gap)
    return pd.DataFrame(
        {
            "t": mine.t,
            "position_error": np.hypot(mine.x - true.x, mine.y - true.y),
            "heading_error": wrap_angle(mine.heading - true.heading),
        }
    )


@dataclass(frozen=True)
class TruthStats:
    """Error against ground truth: position in m, heading in rad."""

    position_rmse: float
    position_mean: float
    position_p95: float
    position_max: float
    heading_rmse: float
    samples: int


def truth_stats(position_error: ArrayLike, heading_error: ArrayLike) -> TruthStats:
    """:class:`TruthStats` of per-sample position (m) and heading (rad) errors; non-finite
    values are left out, NaN figures if nothing remains."""
    p = np.asarray(position_error, dtype=float)
    p = p[np.isfinite(p)]
    h = np.asarray(heading_error, dtype=float)
    h = h[np.isfinite(h)]
    nan = math.nan
    if p.size == 0:
        return TruthStats(nan, nan, nan, nan, nan, 0)
    return TruthStats(
        position_rmse=float(np.sqrt(np.mean(p * p))),
        position_mean=float(np.mean(p)),
        position_p95=float(np.percentile(p, 95)),
        position_max=float(np.max(p)),
        heading_rmse=float(np.sqrt(np.mean(h * h))) if h.size else nan,
        samples=int(p.size),
    )
