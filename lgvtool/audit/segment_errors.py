"""Error by segment (``audit.json``'s ``segments``): the along-track, cross-track and heading
error of each pose source the audit has (the replayed estimator and the raw laser: the NAV's
own poses moved to O) against a reference, binned by the reference's speed, its curvature,
forward/reverse and straight/turn.

The reference is the log's ground truth (/truth/pose) where it has one, else the estimator
the audit replays (then only the laser is compared with it); every part of the section says
which (``reference``). The errors are in the reference's frame of travel: the position error
(estimate minus reference) projected on the direction the reference moves in (its heading
driving forward or standing, its heading + pi driving in reverse: the velocity's direction),
``along`` positive ahead, ``cross`` positive to the left of that direction; ``heading`` is
the estimate's heading minus the reference's, wrapped. The reference's speed (signed along
its heading) and yaw rate are central differences over ``velocity_window_s``; the curvature
is the yaw rate over the speed.

Pure: arrays in, sums out. Each bin keeps the sufficient statistics (count, the sum and the
sum of squares of each error), so that logs pool by adding (:meth:`BinSums.merged`) into
what one long log would give. Positions m, angles rad, times s, speeds m/s, curvature 1/m.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.declared import setting
from lgvtool.json_types import JSON, JSONObject
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["COMPONENTS", "DIMENSIONS", "BinSums", "SegmentErrors", "SegmentSettings",
           "bin_labels", "log_segments", "pooled_segments", "segment_errors", "segments_section"]

COMPONENTS = ("along", "cross", "heading")
"""The errors of every bin: along-track m, cross-track m, heading rad."""

DIMENSIONS = ("speed", "curvature", "direction", "shape")
"""What the poses are binned by: the reference's speed (m/s bins), its curvature (1/m bins),
forward/reverse and straight/turn; each pose falls into one bin of each."""

FRAME = ("position error (estimate - reference) projected on the reference's direction of "
         "travel: its heading forward and at standstill, its heading + pi in reverse (the "
         "velocity's direction); along positive ahead, cross positive to the left; heading: "
         "estimate - reference, wrapped")
"""How along and cross are measured (said in the JSON)."""


@dataclass(frozen=True)
class SegmentSettings:
    """How the poses are binned (``lgvtool audit --set segments.<key>=<value>``)."""

    speed_bin_m_s: float = setting(
        0.25,
        "Width of the speed bins (the reference's speed, either direction), m/s.",
        unit="m/s", minimum=0.0, min_open=True, maximum=10.0)
    speed_bins: int = setting(
        8,
        "Number of speed bins; the last also holds every faster pose.",
        unit="", minimum=1, maximum=100)
    curvature_bin_per_m: float = setting(
        0.25,
        "Width of the curvature bins (the reference's yaw rate over its speed, either "
        "sign), 1/m.",
        unit="1/m", minimum=0.0, min_open=True, maximum=100.0)
    curvature_bins: int = setting(
        8,
        "Number of curvature bins; the last also holds every tighter curve (a standstill "
        "has its own bin).",
        unit="", minimum=1, maximum=100)
    turn_curvature_per_m: float = setting(
        0.05,
        "A moving pose is on a turn when the reference's curvature is above this, else on a "
        "straight, 1/m (a 20 m radius).",
        unit="1/m", minimum=0.0, min_open=True)
    standstill_m_s: float = setting(
        0.05,
        "Below this speed the reference stands: neither forward nor reverse, neither "
        "straight nor turn (its curvature is not defined), m/s.",
        unit="m/s", minimum=0.0)
    velocity_window_s: float = setting(
        0.5,
        "The reference's speed and yaw rate are its displacement and heading change over "
        "this window centred on each pose, s (several of an estimator's revolutions: a "
        "central difference of neighbouring estimates is mostly their noise).",
        unit="s", minimum=0.0, min_open=True, maximum=10.0)


def bin_labels(dimension: str, s: SegmentSettings) -> tuple[str, ...]:
    """The names of the bins of ``dimension`` (of :data:`DIMENSIONS`), in order: speed and
    curvature by their range (m/s, 1/m; the last open), curvature's last bin
    ``standstill``."""
    if dimension == "speed":
        w = s.speed_bin_m_s
        ranges = [f"{i * w:.2f}-{(i + 1) * w:.2f}" for i in range(s.speed_bins - 1)]
        return (*ranges, f">={(s.speed_bins - 1) * w:.2f}")
    if dimension == "curvature":
        w = s.curvature_bin_per_m
        ranges = [f"{i * w:.2f}-{(i + 1) * w:.2f}" for i in range(s.curvature_bins - 1)]
        return (*ranges, f">={(s.curvature_bins - 1) * w:.2f}", "standstill")
    if dimension == "direction":
        return ("forward", "reverse", "standstill")
    if dimension == "shape":
        return ("straight", "turn", "standstill")
    raise ValueError(f"unknown dimension {dimension!r}")


@dataclass(frozen=True)
class BinSums:
    """Per bin: the count ``n`` of poses, and per error of :data:`COMPONENTS` (columns) the
    sum ``total`` (m, m, rad) and the sum of squares ``squares`` (m², m², rad²)."""

    n: IntArray
    total: FloatArray
    squares: FloatArray

    @classmethod
    def of(cls, index: IntArray, errors: FloatArray, bins: int) -> BinSums:
        """The sums of ``errors`` (poses x 3) in the bins ``index`` (each in ``range(bins)``)."""
        idx = np.asarray(index, dtype=np.int64)
        n = np.bincount(idx, minlength=bins).astype(np.int64)
        e = np.asarray(errors, dtype=np.float64)
        total = np.stack([np.bincount(idx, weights=e[:, k], minlength=bins)
                          for k in range(len(COMPONENTS))], axis=1).astype(np.float64)
        squares = np.stack([np.bincount(idx, weights=e[:, k] ** 2, minlength=bins)
                            for k in range(len(COMPONENTS))], axis=1).astype(np.float64)
        return cls(n, total, squares)

    def merged(self, other: BinSums) -> BinSums:
        """Both sets of poses together (the same bins)."""
        if self.n.shape != other.n.shape:
            raise ValueError("sums of different bins cannot be merged")
        return BinSums(self.n + other.n, self.total + other.total,
                       self.squares + other.squares)

    def mean(self) -> FloatArray:
        """Mean (the bias) per bin and error (m, m, rad); NaN in an empty bin."""
        with np.errstate(invalid="ignore", divide="ignore"):
            out: FloatArray = np.where(self.n[:, None] > 0, self.total
                                       / np.maximum(self.n, 1)[:, None], np.nan)
        return out

    def rms(self) -> FloatArray:
        """Root mean square per bin and error (m, m, rad); NaN in an empty bin."""
        with np.errstate(invalid="ignore", divide="ignore"):
            out: FloatArray = np.where(self.n[:, None] > 0, np.sqrt(
                self.squares / np.maximum(self.n, 1)[:, None]), np.nan)
        return out


@dataclass(frozen=True)
class SegmentErrors:
    """One pose source's errors against one reference, binned: ``source`` (the estimator's
    name, or ``laser``), ``reference`` (``truth`` or the reference estimator's name) and per
    dimension of :data:`DIMENSIONS` its :class:`BinSums` (bins in :func:`bin_labels`'
    order)."""

    source: str
    reference: str
    bins: Mapping[str, BinSums]

    @property
    def poses(self) -> int:
        """Poses compared (each in one bin of every dimension)."""
        return int(self.bins["direction"].n.sum())

    def merged(self, other: SegmentErrors) -> SegmentErrors:
        """Both logs' poses together (the same source, reference and bins)."""
        if (self.source, self.reference) != (other.source, other.reference):
            raise ValueError("errors of different sources or references cannot be merged")
        return SegmentErrors(self.source, self.reference,
                             {d: self.bins[d].merged(other.bins[d]) for d in DIMENSIONS})


def _kinematics(ref: Trajectory, t: FloatArray, window: float
                ) -> tuple[FloatArray, FloatArray]:
    """The reference's signed speed along its heading (m/s) and yaw rate (rad/s) at ``t``
    (s): central differences over ``window`` s (clamped to the reference's span)."""
    lo = np.clip(t - 0.5 * window, ref.t[0], ref.t[-1])
    hi = np.clip(t + 0.5 * window, ref.t[0], ref.t[-1])
    a, b, mid = ref.interpolate(lo), ref.interpolate(hi), ref.interpolate(t)
    dt = hi - lo
    ok = dt > 0
    span = np.where(ok, dt, 1.0)
    c, s = np.cos(mid.heading), np.sin(mid.heading)
    speed = np.where(ok, ((b.x - a.x) * c + (b.y - a.y) * s) / span, 0.0)
    yaw = np.where(ok, wrap_angle(b.heading - a.heading) / span, 0.0)
    return speed, yaw


def _bin_index(value: FloatArray, width: float, bins: int) -> IntArray:
    """The bin of each (non-negative) ``value`` in bins ``width`` wide, the last open."""
    out: IntArray = np.minimum(np.floor(value / width), bins - 1).astype(np.int64)
    return out


def segment_errors(estimate: Trajectory, reference: Trajectory, *, source: str,
                   reference_name: str, settings: SegmentSettings) -> SegmentErrors | None:
    """The errors of ``estimate`` (poses of O: s, m, rad) against ``reference`` (the same
    point, the same clock) at the estimate's times inside the reference's span (not in its
    gaps: :meth:`Trajectory.sync`), binned (module doc); ``source`` and ``reference_name``
    name them (``truth``). None: no pose to compare (the reference has fewer than two poses
    or does not overlap the estimate)."""
    if len(reference) < 2 or len(estimate) == 0:
        return None
    est, ref = estimate.sync(reference)
    if len(est) == 0:
        return None
    s = settings
    speed, yaw = _kinematics(reference, est.t, s.velocity_window_s)
    moving = np.abs(speed) >= s.standstill_m_s
    reverse = moving & (speed < 0)
    travel = ref.heading + np.where(reverse, math.pi, 0.0)
    dx, dy = est.x - ref.x, est.y - ref.y
    c, sn = np.cos(travel), np.sin(travel)
    errors = np.stack([c * dx + sn * dy, -sn * dx + c * dy,
                       wrap_angle(est.heading - ref.heading)], axis=1)
    curvature = np.where(moving, np.abs(yaw) / np.maximum(np.abs(speed), 1e-12), 0.0)
    turn = moving & (curvature > s.turn_curvature_per_m)
    standstill_bin = np.int64(s.curvature_bins)
    index: dict[str, IntArray] = {
        "speed": _bin_index(np.abs(speed), s.speed_bin_m_s, s.speed_bins),
        "curvature": np.where(moving, _bin_index(curvature, s.curvature_bin_per_m,
                                                 s.curvature_bins), standstill_bin),
        "direction": np.where(moving, reverse.astype(np.int64), 2),
        "shape": np.where(moving, turn.astype(np.int64), 2),
    }
    return SegmentErrors(source, reference_name,
                         {d: BinSums.of(index[d], errors, len(bin_labels(d, s)))
                          for d in DIMENSIONS})


def log_segments(estimate: Trajectory, estimator: str, laser: Trajectory | None,
                 truth: Trajectory | None, settings: SegmentSettings
                 ) -> tuple[SegmentErrors, ...]:
    """One log's errors by segment: the replayed ``estimate`` (named ``estimator``) and the
    ``laser`` (the NAV's valid poses moved to O; None: none) against the ``truth`` (poses of
    O; None: the log has none), else the laser against the estimate (nothing when the
    estimate is the laser itself). All on one clock: s, m, rad. Empty: nothing to compare."""
    sources: list[tuple[str, Trajectory]] = [(estimator, estimate)]
    if laser is not None and estimator != "laser":
        sources.append(("laser", laser))
    if truth is not None:
        reference, name = truth, "truth"
    else:
        reference, name = estimate, estimator
        sources = sources[1:]
    found = (segment_errors(traj, reference, source=src, reference_name=name,
                            settings=settings) for src, traj in sources)
    return tuple(e for e in found if e is not None)


def pooled_segments(parts: Sequence[SegmentErrors]) -> list[SegmentErrors]:
    """The logs' errors pooled per (source, reference), in the order first met."""
    out: dict[tuple[str, str], SegmentErrors] = {}
    for p in parts:
        key = (p.source, p.reference)
        out[key] = out[key].merged(p) if key in out else p
    return list(out.values())


def _num(v: float, digits: int = 5) -> float | None:
    return round(v, digits) if math.isfinite(v) else None


def _stats(n: int, mean: FloatArray, rms: FloatArray) -> JSONObject:
    """One bin's entry: count and {rms, mean} of each error."""
    out: JSONObject = {"count": n}
    for k, name in enumerate(COMPONENTS):
        digits = 6 if name == "heading" else 5
        out[name] = {"rms": _num(float(rms[k]), digits), "mean": _num(float(mean[k]), digits)}
    return out


def _source_section(e: SegmentErrors, s: SegmentSettings) -> JSONObject:
    """One source's part of ``segments``: overall figures and the bins of every dimension."""
    d0 = e.bins["direction"]
    overall = BinSums(np.array([d0.n.sum()]), d0.total.sum(axis=0, keepdims=True),
                      d0.squares.sum(axis=0, keepdims=True))
    out: JSONObject = {"source": e.source, "reference": e.reference, "poses": e.poses,
                       "overall": _stats(int(overall.n[0]), overall.mean()[0],
                                         overall.rms()[0])}
    for dim in DIMENSIONS:
        b = e.bins[dim]
        mean, rms = b.mean(), b.rms()
        rows: list[JSON] = []
        for i, label in enumerate(bin_labels(dim, s)):
            rows.append({"bin": label, **_stats(int(b.n[i]), mean[i], rms[i])})
        out[dim] = rows
    return out


def segments_section(parts: Sequence[SegmentErrors], without_reference: Sequence[str],
                     settings: SegmentSettings) -> JSONObject:
    """``audit.json``'s ``segments``: ``reference`` (``truth``, the reference estimator's
    name, or several comma-separated when the logs differ; null: none), ``frame`` (how along
    and cross are measured), ``units``, ``sources`` (per pose source and reference, pooled
    over the logs: poses, overall and per bin of every dimension count, and rms and mean of
    along, cross, heading), ``without_reference`` (the logs that had nothing to compare) and
    the settings."""
    from lgvtool.declared import as_dict

    pooled = pooled_segments(parts)
    refs = list(dict.fromkeys(p.reference for p in pooled))
    return {
        "reference": ", ".join(refs) if refs else None,
        "frame": FRAME,
        "units": {"along": "m", "cross": "m", "heading": "rad", "speed": "m/s",
                  "curvature": "1/m"},
        "sources": [_source_section(p, settings) for p in pooled],
        "without_reference": list(without_reference),
        "settings": as_dict(settings),
    }


def _mm(v: JSON) -> str:
    """A length in m shown in mm (one decimal), or ``-``."""
    return f"{v * 1000:.1f}" if isinstance(v, int | float) else "-"


def summary_line(section: JSONObject) -> str | None:
    """The text summary's line of a ``segments`` section: per source the overall RMS (and
    mean) of along and cross (mm) and heading (deg), against which reference; None when
    nothing was compared."""
    sources = section.get("sources")
    if not isinstance(sources, list) or not sources:
        return None
    parts = []
    for src in sources:
        if not isinstance(src, dict):
            continue
        ov = src.get("overall")
        if not isinstance(ov, dict):
            continue
        figs = []
        for name in COMPONENTS:
            c = ov.get(name)
            rms = c.get("rms") if isinstance(c, dict) else None
            mean = c.get("mean") if isinstance(c, dict) else None
            if name == "heading":
                figs.append("heading " + (f"{math.degrees(rms):.2f}" if isinstance(
                    rms, int | float) else "-") + " deg")
            else:
                figs.append(f"{name} {_mm(rms)} mm (mean {_mm(mean)})")
        parts.append(f"{src.get('source')} vs {src.get('reference')}: {', '.join(figs)} rms")
    return "error by segment: " + "; ".join(parts) if parts else None
