"""Clean one MRCLAM robot recording and detect the dataset's quirks (pure: no I/O).

What is done to the data (docs/mrclam.md has the reasoning):

- times become integer ns since the Unix epoch, rounded to the microsecond (the files give ms);
- rows are put into time order (a stable sort; rows that were out of order are counted);
- repeated stamps: of rows sharing a stamp (odometry, ground truth) or a stamp and a barcode
  (measurements), the last one is kept; identical and differing repeats are counted apart;
- measurements of robots (subjects 1-5) and of barcodes without a landmark are dropped and
  counted; non-positive ranges are dropped as invalid;
- range and bearing outliers are *flagged, not dropped*: each landmark observation is compared
  with the range and bearing predicted from the ground truth and the landmark map; the counts and
  times go to the report, the observations stay in the log for the estimators to gate (dropping
  them by the ground truth would hand the estimators information they must not have);
- gaps in odometry and ground truth longer than a threshold, and ground truth that starts late or
  ends early relative to the sensor data, are measured and reported;
- the odometry (commanded velocities) is moved to when the robot carries it out: its stamps are
  delayed by ``odometry_delay_s``, by default the delay measured from the camera alone
  (:mod:`lgvtool.importers.mrclam_timing`), so that motion and camera agree in time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, TypedDict

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.config import Area
from lgvtool.importers.mrclam import ROBOT_SUBJECTS, FileInfo, MrclamDataset, RobotRecording
from lgvtool.importers.mrclam_timing import delay_ns, odometry_delay
from lgvtool.timestamps import seconds_to_ns_array

NS = 1_000_000_000
_LIST_MAX = 20
"""Most items listed in a quirk's details (times, gaps)."""


class OdometryTiming(TypedDict):
    """The odometry delay applied (s) and how it was found: the delay the camera shows (s;
    None when it shows none), the observation pairs used, the bearing residuals without and
    with that delay (rad RMS; None without pairs), and the method."""

    odometry_delay_s: float
    measured_delay_s: float | None
    pairs: int
    bearing_rms_without_delay_rad: float | None
    bearing_rms_with_delay_rad: float | None
    method: str


@dataclass(frozen=True)
class ImportSettings:
    """Thresholds and constants of the import (each with its unit)."""

    gap_threshold_s: float = 0.5
    """A step between consecutive odometry or ground-truth stamps longer than this is a gap, s."""
    outlier_range_fraction: float = 0.25
    """Range outlier: |measured - predicted range| above this fraction of the predicted range."""
    outlier_bearing_rad: float = 0.35
    """Bearing outlier: |measured - predicted bearing| above this, rad (about 20 deg)."""
    truth_interp_max_gap_s: float = 0.5
    """Outlier checks use ground truth only between samples at most this far apart, s."""
    truth_tolerance_s: float = 1.0
    """Ground truth starting later or ending earlier than the sensor data by more than this is
    reported, s."""
    landmark_radius_m: float = 0.05
    """Radius given to every landmark in the map, m (see docs/mrclam.md)."""
    area_margin_m: float = 1.5
    """Margin added around the landmark bounding box to form the work area, m."""
    odometry_delay_s: float | None = None
    """How long after its stamp a commanded velocity takes effect, s: the odometry messages are
    written this much later than the file's stamps. None measures it per robot from the camera
    without ground truth (:func:`lgvtool.importers.mrclam_timing.odometry_delay`; 0 when there
    are too few landmark sightings to tell); 0 keeps the file's stamps."""


@dataclass(frozen=True)
class Quirk:
    """One kind of dataset quirk found in a recording: becomes one /diagnostics event."""

    kind: str
    """Machine-readable kind, e.g. 'odometry_gap'."""
    count: int
    """Occurrences."""
    time_ns: int
    """Time of the first occurrence, ns since the Unix epoch."""
    message: str
    """One human-readable sentence."""
    level: int = 3
    """Severity as foxglove.Log: 2 info, 3 warning."""
    details: dict[str, Any] = field(default_factory=dict)
    """Kind-specific JSON-able facts, units in the key names."""


