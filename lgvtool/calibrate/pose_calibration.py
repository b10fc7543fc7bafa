"""The pose observation model of a log's NAV poses, estimated for ``lgvtool calibrate``.

A rotating-head NAV reports each pose late (its age) and skewed by its own turning (the lever
``(s_x, s_y)``), with a noise at standstill (docs/filter.md, "The pose observation model").
Replay fits the age and the lever on every log it replays; :func:`estimate_pose_model` fits
them once, by the same fits (:func:`lgvtool.localize.pose_model.fit_pose_model`), on the
calibration's logs with the calibrated installation applied (what a replay with the written
configuration sees), pools them over the logs, and adds the noise at standstill (the scatter
of the poses while the vehicle stood still, :func:`lgvtool.localize.pose_model.standstill_noise`).
:func:`pose_model_settings` turns what the logs determined into the estimators' settings, so
that replay and the live view use them as stated instead of fitting them again.

Pure: log data in, values out. Units: s, m, rad.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from lgvtool.config import Vehicle
from lgvtool.json_types import JSON, JSONObject
from lgvtool.localize.installation import apply_installation
from lgvtool.localize.logdata import LogData
from lgvtool.localize.motion import MotionSettings, MotionTrack
from lgvtool.localize.pose_model import (
    AGE_MAX_SIGMA_S,
    SKEW_MAX_SIGMA_M,
    PoseFit,
    PoseModelParams,
    StandstillNoise,
    fit_pose_model,
    latency_for,
    standstill_noise,
    vehicle_states_age,
)

AGE_UNDETERMINED = ("only changes of the turn rate and of the speed determine it: on a steady "
                    "circle a late pose looks like a turned frame")
"""Why an age is not determined, said once (the table, the JSON, the warnings)."""
SKEW_UNDETERMINED = "it needs turning, at more than one heading"
NOISE_UNDETERMINED = "no standstill long enough (2 s, with at least 10 poses in all)"


@dataclass(frozen=True)
class LogPoseModel:
    """One log's fits: the age and lever (:class:`PoseFit`, on the installation's corrected
    poses) and the noise at standstill."""

    name: str
    fit: PoseFit
    noise: StandstillNoise
    poses: int


@dataclass(frozen=True)
class PooledValue:
    """A value pooled over the logs that determine it (SI), with its 1-sigma; NaN when none
    does (``why`` then says what the drives lack)."""

    value: float
    sigma: float
    determined: bool
    why: str = ""


@dataclass(frozen=True)
class PoseModelEstimate:
    """The pose model the calibration's logs determine.

    ``age``: the poses' age beyond what the calibrated vehicle already states
    (``nav_time_offset + nav_pose_age``, :attr:`stated_age_s`), s; the whole age of a pose is
    their sum (:attr:`total_age_s`). ``skew_x``, ``skew_y``: the lever in the head frame, m.
    ``sigma_xy``, ``sigma_heading``: the noise at standstill, m and rad.
    """

    age: PooledValue
    skew_x: PooledValue
    skew_y: PooledValue
    sigma_xy: PooledValue
    sigma_heading: PooledValue
    stated_age_s: float
    configured_age: bool
    period_s: float
    logs: tuple[LogPoseModel, ...]

    @property
    def total_age_s(self) -> float:
        """Receive time minus the pose's reference instant on the motion data's clock, s."""
        return self.stated_age_s + self.age.value

    def settings(self, start_xy_m: float = 0.0, start_heading_rad: float = 0.0
                 ) -> dict[str, object]:
        """The pose-model settings of an estimator that make replay and the live view use what
        the logs determined instead of fitting it again: the age as ``pose_latency_s`` with
        ``pose_age_fit = false``, the lever with ``pose_skew_fit = false``, and the noise at
        standstill where it exceeds the estimator's own (``start_xy_m`` m,
        ``start_heading_rad`` rad): the scatter at standstill is a lower bound of the noise,
        since an error that stays while the vehicle stands (a reflector surveyed off, a range
        offset) does not scatter there, yet changes as it drives. An age below what the
        vehicle states already is held at it (0 s more)."""
        out: dict[str, object] = {}
        if self.age.determined:
            out["pose_age_fit"] = False
            out["pose_latency_s"] = max(0.0, latency_for(self.age.value, self.period_s,
                                                         self.configured_age))
        if self.skew_x.determined and self.skew_y.determined:
            out["pose_skew_fit"] = False
            out["pose_skew_x_m"] = self.skew_x.value
            out["pose_skew_y_m"] = self.skew_y.value
        if self.sigma_xy.determined and self.sigma_xy.value > start_xy_m:
            out["sigma_pose_xy_m"] = max(self.sigma_xy.value, 1e-6)
        if self.sigma_heading.determined and self.sigma_heading.value > start_heading_rad:
            out["sigma_pose_heading_rad"] = max(self.sigma_heading.value, 1e-9)
        return out

    def warnings(self) -> list[str]:
        """What the logs did not determine, one line each."""
        out = []
        if not self.age.determined:
            out.append(f"pose model: the pose age is not determined ({self.age.why}): replay "
                       f"fits it on each log, else uses pose_latency_s")
        if not (self.skew_x.determined and self.skew_y.determined):
            out.append(f"pose model: the skew lever is not determined ({self.skew_x.why})")
        if self.age.determined and self.age.value < -2.0 * self.age.sigma:
            out.append(f"pose model: the poses are {-self.age.value * 1e3:.1f} ms younger than "
                       f"the vehicle's nav_time_offset + nav_pose_age state "
                       f"(1-sigma {self.age.sigma * 1e3:.1f} ms): held at those")
        return out

    def to_dict(self) -> JSONObject:
        """JSON-ready: every value in SI with its 1-sigma and whether it is determined, the
        settings written, and each log's own fits."""
        def pooled(v: PooledValue) -> JSONObject:
            return {"value": _finite(v.value), "sigma": _finite(v.sigma),
                    "determined": v.determined, "why": v.why or None}

        per_log: list[JSON] = []
        for lg in self.logs:
            per_log.append({
                "path": lg.name, "poses": lg.poses,
                "age_s": _finite(lg.fit.age_s) if lg.fit.age_fitted else None,
                "age_sigma_s": _finite(lg.fit.age_sigma_s if lg.fit.age_fitted
                                       else lg.fit.age_tried_sigma_s),
                "skew_x_m": _finite(lg.fit.skew_x_m) if lg.fit.skew_fitted else None,
                "skew_y_m": _finite(lg.fit.skew_y_m) if lg.fit.skew_fitted else None,
                "skew_sigma_m": _finite(lg.fit.skew_sigma_m if lg.fit.skew_fitted
                                        else lg.fit.skew_tried_sigma_m),
                "standstill_poses": lg.noise.poses, "standstills": lg.noise.standstills,
                "standstill_s": lg.noise.duration_s})
        return {"age_s": pooled(self.age), "stated_age_s": self.stated_age_s,
                "total_age_s": _finite(self.total_age_s) if self.age.determined else None,
                "skew_x_m": pooled(self.skew_x), "skew_y_m": pooled(self.skew_y),
                "sigma_pose_xy_m": pooled(self.sigma_xy),
                "sigma_pose_heading_rad": pooled(self.sigma_heading),
                "logs": per_log}


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


