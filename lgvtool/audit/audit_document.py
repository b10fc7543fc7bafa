"""``audit.json`` (:func:`audit_document`) and the one-screen text summary (:func:`summary_lines`).

The document's keys: ``logs`` (the paths audited, in order), ``log_details`` (per log: path,
estimator and why, device family, duration s, revolutions used, note), ``estimator`` (the one
whose replayed pose was used; several comma-separated when the logs differ), ``device``,
``settings`` (the audit's thresholds), ``notes`` (what could not be audited, one line each),
``counts`` (reflectors per status, unmapped objects), ``reflectors`` (per layout reflector: id,
x, y m, status, expected_sightings, sightings, detection_share, shortfall_sigmas, residual_m,
shift_m [dx, dy], shift_sigma_m [sx, sy], shift_sigmas, range_offset_m (its own range
offset, fitted beside the shift), range_residual_m {mean, rms},
bearing_residual_rad {mean, rms}, quality {mean, trend_per_day} (the device's quality),
mean_echo {mean, trend_per_day} (the device's mean echo, device units), near: the ids an
ambiguous one is confused with), ``unmapped`` (x, y m, sightings, sigma_m), ``coverage``
(:func:`lgvtool.audit.coverage.coverage_section`), ``navigation`` (the device's own
navigation status: :func:`lgvtool.audit.navigation_health.navigation_section`), ``segments``
(the errors by segment: :func:`lgvtool.audit.segment_errors.segments_section`), ``stations``
(the standstills grouped into stations, each source's repeatability there:
:func:`lgvtool.audit.stations.stations_section`). Numbers
that do not exist (no sightings, no quality or echo) are null. A NAV200 log without landmarks has
``reflectors`` empty and a note.
``layout`` (the site's layout as the first log stores it: per reflector id, x, y m) is
there in every case, so that two audits can be told to be of one site
(``lgvtool compare``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from lgvtool.audit.audit_settings import AuditSettings
from lgvtool.audit.log_audit import LogEvidence
from lgvtool.audit.reflector_audit import STATUSES, ReflectorVerdict
from lgvtool.audit.segment_errors import summary_line as segment_summary
from lgvtool.audit.stations import summary_line as station_summary
from lgvtool.audit.unmapped_objects import UnmappedObject
from lgvtool.declared import as_dict
from lgvtool.json_types import JSON, JSONObject

__all__ = ["audit_document", "summary_lines"]


def _num(v: float, digits: int = 4) -> float | None:
    """A float rounded to ``digits`` decimals; None when not finite."""
    return round(v, digits) if math.isfinite(v) else None


def _pair(v: tuple[float, float], digits: int = 4) -> list[JSON] | None:
    a, b = _num(v[0], digits), _num(v[1], digits)
    return None if a is None or b is None else [a, b]


def _reflector(v: ReflectorVerdict) -> JSONObject:
    return {
        "id": v.id, "x": _num(v.x), "y": _num(v.y), "status": v.status,
        "expected_sightings": v.expected_sightings, "sightings": v.sightings,
        "detection_share": _num(v.detection_share, 3),
        "shortfall_sigmas": _num(v.shortfall_sigmas, 2),
        "residual_m": _num(v.residual_m), "shift_m": _pair(v.shift_m),
        "shift_sigma_m": _pair(v.shift_sigma_m), "shift_sigmas": _num(v.shift_sigmas, 2),
        "range_offset_m": _num(v.range_offset_m),
        "range_residual_m": {"mean": _num(v.range_residual_m[0]),
                             "rms": _num(v.range_residual_m[1])},
        "bearing_residual_rad": {"mean": _num(v.bearing_residual_rad[0], 6),
                                 "rms": _num(v.bearing_residual_rad[1], 6)},
        **{name: {"mean": _num(t.mean, 2), "trend_per_day": _num(t.per_day, 3)}
           for name, t in v.device.items()},
        "near": list(v.near),
    }


def _unmapped(u: UnmappedObject) -> JSONObject:
    return {"x": _num(u.x), "y": _num(u.y), "sightings": u.sightings,
            "sigma_m": _num(u.sigma_m)}


def audit_document(parts: Sequence[LogEvidence], verdicts: Sequence[ReflectorVerdict],
                   unmapped: Sequence[UnmappedObject], coverage: JSONObject,
                   settings: AuditSettings, *, navigation: JSONObject | None = None,
                   segments: JSONObject | None = None,
                   stations: JSONObject | None = None) -> JSONObject:
    """The ``audit.json`` document of the logs ``parts`` (their evidence, in the order given),
    the pooled ``verdicts`` per layout reflector (empty: none audited), the ``unmapped``
    objects, the ``coverage`` section and the ``navigation``, ``segments`` and ``stations``
    sections (module doc; None: an empty one)."""
    notes: list[JSON] = [f"{p.path}: {p.note}" for p in parts if p.note]
    counts: JSONObject = {s: sum(v.status == s for v in verdicts) for s in STATUSES}
    counts["unmapped"] = len(unmapped)
    return {
        "logs": [p.path for p in parts],
        "log_details": [{"path": p.path, "estimator": p.estimator,
                         "estimator_chosen": p.chosen_because, "device": p.family,
                         "duration_s": _num(p.duration_s, 3),
                         "revolutions": p.reflectors.revolutions if p.reflectors else 0,
                         "note": p.note} for p in parts],
        "estimator": ", ".join(dict.fromkeys(p.estimator for p in parts)),
        "device": ", ".join(dict.fromkeys(p.family for p in parts)),
        "settings": as_dict(settings),
        "notes": notes,
        "counts": counts,
        "reflectors": [_reflector(v) for v in verdicts],
        "unmapped": [_unmapped(u) for u in unmapped],
        "coverage": coverage,
        "navigation": navigation if navigation is not None else {},
        "segments": segments if segments is not None else {},
        "stations": stations if stations is not None else {},
        "layout": [{"id": r.id, "x": _num(r.x), "y": _num(r.y)}
                   for r in (parts[0].layout if parts else ())],
    }


def _mm(v: JSON) -> str:
    return f"{v * 1000:+.1f}" if isinstance(v, int | float) else "-"


def _fixed(value: JSON, digits: int) -> str:
    """A number with ``digits`` decimals, or ``-`` for anything else."""
    return f"{value:.{digits}f}" if isinstance(value, int | float) else "-"


def _m(value: JSON) -> str:
    """A position in m to the millimetre, or ``-``."""
    return _fixed(value, 3)


def summary_lines(doc: JSONObject, written: Sequence[str] = (), most: int = 12) -> list[str]:
    """The text summary of an audit document: what was audited with which pose, the counts,
    one line per reflector that is not ok (at most ``most``), the unmapped objects, a line of
    coverage and the files ``written``; about one screen."""
    logs = doc.get("logs")
    n_logs = len(logs) if isinstance(logs, list) else 0
    details = doc.get("log_details")
    why = ""
    if isinstance(details, list) and details and isinstance(details[0], dict):
        why = str(details[0].get("estimator_chosen", ""))
    head = (f"audit of {n_logs} log{'s' if n_logs != 1 else ''} ({doc.get('device')}); pose: "
            f"{doc.get('estimator')}" + (f" ({why})" if why and n_logs == 1 else ""))
    lines = [head]
    notes = doc.get("notes")
    if isinstance(notes, list):
        lines += [str(n) for n in notes]
    refl = doc.get("reflectors")
    refl = refl if isinstance(refl, list) else []
    counts = doc.get("counts")
    if refl and isinstance(counts, dict):
        lines.append(f"reflectors: {len(refl)} in the layout: " + ", ".join(
            f"{counts.get(s, 0)} {s}" for s in STATUSES))
        bad = [r for r in refl if isinstance(r, dict) and r.get("status") != "ok"]
        if bad:
            lines.append("    id  status     expected  seen  share  shift dx, dy (mm)  "
                         "1-sigma (mm)")
        for r in bad[:most]:
            shift = r.get("shift_m")
            sig = r.get("shift_sigma_m")
            share = r.get("detection_share")
            near = r.get("near")
            text = (f"  {r.get('id')!s:>4}  {r.get('status')!s:<9} "
                    f"{r.get('expected_sightings')!s:>9} {r.get('sightings')!s:>5}  "
                    + (f"{share:5.2f}" if isinstance(share, int | float) else "    -"))
            if r.get("status") == "moved" and isinstance(shift, list) and isinstance(sig, list):
                text += (f"  {_mm(shift[0])}, {_mm(shift[1])}".ljust(20)
                         + f" {_mm(sig[0]).lstrip('+')}, {_mm(sig[1]).lstrip('+')}")
            if r.get("status") == "ambiguous" and isinstance(near, list):
                text += "  near " + ", ".join(str(v) for v in near)
            lines.append(text)
        if len(bad) > most:
            lines.append(f"  ... and {len(bad) - most} more in audit.json")
    unmapped = doc.get("unmapped")
    if isinstance(unmapped, list) and unmapped:
        lines.append(f"unmapped: {len(unmapped)} recurring detection"
                     f"{'s' if len(unmapped) != 1 else ''} matching no layout reflector")
        for u in unmapped[:4]:
            if isinstance(u, dict):
                sigma = u.get("sigma_m")
                lines.append(f"  at ({_m(u.get('x'))}, {_m(u.get('y'))}) m, "
                             f"{u.get('sightings')} sightings" + (f", sigma {float(sigma) * 1000:.0f} mm"
                                            if isinstance(sigma, int | float) else ""))
    elif refl:
        lines.append("unmapped: none")
    cov = doc.get("coverage")
    if isinstance(cov, dict) and cov:
        vis, g = cov.get("visible"), cov.get("gdop")
        vis_med = vis.get("median") if isinstance(vis, dict) else None
        g_med = g.get("median") if isinstance(g, dict) else None
        lines.append(f"coverage: {cov.get('poses')} poses; reflectors visible median "
                     f"{_fixed(vis_med, 0)}, GDOP median {_fixed(g_med, 2)}; "
                     f"{cov.get('segments_total')} poor "
                     f"segment{'s' if cov.get('segments_total') != 1 else ''} "
                     f"({_fixed(cov.get('poor_time_s'), 1)} s)")
    nav = doc.get("navigation")
    if isinstance(nav, dict) and nav.get("logs"):
        share = nav.get("share_in_navigation")
        causes = nav.get("dropout_causes")
        why = (" (" + ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in causes.items()) + ")"
               if isinstance(causes, dict) and causes else "")
        lines.append(f"navigation: {_fixed(share * 100 if isinstance(share, int | float) else None, 1)}"
                     f" % of the time; {nav.get('dropouts')} dropouts{why}, "
                     f"{_fixed(nav.get('dropout_time_s'), 1)} s; {nav.get('pose_jumps')} pose "
                     f"jumps; {nav.get('clock_jumps')} clock jumps")
    seg = doc.get("segments")
    seg_line = segment_summary(seg) if isinstance(seg, dict) else None
    if seg_line:
        lines.append(seg_line)
    st = doc.get("stations")
    st_line = station_summary(st) if isinstance(st, dict) else None
    if st_line:
        lines.append(st_line)
    if written:
        lines.append("wrote " + ", ".join(written))
    return lines