@dataclass(frozen=True)
class PreparedRun:
    """A robot's recording cleaned, in time order, ready to be written as a log."""

    robot: int
    """Robot (subject) number."""
    odometry: pd.DataFrame
    """t_ns (int64), v (m/s), omega (rad/s); t_ns strictly increasing."""
    truth: pd.DataFrame
    """t_ns, x (m), y (m), theta (rad); t_ns strictly increasing."""
    observations: pd.DataFrame
    """t_ns, landmark (subject number), range (m), bearing (rad), range_outlier (bool),
    bearing_outlier (bool); t_ns non-decreasing, file order within a stamp."""
    quirks: tuple[Quirk, ...]
    """The quirks found, one per kind, in order of first occurrence."""
    counts: dict[str, int]
    """Row and message counts (keys listed in docs/mrclam.md)."""
    camera: dict[str, float]
    """Sensor geometry: x_m, y_m (camera at the robot centre) and, measured from the landmark
    observations kept, bearing_min_rad, bearing_max_rad, fov_rad (max - min bearing), fov_deg,
    half_fov_rad (largest absolute bearing), range_min_m, range_max_m."""
    residuals: dict[str, float | int | None]
    """Observation residuals against ground truth (outliers excluded), for reference: medians
    and robust standard deviations in m and rad (None without data), observations compared."""
    area: Area
    """The landmark bounding box plus ``settings.area_margin_m``, m."""
    timing: OdometryTiming
    """The odometry delay: ``odometry_delay_s`` (applied, s), ``measured_delay_s`` (what the
    camera shows, s, None when not measured), ``pairs`` (landmark sightings compared),
    ``bearing_rms_without_delay_rad`` and ``bearing_rms_with_delay_rad`` (residual of the
    bearing changes predicted from the commands, rad), ``method``."""
    files: tuple[FileInfo, ...]
    """The robot's three files."""
    settings: ImportSettings
    """The settings used."""

    @property
    def start_ns(self) -> int:
        """Earliest stamp of any stream, ns."""
        firsts = [int(df["t_ns"].iloc[0]) for df in self._streams() if len(df)]
        return min(firsts)

    @property
    def end_ns(self) -> int:
        """Latest stamp of any stream, ns."""
        lasts = [int(df["t_ns"].iloc[-1]) for df in self._streams() if len(df)]
        return max(lasts)

    def _streams(self) -> tuple[pd.DataFrame, ...]:
        return (self.odometry, self.truth, self.observations)


def area_of(dataset: MrclamDataset, margin: float) -> Area:
    """The landmarks' bounding box grown by ``margin`` m on every side."""
    lm = dataset.landmarks
    return Area(x_min=float(lm["x"].min()) - margin, x_max=float(lm["x"].max()) + margin,
                y_min=float(lm["y"].min()) - margin, y_max=float(lm["y"].max()) + margin)


def _s(ns: int | np.integer) -> float:
    return round(int(ns) / NS, 6)


def _n(count: int, noun: str, plural: str | None = None) -> str:
    """'1 row', '3 rows'."""
    return f"{count} {noun if count == 1 else plural or noun + 's'}"


class _Collector:
    """Gathers quirks and counts while a run is prepared."""

    def __init__(self) -> None:
        self.quirks: list[Quirk] = []
        self.counts: dict[str, int] = {}

    def add(self, kind: str, count: int, time_ns: int, message: str, *, level: int = 3,
            **details: object) -> None:
        """Record a quirk of ``kind`` (nothing when ``count`` is 0); details: JSON-able."""
        if count > 0:
            self.quirks.append(Quirk(kind, int(count), int(time_ns), message, level, details))


def _order(df: pd.DataFrame) -> tuple[pd.DataFrame, int, int]:
    """Stable sort by t_ns; how many rows were out of order and the first such stamp."""
    t = df["t_ns"].to_numpy()
    if len(t) < 2:
        return df, 0, 0
    late = t[1:] < np.maximum.accumulate(t)[:-1]
    n = int(late.sum())
    if n == 0:
        return df, 0, 0
    first = int(t[1:][late].min())
    return df.sort_values("t_ns", kind="stable").reset_index(drop=True), n, first


def _dedupe(df: pd.DataFrame, keys: list[str]) -> tuple[pd.DataFrame, int, int, int]:
    """Keep the last row of each key; counts of identical and differing repeats, first stamp."""
    identical = df.duplicated(keep="last")
    kept = df[~identical]
    differing = kept.duplicated(subset=keys, keep="last")
    out = kept[~differing].reset_index(drop=True)
    dropped = pd.concat([df["t_ns"][identical], kept["t_ns"][differing]])
    first = int(dropped.min()) if len(dropped) else 0
    return out, int(identical.sum()), int(differing.sum()), first