def pooled_mean(values: Sequence[float], sigmas: Sequence[float], why: str) -> PooledValue:
    """The inverse-variance mean of ``values`` with their 1-sigmas ``sigmas`` (same unit);
    with several, its 1-sigma grows by the Birge ratio ``sqrt(chi2 / (n - 1))`` when they
    disagree by more than their 1-sigmas allow. None given: not determined, for ``why``."""
    if not values:
        return PooledValue(math.nan, math.nan, False, why)
    v, s = np.asarray(values, dtype=np.float64), np.asarray(sigmas, dtype=np.float64)
    w = 1.0 / np.maximum(s, 1e-12) ** 2
    mean = float(np.sum(w * v) / np.sum(w))
    sigma = math.sqrt(1.0 / float(np.sum(w)))
    if len(v) > 1:
        chi2 = float(np.sum(w * (v - mean) ** 2))
        sigma *= max(1.0, math.sqrt(chi2 / (len(v) - 1)))
    return PooledValue(mean, sigma, True)


def _pooled_noise(noises: Sequence[StandstillNoise]) -> tuple[PooledValue, PooledValue]:
    """The noise at standstill pooled over the logs (variances weighted by their degrees of
    freedom): position (m) and heading (rad)."""
    usable = [n for n in noises if math.isfinite(n.sigma_xy_m)]
    dof = [n.poses - n.standstills for n in usable]
    total = sum(dof)
    if not usable or total < 10:
        none = PooledValue(math.nan, math.nan, False, NOISE_UNDETERMINED)
        return none, none
    sxy = math.sqrt(sum(k * n.sigma_xy_m ** 2 for k, n in zip(dof, usable, strict=True)) / total)
    sh = math.sqrt(sum(k * n.sigma_heading_rad ** 2 for k, n in zip(dof, usable, strict=True))
                   / total)
    return (PooledValue(sxy, sxy / math.sqrt(4.0 * total), True),
            PooledValue(sh, sh / math.sqrt(2.0 * total), True))


