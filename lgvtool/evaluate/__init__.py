"""Evaluation of localisation accuracy: reference circle, rotations, metrics, Table 1.

The core is pure (no files, no logs): it takes pandas DataFrames with columns t (s), x (m),
y (m), heading (rad) and returns plain objects. Reading logs and running estimators is the job
of :func:`lgvtool.evaluate.log_evaluation.evaluate_log`; plots and the HTML report live in
:mod:`lgvtool.evaluate.plots` and :mod:`lgvtool.evaluate.html_report` (they import plotly).

>>> from lgvtool.evaluate import evaluate_trajectories, build_table, to_markdown
>>> result = evaluate_trajectories({"laser": df1, "pf": df2}, steering_angle=math.radians(60),
...                                h=1.2)                                  # doctest: +SKIP
>>> print(to_markdown(build_table([result])))                              # doctest: +SKIP
"""

from typing import TYPE_CHECKING

from lgvtool.lazy_names import lazy_names

if TYPE_CHECKING:
    from lgvtool.circle import (
        Circle,
        fit_centre,
        fit_circle,
        fit_geometric,
        fit_kasa,
        kinematic_radius,
    )
    from lgvtool.evaluate.document import build_document, to_json
    from lgvtool.evaluate.evaluation import (
        EstimatorEvaluation,
        EvaluationResult,
        Rotation,
        evaluate_trajectories,
    )
    from lgvtool.evaluate.laps import Laps, segment_laps
    from lgvtool.evaluate.metrics import (
        RadialStats,
        TruthStats,
        associate_truth,
        radial_stats,
        truth_errors,
        truth_stats,
    )
    from lgvtool.evaluate.reference import ReferenceInfo
    from lgvtool.evaluate.regress import check_baseline, check_bounds, lookup
    from lgvtool.evaluate.table import Table1, build_table, to_csv, to_latex, to_markdown, to_text

#: public name -> module that defines it (imported on first use, so that a command needing one
#: part does not import the tables and pandas; the circle's fits are :mod:`lgvtool.circle`)
_EXPORTS = {
    "Circle": "lgvtool.circle", "fit_centre": "lgvtool.circle", "fit_circle": "lgvtool.circle",
    "fit_geometric": "lgvtool.circle", "fit_kasa": "lgvtool.circle",
    "build_document": "document", "to_json": "document",
    "EstimatorEvaluation": "evaluation", "EvaluationResult": "evaluation",
    "Rotation": "evaluation", "evaluate_trajectories": "evaluation",
    "Laps": "laps", "segment_laps": "laps",
    "RadialStats": "metrics", "TruthStats": "metrics", "associate_truth": "metrics",
    "radial_stats": "metrics", "truth_errors": "metrics", "truth_stats": "metrics",
    "ReferenceInfo": "reference", "kinematic_radius": "lgvtool.circle",
    "check_baseline": "regress", "check_bounds": "regress", "lookup": "regress",
    "Table1": "table", "build_table": "table", "to_csv": "table", "to_latex": "table",
    "to_markdown": "table", "to_text": "table",
}


__getattr__, __dir__ = lazy_names(__name__, _EXPORTS, globals())

__all__ = [
    "Circle",
    "EstimatorEvaluation",
    "EvaluationResult",
    "Laps",
    "RadialStats",
    "ReferenceInfo",
    "Rotation",
    "Table1",
    "TruthStats",
    "associate_truth",
    "build_document",
    "build_table",
    "check_baseline",
    "check_bounds",
    "evaluate_trajectories",
    "fit_centre",
    "fit_circle",
    "fit_geometric",
    "fit_kasa",
    "kinematic_radius",
    "lookup",
    "radial_stats",
    "segment_laps",
    "to_csv",
    "to_json",
    "to_latex",
    "to_markdown",
    "to_text",
    "truth_errors",
    "truth_stats",
]