class _GapFigures(TypedDict, total=False):
    """The figures of gaps found (times in s since the Unix epoch, steps in s)."""

    first_ns: int
    threshold_s: float
    max_gap_s: float
    max_gap_at_s: float
    total_gap_s: float
    gaps_s: list[list[float]]
    max_step_s: float


class Gaps(_GapFigures):
    """What :func:`_gaps` finds: how many gaps, and (when there are steps) their figures:
    the first gap's start (ns), the threshold, the longest gap and when it began, their total,
    the first few (start, length) and the longest step when there is no gap (s)."""

    count: int


def _gaps(t_ns: NDArray[np.int64], threshold_s: float) -> Gaps:
    """Gaps (steps longer than ``threshold_s``) in a strictly increasing stamp array."""
    if len(t_ns) < 2:
        return {"count": 0}
    dt = np.diff(t_ns)
    idx = np.flatnonzero(dt > threshold_s * NS)
    if len(idx) == 0:
        return {"count": 0, "max_step_s": _s(dt.max())}
    longest = idx[np.argmax(dt[idx])]
    return {
        "count": len(idx), "first_ns": int(t_ns[idx[0]]),
        "threshold_s": threshold_s, "max_gap_s": _s(dt[longest]),
        "max_gap_at_s": _s(t_ns[longest]), "total_gap_s": _s(dt[idx].sum()),
        "gaps_s": [[_s(t_ns[i]), _s(dt[i])] for i in idx[:_LIST_MAX]],
    }


def _clean_stream(df: pd.DataFrame, keys: list[str]) -> tuple[pd.DataFrame, dict[str, int]]:
    """Time order and repeated stamps of one stream; the counts and first stamps of each."""
    df, late, late_first = _order(df)
    df, same, differ, rep_first = _dedupe(df, keys)
    return df, {"out_of_order": late, "out_of_order_first_ns": late_first,
                "repeated_identical": same, "repeated_differing": differ,
                "repeated_first_ns": rep_first}