def log_pose_model(name: str, data: LogData, vehicle: Vehicle, params: PoseModelParams,
                   motion: MotionSettings) -> LogPoseModel | None:
    """One log's pose model (:class:`LogPoseModel`), with ``vehicle``'s installation applied
    to its data and the odometry of ``motion``; None without valid NAV poses or motion data.
    The age and the lever are fitted whatever ``params`` say of fitting them
    (``pose_age_fit``, ``pose_skew_fit``); their period and the latency are ``params``'."""
    from lgvtool.localize.replay_driver import apply_pose_gate

    if data.nav is None or not data.has_poses or not data.has_motion:
        return None
    data = apply_installation(data, vehicle)
    data = replace(data, nav=dict(data.nav)) if data.nav is not None else data
    tracks: dict[MotionSettings, MotionTrack] = {}
    apply_pose_gate(data, vehicle, tracks)
    nav = data.nav
    assert nav is not None
    usable = np.asarray(nav["valid"], dtype=bool)
    if "gate" in nav:
        usable = usable & np.asarray(nav["gate"], dtype=bool)
    ok = np.nonzero(usable)[0]
    if len(ok) < 10:
        return None
    track = tracks.get(motion) or MotionTrack(data.increments(motion, vehicle), motion.step_form)
    t, x, y, h = nav["t"][ok], nav["x"][ok], nav["y"][ok], nav["heading"][ok]
    fitting = replace(params, pose_age_fit=True, pose_skew_fit=True)
    configured = vehicle_states_age(vehicle.nav_time_offset, vehicle.nav_pose_age)
    latency = float(getattr(params, "pose_latency_s", 0.0))
    fit = fit_pose_model(t, x, y, h, track, vehicle.nav_x, vehicle.nav_y, fitting, latency,
                         configured)
    noise = standstill_noise(t - fit.age_s, x, y, h, track)
    return LogPoseModel(name, fit, noise, len(ok))


def estimate_pose_model(logs: Sequence[tuple[str, LogData]], vehicle: Vehicle,
                        params: PoseModelParams, motion: MotionSettings
                        ) -> PoseModelEstimate | None:
    """The pose model of the NAV poses of ``logs`` (name, data), pooled over the logs
    (:func:`pooled_mean`), with the calibrated ``vehicle`` applied; None when no log has valid
    NAV poses beside motion data. ``params``: an estimator's pose-model parameters (its head
    period, its ``pose_latency_s``); ``motion``: its odometry settings."""
    per_log = [m for m in (log_pose_model(n, d, vehicle, params, motion) for n, d in logs)
               if m is not None]
    if not per_log:
        return None
    aged = [m.fit for m in per_log if m.fit.age_fitted]
    skewed = [m.fit for m in per_log if m.fit.skew_fitted]
    configured = vehicle_states_age(vehicle.nav_time_offset, vehicle.nav_pose_age)
    stated = vehicle.nav_time_offset + vehicle.nav_pose_age
    age = pooled_mean([f.age_s for f in aged], [f.age_sigma_s for f in aged], AGE_UNDETERMINED)
    sx = pooled_mean([f.skew_x_m for f in skewed], [f.skew_sigma_m for f in skewed],
                     SKEW_UNDETERMINED)
    sy = pooled_mean([f.skew_y_m for f in skewed], [f.skew_sigma_m for f in skewed],
                     SKEW_UNDETERMINED)
    if not age.determined:
        tried = [m.fit.age_tried_sigma_s for m in per_log
                 if math.isfinite(m.fit.age_tried_sigma_s)]
        shown = (f"1-sigma {min(tried) * 1e3:.3g} ms > {AGE_MAX_SIGMA_S * 1e3:.0f} ms; "
                 if tried else "")
        age = replace(age, why=shown + AGE_UNDETERMINED)
    if not sx.determined:
        tried = [m.fit.skew_tried_sigma_m for m in per_log
                 if math.isfinite(m.fit.skew_tried_sigma_m)]
        shown = f"1-sigma {min(tried):.3g} m > {SKEW_MAX_SIGMA_M} m; " if tried else ""
        sx = replace(sx, why=shown + SKEW_UNDETERMINED)
        sy = replace(sy, why=shown + SKEW_UNDETERMINED)
    sxy, sh = _pooled_noise([m.noise for m in per_log])
    return PoseModelEstimate(age, sx, sy, sxy, sh, stated, configured, params.pose_period_s,
                             tuple(per_log))


def pose_model_estimators() -> list[str]:
    """The estimators that read NAV poses through the pose model (their parameters are
    :class:`PoseModelParams`), in the registry's order."""
    from lgvtool.localize.registry import ESTIMATORS

    return [n for n, cls in ESTIMATORS.items() if issubclass(cls.Params, PoseModelParams)]


def pose_model_settings(settings: Mapping[str, Mapping[str, object]],
                        estimate: PoseModelEstimate | None) -> dict[str, dict[str, object]]:
    """``settings`` (``[estimators.*]``) with :meth:`PoseModelEstimate.settings` set in the
    table of every pose-model estimator (:func:`pose_model_estimators`; a table is made where
    there is none). Returns new dicts; ``settings`` is not changed."""
    from lgvtool.localize.registry import resolve_params

    out = {name: dict(table) for name, table in settings.items()}
    if estimate is None:
        return out
    for name in pose_model_estimators():
        p = resolve_params(name, settings, None)
        values = estimate.settings(float(getattr(p, "sigma_pose_xy_m", 0.0)),
                                   float(getattr(p, "sigma_pose_heading_rad", 0.0)))
        if values:
            out.setdefault(name, {}).update(values)
    return out
