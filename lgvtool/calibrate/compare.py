"""Before and after: the estimators' errors on each log with the starting and with the
calibrated configuration (ground truth where the log has it, else the reference circle)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from lgvtool.config import Config
from lgvtool.json_types import JSONObject

if TYPE_CHECKING:
    from lgvtool.evaluate.evaluation import EvaluationResult


@dataclass(frozen=True)
class Row:
    """One estimator on one log (or on all logs, ``log`` = ``"all"``)."""

    log: str
    estimator: str
    metric: str
    """``truth_rmse_m`` (position RMSE against the ground truth) or ``circle_rmse_m`` (Table 1's
    average radial RMSE)."""
    before: float
    """With the starting configuration, m."""
    after: float
    """With the calibrated configuration, m."""
    samples: int

    @property
    def change(self) -> float:
        """Relative change after against before, % (negative: better)."""
        if not (math.isfinite(self.before) and self.before > 0):
            return math.nan
        return 100.0 * (self.after - self.before) / self.before

    def to_dict(self) -> JSONObject:
        """JSON-ready (NaN as None)."""
        def num(v: float) -> float | None:
            return v if math.isfinite(v) else None

        return {"log": self.log, "estimator": self.estimator, "metric": self.metric,
                "before_m": num(self.before), "after_m": num(self.after),
                "change_percent": num(self.change), "samples": self.samples}


def _figure(result: EvaluationResult, name: str) -> tuple[str, float, int] | None:
    ev = result.estimators.get(name)
    if ev is None:
        return None
    if ev.truth is not None and ev.truth.samples:
        return "truth_rmse_m", float(ev.truth.position_rmse), int(ev.truth.samples)
    if ev.average is not None:
        return "circle_rmse_m", float(ev.average.rmse), len(ev.rotations)
    return None


def compare(paths: Sequence[str], estimators: Sequence[str], before: Config, after: Config,
            seed: int = 0, start_at_truth: bool = False) -> tuple[list[Row], list[str]]:
    """Rows per log and estimator, then one per estimator over all logs (RMS over every
    sample); warnings of the evaluations. ``start_at_truth``: every estimator starts at the
    ground truth (``lgvtool evaluate --start-at-truth``)."""
    import warnings as pywarnings

    from lgvtool.evaluate.log_evaluation import evaluate_log

    rows: list[Row] = []
    notes: list[str] = []
    pooled: dict[tuple[str, str], list[float]] = {}
    for path in paths:
        results = []
        for cfg in (before, after):
            with pywarnings.catch_warnings():
                pywarnings.simplefilter("ignore")
                results.append(evaluate_log(path, estimators=list(estimators), config=cfg,
                                            seed=seed, replay=True,
                                            start_at_truth=start_at_truth))
        for name in estimators:
            a, b = _figure(results[0], name), _figure(results[1], name)
            if a is None or b is None:
                notes.append(f"{path}: {name} has no error figure (no ground truth and no "
                             f"complete rotation)")
                continue
            rows.append(Row(path, name, a[0], a[1], b[1], a[2]))
            acc = pooled.setdefault((name, a[0]), [0.0, 0.0, 0.0])
            acc[0] += a[1] ** 2 * a[2]
            acc[1] += b[1] ** 2 * a[2]
            acc[2] += a[2]
    if len(paths) > 1:
        for (name, metric), (sa, sb, n) in pooled.items():
            if n > 0:
                rows.append(Row("all", name, metric, math.sqrt(sa / n), math.sqrt(sb / n),
                                int(n)))
    return rows, notes