def _predicted(truth: pd.DataFrame, obs: pd.DataFrame, dataset: MrclamDataset,
               max_gap_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Range (m) and bearing (rad) of each observation predicted from ground truth and the map,
    and a mask of the observations that ground truth covers."""
    tt = truth["t_ns"].to_numpy()
    to = obs["t_ns"].to_numpy()
    n = len(to)
    if len(tt) < 2 or n == 0:
        return np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, dtype=bool)
    j = np.clip(np.searchsorted(tt, to, side="right"), 1, len(tt) - 1)
    covered = (to >= tt[0]) & (to <= tt[-1]) & ((tt[j] - tt[j - 1]) <= max_gap_s * NS)
    ref = tt[0]
    ts = (tt - ref) / NS
    os_ = (to - ref) / NS
    x = np.interp(os_, ts, truth["x"].to_numpy())
    y = np.interp(os_, ts, truth["y"].to_numpy())
    th = np.interp(os_, ts, np.unwrap(truth["theta"].to_numpy()))
    lm = dataset.landmarks.set_index("subject")
    lx = lm["x"].reindex(obs["landmark"]).to_numpy()
    ly = lm["y"].reindex(obs["landmark"]).to_numpy()
    rng = np.hypot(lx - x, ly - y)
    brg = wrap_angle(np.arctan2(ly - y, lx - x) - th)
    return rng, brg, covered


def _median(a: np.ndarray) -> float | None:
    """Median rounded to 1e-6, None for no data."""
    return round(float(np.median(a)), 6) if len(a) else None


def _robust_sd(a: np.ndarray) -> float | None:
    """1.4826 x median absolute deviation, rounded to 1e-6; None for no data."""
    if len(a) == 0:
        return None
    return round(float(1.4826 * np.median(np.abs(a - np.median(a)))), 6)


def _stream_quirks(col: _Collector, stats: dict[str, dict[str, int]]) -> None:
    late = {k: v["out_of_order"] for k, v in stats.items() if v["out_of_order"]}
    if late:
        first = min(stats[k]["out_of_order_first_ns"] for k in late)
        col.add("out_of_order_rows", sum(late.values()), first,
                f"{_n(sum(late.values()), 'row')} out of time order, sorted "
                f"({', '.join(f'{k} {v}' for k, v in late.items())})", rows=late)
    rep = {k: {"identical": v["repeated_identical"], "differing": v["repeated_differing"]}
           for k, v in stats.items() if v["repeated_identical"] + v["repeated_differing"]}
    if rep:
        total = sum(r["identical"] + r["differing"] for r in rep.values())
        first = min(stats[k]["repeated_first_ns"] for k in rep)
        parts = ", ".join(f"{k} {r['identical']} identical + {r['differing']} differing"
                          for k, r in rep.items())
        col.add("repeated_stamp", total, first,
                f"{_n(total, 'row')} repeating a time stamp dropped, the last row of each "
                f"stamp kept ({parts})", rows=rep)


def _gap_quirk(col: _Collector, kind: str, what: str, gaps: Gaps, start_ns: int,
               note: str = "") -> None:
    if gaps["count"]:
        into = gaps["max_gap_at_s"] - start_ns / NS
        col.add(kind, gaps["count"], gaps["first_ns"],
                f"{_n(gaps['count'], what + ' gap')} longer than {gaps['threshold_s']} s, the "
                f"longest {gaps['max_gap_s']:.3f} s at {into:.1f} s into the run{note}", level=3,
                **{k: v for k, v in gaps.items() if k not in ("count", "first_ns")})


def _classify(meas: pd.DataFrame, dataset: MrclamDataset, col: _Collector) -> pd.DataFrame:
    """Map barcodes to landmark subjects; drop robots, unknown barcodes and invalid ranges."""
    subject = meas["barcode"].map(dataset.subject_of_barcode())
    is_robot = subject.isin(list(ROBOT_SUBJECTS)).to_numpy()
    is_landmark = subject.isin(dataset.landmarks["subject"].tolist()).to_numpy()
    unknown = ~is_robot & ~is_landmark
    invalid = is_landmark & ~(meas["range"].to_numpy() > 0)
    t = meas["t_ns"].to_numpy()
    if is_robot.any():
        by = subject[is_robot].astype(int).value_counts().sort_index()
        col.add("robot_sighting", int(is_robot.sum()), int(t[is_robot].min()),
                f"{_n(int(is_robot.sum()), 'sighting')} of other robots dropped (subjects "
                f"{', '.join(str(s) for s in by.index)})", level=2,
                by_subject={str(k): int(v) for k, v in by.items()})
    if unknown.any():
        codes = meas["barcode"][unknown].value_counts().sort_index()
        col.add("unknown_barcode", int(unknown.sum()), int(t[unknown].min()),
                f"{_n(int(unknown.sum()), 'measurement')} of a barcode that is no landmark "
                f"dropped (barcodes {', '.join(str(c) for c in codes.index)})",
                by_barcode={str(k): int(v) for k, v in codes.items()})
    if invalid.any():
        col.add("invalid_range", int(invalid.sum()), int(t[invalid].min()),
                f"{_n(int(invalid.sum()), 'landmark measurement')} with a range <= 0 dropped")
    col.counts.update(robot_sightings=int(is_robot.sum()), unknown_barcodes=int(unknown.sum()),
                      invalid_ranges=int(invalid.sum()))
    keep = is_landmark & ~invalid
    out = pd.DataFrame({
        "t_ns": t[keep], "landmark": subject[keep].astype(np.int64).to_numpy(),
        "range": meas["range"].to_numpy()[keep], "bearing": meas["bearing"].to_numpy()[keep],
    })
    stamps_all = np.unique(t)
    col.counts["stamps_without_landmarks"] = int(len(stamps_all) - len(np.unique(t[keep])))
    return out


def _outliers(obs: pd.DataFrame, truth: pd.DataFrame, dataset: MrclamDataset,
              settings: ImportSettings, col: _Collector
              ) -> tuple[pd.DataFrame, dict[str, float | int | None]]:
    """Flag observations inconsistent with ground truth; residual statistics of the rest."""
    rng, brg, covered = _predicted(truth, obs, dataset, settings.truth_interp_max_gap_s)
    dr = obs["range"].to_numpy() - rng
    db = wrap_angle(obs["bearing"].to_numpy() - brg)
    with np.errstate(invalid="ignore"):
        r_out = covered & (np.abs(dr) > settings.outlier_range_fraction * rng)
        b_out = covered & (np.abs(db) > settings.outlier_bearing_rad)
    obs = obs.assign(range_outlier=r_out, bearing_outlier=b_out)
    t = obs["t_ns"].to_numpy()
    col.counts.update(outliers_checked=int(covered.sum()),
                      outliers_unchecked=int((~covered).sum()),
                      range_outliers=int(r_out.sum()), bearing_outliers=int(b_out.sum()))
    for kind, mask, err, unit, limit in (
        ("range_outlier", r_out, dr, "m",
         f"{settings.outlier_range_fraction:.0%} of the predicted range"),
        ("bearing_outlier", b_out, db, "rad", f"{settings.outlier_bearing_rad} rad"),
    ):
        if mask.any():
            n = int(mask.sum())
            details: dict[str, Any] = {
                "times_s": [_s(v) for v in t[mask][:_LIST_MAX]],
                "landmarks": [int(v) for v in obs["landmark"].to_numpy()[mask][:_LIST_MAX]],
                f"max_abs_error_{unit}": round(float(np.abs(err[mask]).max()), 6),
                "checked": int(covered.sum()), "unchecked": int((~covered).sum()),
            }
            col.add(kind, n, int(t[mask].min()),
                    f"{_n(n, 'landmark observation')} off the ground-truth prediction by more "
                    f"than {limit} (kept in the log: estimators must gate them)", **details)
    good = covered & ~r_out & ~b_out
    residuals: dict[str, float | int | None] = {
        "range_median_m": _median(dr[good]), "range_sd_robust_m": _robust_sd(dr[good]),
        "bearing_median_rad": _median(db[good]), "bearing_sd_robust_rad": _robust_sd(db[good]),
        "observations": int(good.sum()),
    }
    return obs, residuals


def _truth_coverage(truth: pd.DataFrame, odo: pd.DataFrame, obs: pd.DataFrame,
                    settings: ImportSettings, col: _Collector) -> None:
    starts = [int(df["t_ns"].iloc[0]) for df in (odo, obs) if len(df)]
    ends = [int(df["t_ns"].iloc[-1]) for df in (odo, obs) if len(df)]
    if not len(truth) or not starts:
        return
    t0, t1 = int(truth["t_ns"].iloc[0]), int(truth["t_ns"].iloc[-1])
    tol = settings.truth_tolerance_s * NS
    late = t0 - min(starts)
    if late > tol:
        n_odo = int((odo["t_ns"] < t0).sum())
        n_obs = int((obs["t_ns"] < t0).sum())
        col.add("truth_starts_late", 1, min(starts),
                f"ground truth starts {late / NS:.1f} s after the sensor data ({n_odo} odometry "
                f"rows and {n_obs} observations before it)", truth_start_s=_s(t0),
                sensors_start_s=_s(min(starts)), uncovered_s=_s(late),
                odometry_rows_before=n_odo, observations_before=n_obs)
    early = max(ends) - t1
    if early > tol:
        n_odo = int((odo["t_ns"] > t1).sum())
        n_obs = int((obs["t_ns"] > t1).sum())
        col.add("truth_ends_early", 1, t1,
                f"ground truth ends {early / NS:.1f} s before the sensor data ({n_odo} odometry "
                f"rows and {n_obs} observations after it)", truth_end_s=_s(t1),
                sensors_end_s=_s(max(ends)), uncovered_s=_s(early),
                odometry_rows_after=n_odo, observations_after=n_obs)


def _camera(obs: pd.DataFrame) -> dict[str, float]:
    if not len(obs):
        return {}
    b = obs["bearing"].to_numpy()
    r = obs["range"].to_numpy()
    return {"x_m": 0.0, "y_m": 0.0, "bearing_min_rad": round(float(b.min()), 6),
            "bearing_max_rad": round(float(b.max()), 6),
            "fov_rad": round(float(b.max() - b.min()), 6),
            "fov_deg": round(float(np.degrees(b.max() - b.min())), 3),
            "half_fov_rad": round(float(np.abs(b).max()), 6),
            "range_min_m": round(float(r.min()), 6), "range_max_m": round(float(r.max()), 6)}


def prepare_run(dataset: MrclamDataset, rec: RobotRecording,
                settings: ImportSettings | None = None) -> PreparedRun:
    """Clean ``rec`` (time order, repeated stamps, dropped sightings), detect its quirks and
    measure the camera's field of view and range limits. Pure: reads and writes no file."""
    st = settings or ImportSettings()
    col = _Collector()
    broken = {f.name: f.broken for f in rec.files if f.broken}
    odo = rec.odometry.assign(t_ns=seconds_to_ns_array(rec.odometry["t"].to_numpy(), 1000))
    tru = rec.truth.assign(t_ns=seconds_to_ns_array(rec.truth["t"].to_numpy(), 1000))
    meas = rec.measurements.assign(t_ns=seconds_to_ns_array(rec.measurements["t"].to_numpy(), 1000))
    odo = odo[["t_ns", "v", "omega"]]
    tru = tru[["t_ns", "x", "y", "theta"]]
    meas = meas[["t_ns", "barcode", "range", "bearing"]]
    stats: dict[str, dict[str, int]] = {}
    odo, stats["odometry"] = _clean_stream(odo, ["t_ns"])
    tru, stats["truth"] = _clean_stream(tru, ["t_ns"])
    meas, stats["measurement"] = _clean_stream(meas, ["t_ns", "barcode"])
    first_ns = min(int(df["t_ns"].iloc[0]) for df in (odo, tru, meas) if len(df))
    if broken:
        col.add("broken_rows", sum(broken.values()), first_ns,
                f"{_n(sum(broken.values()), 'broken row')} skipped "
                f"({', '.join(f'{k} {v}' for k, v in broken.items())})",
                rows=broken, lines={f.name: list(f.broken_lines[:_LIST_MAX])
                                    for f in rec.files if f.broken})
    _stream_quirks(col, stats)
    obs = _classify(meas, dataset, col)
    odo_gaps = _gaps(odo["t_ns"].to_numpy(), st.gap_threshold_s)
    tru_gaps = _gaps(tru["t_ns"].to_numpy(), st.gap_threshold_s)
    _gap_quirk(col, "odometry_gap", "odometry", odo_gaps, first_ns,
               "; the last commanded velocity holds across a gap")
    _gap_quirk(col, "truth_gap", "ground-truth", tru_gaps, first_ns)
    _truth_coverage(tru, odo, obs, st, col)
    obs, residuals = _outliers(obs, tru, dataset, st, col)
    area = area_of(dataset, st.area_margin_m)
    outside = ((tru["x"] < area.x_min) | (tru["x"] > area.x_max) | (tru["y"] < area.y_min)
               | (tru["y"] > area.y_max))
    col.counts.update(
        odometry_rows=len(rec.odometry), truth_rows=len(rec.truth),
        measurement_rows=len(rec.measurements), odometry=len(odo), truth=len(tru),
        landmark_observations=len(obs), scans=int(obs["t_ns"].nunique()),
        broken_rows=sum(broken.values()),
        out_of_order_rows=sum(v["out_of_order"] for v in stats.values()),
        repeated_stamps=sum(v["repeated_identical"] + v["repeated_differing"]
                            for v in stats.values()),
        odometry_gaps=odo_gaps["count"], truth_gaps=tru_gaps["count"],
        truth_outside_area=int(outside.sum()),
    )
    quirks = tuple(sorted(col.quirks, key=lambda q: q.time_ns))
    timing = _timing(odo, obs, st.odometry_delay_s)
    odo = odo.assign(t_ns=odo["t_ns"].to_numpy() + delay_ns(timing["odometry_delay_s"]))
    return PreparedRun(robot=rec.robot, odometry=odo, truth=tru, observations=obs,
                       quirks=quirks, counts=col.counts, camera=_camera(obs),
                       residuals=residuals, area=area, timing=timing, files=rec.files,
                       settings=st)


def _timing(odo: pd.DataFrame, obs: pd.DataFrame, delay_s: float | None) -> OdometryTiming:
    """The odometry delay to apply: ``delay_s`` if given, else the one the camera shows
    (:func:`odometry_delay` on the landmark observations; no ground truth involved)."""
    est = odometry_delay(odo["t_ns"].to_numpy() * 1e-9, odo["v"].to_numpy(),
                         odo["omega"].to_numpy(), obs["t_ns"].to_numpy() * 1e-9,
                         obs["landmark"].to_numpy(), obs["range"].to_numpy(),
                         obs["bearing"].to_numpy())
    measured = est.delay_s if est.rms_rad is not None else None
    applied = float(delay_s) if delay_s is not None else (measured or 0.0)
    return {
        "odometry_delay_s": applied,
        "measured_delay_s": measured,
        "pairs": est.pairs,
        "bearing_rms_without_delay_rad": est.rms_at_zero_rad,
        "bearing_rms_with_delay_rad": est.rms_rad,
        "method": "given" if delay_s is not None else "measured from the camera",
    }
