"""The evaluation as a JSON document with stable keys (docs/evaluation.md).

One log gives one document; several logs give the same layout with the figures over all logs
and one document per log under ``per_log``. Circle figures are in mm and mm^2, ground-truth
figures in m and degrees, times in s; a figure that cannot be computed is ``null``. Each log's
document holds its verdict (``verdict``, :func:`lgvtool.evaluate.verdict.verdict_dict`, m);
several logs add ``verdict_summary``, one line. ``evaluate`` adds ``checks``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence

from lgvtool import __version__
from lgvtool.evaluate.evaluation import EvaluationResult
from lgvtool.evaluate.metrics import RadialStats, TruthStats
from lgvtool.evaluate.quality import DataQuality, log_quality
from lgvtool.evaluate.table import MM, Table1, build_table
from lgvtool.evaluate.verdict import Verdict, summary_line, verdict_dict, verdict_of
from lgvtool.json_types import JSON, JSONObject, JSONRecord

FORMAT = "lgvtool.evaluation"
FORMAT_VERSION = 1


def _num(v: float | None) -> float | None:
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else None


def radial_dict(s: RadialStats) -> JSONObject:
    """Radial statistics in mm / mm^2."""
    return {
        "rmse_mm": _num(s.rmse * MM),
        "variance_mm2": _num(s.variance * MM * MM),
        "mean_mm": _num(s.mean * MM),
        "max_abs_mm": _num(s.max_abs * MM),
        "samples": s.samples,
    }


def truth_dict(t: TruthStats) -> JSONObject:
    """Ground-truth statistics in m / degrees."""
    return {
        "position_rmse_m": _num(t.position_rmse),
        "position_mean_m": _num(t.position_mean),
        "position_p95_m": _num(t.position_p95),
        "position_max_m": _num(t.position_max),
        "heading_rmse_deg": _num(math.degrees(t.heading_rmse)),
        "samples": t.samples,
    }


def _estimators(table: Table1) -> dict[str, JSONObject]:
    out: dict[str, JSONObject] = {}
    for n in table.estimators:
        circle: JSONObject | None = None
        avg = table.average.get(n)
        if avg is not None:
            rows: list[JSON] = []
            for r in table.rows:
                s = r.stats.get(n)
                if s is None:
                    continue
                row: JSONObject = {"log": r.log, "number": r.number, "rotation": r.rotation,
                       "start_s": r.start, "end_s": r.end, **radial_dict(s)}
                if r.truth_rmse.get(n) is not None:
                    row["truth_position_rmse_mm"] = _num(r.truth_rmse[n] * MM)
                rows.append(row)
            circle = {**radial_dict(avg), "rotations": len(rows),
                      "improvement_pct": _num(table.improvement.get(n)),
                      "centre_offset_m": _num(table.centre_offset.get(n)), "rows": rows}
        truth = table.truth.get(n)
        tblock: JSONObject | None = None
        if truth is not None:
            tblock = truth_dict(truth)
            inside = table.truth_in_rotations.get(n)
            tblock["position_rmse_rotations_m"] = _num(inside) if inside is not None else None
        out[n] = {"circle": circle, "truth": tblock}
    return out


def quality_dict(q: DataQuality) -> JSONObject:
    """The data-quality figures of a log (counts; gap times in s)."""
    longest = max((g.length for g in q.gaps), default=None)
    return {
        "diagnostics": q.diagnostics,
        "by_level": {_LEVEL_NAMES.get(k, str(k)): v for k, v in sorted(q.by_level.items())},
        "by_kind": [{"source": s, "kind": k, "count": n}
                    for (s, k), n in sorted(q.by_kind.items())],
        "dropped_frames": q.dropped_frames,
        "corrupt_frames": sum(q.corrupt_frames.values()),
        "corrupt_frames_by_source": dict(sorted(q.corrupt_frames.items())),
        "skipped_bytes": q.skipped_bytes,
        "nav_replies": q.nav_replies,
        "nav_no_position": q.nav_no_position,
        "nav_unanswered": q.nav_unanswered,
        "gaps": len(q.gaps),
        "gaps_total_s": sum(g.length for g in q.gaps),
        "longest_gap_s": longest,
    }


_LEVEL_NAMES = {1: "debug", 2: "info", 3: "warning", 4: "error", 5: "fatal"}


def _log_doc(res: EvaluationResult) -> JSONObject:
    table = build_table([res])
    ref = res.reference
    t_end = max(float(ev.trajectory.t[-1]) for ev in res.estimators.values())
    circles: JSONObject = {}
    for n, ev in res.estimators.items():
        if ev.circle is not None:
            circles[n] = {"centre_x_m": ev.circle.cx, "centre_y_m": ev.circle.cy,
                          "radius_m": ev.circle.r,
                          "fitted_radius_m": ev.fitted.r if ev.fitted else None,
                          "centre_offset_m": ev.centre_offset}
    if res.truth_circle is not None:
        circles["truth"] = {"centre_x_m": res.truth_circle.cx, "centre_y_m": res.truth_circle.cy,
                            "radius_m": res.truth_circle.r, "fitted_radius_m": None,
                            "centre_offset_m": 0.0}
    estimators = _estimators(table)
    quality = log_quality(res)
    for n, block in estimators.items():
        if res.settings.get(n):
            block["settings"] = dict(res.settings[n])
    return {
        "log": {"name": res.name, "path": res.path, "source": res.source, "start_s": res.t0,
                "duration_s": t_end - res.t0, "ground_truth": res.has_truth},
        "reference": {
            "steering_angle_deg": _num(math.degrees(ref.steering_angle))
            if ref.steering_angle is not None else None,
            "steering_source": ref.steering_source,
            "h_m": ref.h,
            "kinematic_radius_m": _num(ref.kinematic_radius),
            "free_radius": ref.free_radius,
            "shared_centre": ref.shared_centre,
            "circle_drive": ref.circle_drive,
            "circle_source": ref.circle_source,
            "circle_reference": ref.circle_reference,
            "circles": circles,
        },
        "rotations": {
            "complete": res.laps.complete,
            "partial": res.laps.partial,
            "partial_fraction": res.laps.partial_fraction,
            "lap_source": res.laps.source or None,
            "direction": "ccw" if res.laps.direction > 0 else "cw",
            "boundaries_s": list(res.laps.boundaries),
        },
        "truth_path": radial_dict(res.truth_path) if res.truth_path is not None else None,
        "estimators": {**estimators},
        "data_quality": None if quality is None else quality_dict(quality),
        "warnings": list(res.warnings),
        "verdict": verdict_dict(res.verdict if res.verdict is not None
                                else verdict_of(res, quality=quality)),
    }


def build_document(results: Sequence[EvaluationResult]) -> JSONObject:
    """The JSON-ready document of an evaluation of one or more logs."""
    head: JSONObject = {"format": FORMAT, "format_version": FORMAT_VERSION, "lgvtool_version": __version__}
    if len(results) == 1:
        return {**head, **_log_doc(results[0])}
    table = build_table(results)
    per_log: list[JSON] = [_log_doc(r) for r in results]
    return {
        **head,
        "log": {"name": "all", "logs": len(results), "paths": [r.path for r in results],
                "names": [r.name for r in results]},
        "reference": None,
        "rotations": {"complete": sum(r.laps.complete for r in results),
                      "partial": sum(r.laps.partial for r in results)},
        "truth_path": None,
        "estimators": {**_estimators(table)},
        "warnings": [f"{r.name}: {w}" for r in results for w in r.warnings],
        "verdict": None,
        "verdict_summary": summary_line([_verdict(r) for r in results]),
        "per_log": per_log,
    }


def _verdict(res: EvaluationResult) -> Verdict:
    return res.verdict if res.verdict is not None else verdict_of(res)


def _plain(value: object) -> JSON:
    """JSON-safe copy: non-finite numbers become null, tuples lists, numpy scalars Python."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, bool) or value is None or isinstance(value, str | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    item = getattr(value, "item", None)       # numpy scalars
    if callable(item):
        return _plain(item())
    return str(value)


def to_json(doc: JSONRecord) -> str:
    """The document as indented JSON text (NaN never appears: missing figures are null)."""
    return json.dumps(_plain(doc), indent=2, allow_nan=False) + "\n"
