"""``calibrate``: logs in, the vehicle's installation estimated, a configuration out.

Reads each log (motion, reflector scans and/or NAV poses), prepares the drives
(:mod:`lgvtool.calibrate.drive`), solves the least squares over all of them at once
(:mod:`lgvtool.calibrate.solve`), fits the NAV poses' age where poses stand beside scans
(:mod:`lgvtool.calibrate.timing`), and builds the calibrated configuration: the starting one
with the estimated ``vehicle.*`` values. Optionally it replays the estimators with both to show
what the calibration changes (:mod:`lgvtool.calibrate.compare`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, TypedDict

from lgvtool.calibrate.compare import Row
from lgvtool.calibrate.pose_calibration import (
    PoseModelEstimate,
    estimate_pose_model,
    pose_model_settings,
)
from lgvtool.calibrate.quantities import QUANTITIES, default_names
from lgvtool.config import Config, Vehicle
from lgvtool.errors import InputError, MissingDataError
from lgvtool.extras import require
from lgvtool.json_types import JSONObject
from lgvtool.progress import Progress

if TYPE_CHECKING:
    from lgvtool.localize.logdata import LogData
    from lgvtool.localize.pose_model import PoseModelParams

TIME_FLOOR_S = 1e-3
"""Added in quadrature to the time offset's 1-sigma: the host's read latency of the MCU frames,
which no log shows (:mod:`lgvtool.calibrate.drive`), s."""

SCALE_PRIORS: dict[str, dict[str, str]] = {
    "ekf": {"odom_scale_v": "scale_sigma_v", "odom_scale_w": "scale_sigma_w"},
    "pf": {"odom_scale_v": "scale_sigma_v", "odom_scale_w": "scale_sigma_w"}}
"""Estimator -> {calibrated odometry scale: the parameter of its prior's 1-sigma}: the estimators
whose odometry scales in the state (``odometry_scales``: the EKF's state, each of pf's
particles) start from the calibration's uncertainty once the odometry is calibrated
(:func:`scale_priors`)."""


@dataclass
class Estimate:
    """One quantity: starting and calibrated value and 1-sigma (SI), whether estimated."""

    name: str
    start: float
    value: float
    sigma: float | None
    """None when held fixed."""
    status: str
    """``estimated``, ``fixed`` (asked to hold) or ``unobservable`` (held: the drive cannot
    observe it)."""

    def to_dict(self) -> JSONObject:
        """JSON-ready, SI and in the display unit."""
        q = QUANTITIES[self.name]
        out: JSONObject = {"status": self.status, "unit": q.unit or "1",
                               "start": self.start * q.display,
                               "value": self.value * q.display,
                               "sigma": None if self.sigma is None else self.sigma * q.display,
                               "start_si": self.start, "value_si": self.value,
                               "sigma_si": self.sigma}
        return out


class CalibrationDocument(TypedDict):
    """``calibrate --json``: each quantity's estimate (:meth:`Estimate.to_dict`), the
    calibrated vehicle values (SI), the estimator settings it changes, the logs, the warnings,
    the before/after comparison, the residuals and the timings (s)."""

    estimates: dict[str, JSONObject]
    vehicle: dict[str, float]
    estimator_settings: dict[str, dict[str, object]]
    logs: list[dict[str, object]]
    warnings: list[str]
    comparison: list[JSONObject]
    residuals: dict[str, object]
    timings_s: dict[str, float]
    pose_model: JSONObject | None


@dataclass
class Calibration:
    """What ``calibrate`` found."""

    estimates: dict[str, Estimate]
    config: Config
    """The calibrated configuration (the starting one with the estimated vehicle values)."""
    start_config: Config
    logs: list[dict[str, Any]]
    warnings: list[str]
    comparison: list[Row] = field(default_factory=list)
    residuals: dict[str, Any] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    pose_model: PoseModelEstimate | None = None
    """The NAV poses' observation model (age, skew lever, noise at standstill), when the logs
    have NAV poses beside motion data (:mod:`lgvtool.calibrate.pose_calibration`)."""

    def settings_set(self) -> dict[str, dict[str, object]]:
        """Estimator settings the calibrated configuration sets to other values than the
        starting one (:func:`scale_priors`): ``{estimator: {parameter: value}}``."""
        out: dict[str, dict[str, object]] = {}
        for name, table in self.config.estimators.items():
            before = self.start_config.estimators.get(name, {})
            changed = {k: v for k, v in table.items() if before.get(k) != v}
            if changed:
                out[name] = changed
        return out

    def to_dict(self) -> CalibrationDocument:
        """The JSON document (``calibrate --json``)."""
        return {"estimates": {n: e.to_dict() for n, e in self.estimates.items()},
                "vehicle": {n: getattr(self.config.vehicle, n) for n in QUANTITIES},
                "estimator_settings": self.settings_set(),
                "logs": self.logs, "warnings": self.warnings,
                "comparison": [r.to_dict() for r in self.comparison],
                "residuals": self.residuals, "timings_s": self.timings,
                "pose_model": (self.pose_model.to_dict() if self.pose_model is not None
                               else None)}


def _names(estimate: Sequence[str] | None, fix: Sequence[str], motion: str, has_scans: bool,
           has_poses: bool) -> list[str]:
    for n in [*(estimate or []), *fix]:
        if n not in QUANTITIES:
            raise InputError(f"unknown quantity '{n}' (known: {', '.join(QUANTITIES)})")
    if estimate:
        for n in estimate:
            need = QUANTITIES[n].motion
            if need not in ("any", motion):
                kind = ("MCU encoder and gyro frames (/mcu/frame)" if need == "mcu"
                        else "generic odometry (/odom/twist)")
                raise InputError(f"{n} needs {kind}, which the logs do not have")
        if "nav_pose_age" in estimate and not (has_scans and has_poses):
            raise InputError("nav_pose_age needs NAV poses beside reflector scans")
        names = list(dict.fromkeys(estimate))
    else:
        names = default_names(motion, has_scans, has_poses)
    return [n for n in names if n not in fix]


def calibrate(paths: Sequence[str], *, config: Config | None = None,
              estimate: Sequence[str] | None = None, fix: Sequence[str] = (),
              observations: str = "auto", allow_unobservable: bool = False,
              compare_with: Sequence[str] = ("laser", "ekf"), seed: int = 0,
              start_at_truth: bool = False, progress: Progress | None = None) -> Calibration:
    """Calibrate the vehicle from the logs ``paths`` (see the module docstring).

    :param config: starting values, map and everything else of the output (default: the first
        log's stored configuration).
    :param estimate: quantities to estimate (default: every one the logs' data has); ``fix``
        holds some of them at their starting values.
    :param observations: ``auto`` (reflector scans if the logs have them, else NAV poses),
        ``scans`` or ``poses``.
    :param allow_unobservable: hold the quantities the drives cannot observe at their starting
        values (with a warning) instead of refusing.
    :param compare_with: estimators to replay with the starting and the calibrated
        configuration (empty: none); ``start_at_truth`` starts them at the ground truth.
    :param progress: shows the stages (read each log, solve, compare) on stderr.
    :raises InputError: unusable input (one line), unobservable quantities.
    """
    require("calibrate", "calibrate", "scipy")
    from lgvtool.calibrate.drive import log_mcu_baud, prepare
    from lgvtool.calibrate.solve import Problem, SolveSettings, UnobservableError, solve
    from lgvtool.calibrate.timing import fit_pose_age
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader

    if observations not in ("auto", "scans", "poses"):
        raise InputError(f"observations must be auto, scans or poses, got {observations!r}")
    if not paths:
        raise InputError("calibrate needs at least one log")
    started = time.perf_counter()
    if progress is not None:
        progress.stage("read", len(paths))
    readers = [LogReader(p) for p in paths]
    cfg = config if config is not None else readers[0].config()
    reflectors = cfg.reflectors or readers[0].reflector_map()
    if not reflectors:
        raise MissingDataError("no reflector map: neither the configuration nor the log has one")
    drives = []
    datas = []
    for path, reader in zip(paths, readers, strict=True):
        data = load_log(reader, reflectors, decode_scans=observations != "poses")
        datas.append((path, data))
        drives.append(prepare(path, data, reflectors, observations=observations,
                              mcu_baud=log_mcu_baud(reader.metadata)))
        if progress is not None:
            progress.advance()
    read_s = time.perf_counter() - started
    kinds = {d.motion for d in drives}
    if len(kinds) > 1:
        raise InputError("the logs mix MCU frames and generic odometry: calibrate them apart")
    motion = kinds.pop()
    has_scans = any(len(d.obs_t) for d in drives)
    has_poses = any(len(d.pose_t) for d in drives)
    if observations == "auto" and has_scans and not all(len(d.obs_t) for d in drives):
        raise InputError("some logs have reflector scans and some only NAV poses: give "
                         "--observations poses to use the poses of all")
    names = _names(estimate, fix, motion, has_scans, has_poses)
    if not names:
        raise InputError("nothing to estimate: every quantity is held fixed")
    v = cfg.vehicle
    start = {n: float(getattr(v, n)) for n in QUANTITIES}
    solved = [n for n in names if n != "nav_pose_age"]
    use_poses = [not len(d.obs_t) for d in drives]
    warnings: list[str] = []
    if observations == "poses" and any(d.has_scans for _, d in datas):
        warnings.append("the logs have reflector scans, calibrated here from the NAV poses: "
                        "nav_time_offset takes the poses' whole age, so this file would replay "
                        "the scans that much late (docs/calibration.md, \"Limits\")")
    pose_params = _pose_params(cfg.estimators)
    settings = SolveSettings(pose_period_s=_skew_period(pose_params))
    problem = Problem(drives, solved, start, reflectors, v.encoder_ppr, settings, use_poses)
    if progress is not None:
        progress.stage("solve", 1)
    try:
        sol = solve(problem, allow_unobservable=allow_unobservable)
    except UnobservableError as exc:
        raise InputError(_unobservable_line(exc.sigma)) from None
    for n, s in sol.unobservable.items():
        q = QUANTITIES[n]
        warnings.append(f"{n} is not observable by these drives (1-sigma {s * q.display:.3g} "
                        f"{q.unit}; it needs {q.needs}): held at its starting value")
    values = dict(sol.values)
    sigma: dict[str, float | None] = {n: sol.sigma.get(n) for n in solved}
    if "nav_time_offset" in sol.sigma:
        sigma["nav_time_offset"] = math.hypot(sol.sigma["nav_time_offset"], TIME_FLOOR_S)
    if "nav_pose_age" in names:
        fit = fit_pose_age(drives, sol.poses, values, start["nav_pose_age"])
        if fit.used and math.isfinite(fit.sigma_fit) and fit.sigma_fit <= QUANTITIES[
                "nav_pose_age"].max_sigma:
            values["nav_pose_age"] = max(0.0, fit.age)
            sigma["nav_pose_age"] = fit.sigma
            if fit.sigma > 2.0 * fit.sigma_fit:
                own = ", ".join(f"{a * 1e3:.1f}" for a in fit.per_drive)
                warnings.append(f"nav_pose_age differs between the logs ({own} ms): its "
                                f"1-sigma includes the spread")
        elif allow_unobservable:
            sol.unobservable["nav_pose_age"] = fit.sigma_fit
            warnings.append("nav_pose_age is not observable by these drives: held at its "
                            "starting value")
        else:
            raise InputError(_unobservable_line({"nav_pose_age": fit.sigma_fit}))
    estimates: dict[str, Estimate] = {}
    for n in QUANTITIES:
        if QUANTITIES[n].motion not in ("any", motion):
            continue
        if n in sol.unobservable:
            estimates[n] = Estimate(n, start[n], start[n], None, "unobservable")
        elif n in names:
            estimates[n] = Estimate(n, start[n], values[n], sigma.get(n), "estimated")
        else:
            estimates[n] = Estimate(n, start[n], start[n], None, "fixed")
    calibrated: dict[str, Any] = {n: e.value for n, e in estimates.items()}
    vehicle = replace(v, **calibrated)
    pose_model = _pose_model(datas, vehicle, pose_params)
    warnings.extend(pose_model.warnings() if pose_model is not None else [])
    out_cfg = replace(cfg, vehicle=vehicle, simulator={},
                      estimators=pose_model_settings(scale_priors(cfg.estimators, estimates),
                                                     pose_model))
    solve_s = time.perf_counter() - started - read_s
    logs = []
    for d, drive in enumerate(drives):
        info = dict(drive.info, path=drive.name, motion=drive.motion,
                    duration_s=drive.duration, nodes=len(drive.t),
                    reflector_measurements=len(drive.obs_t),
                    gyro_bias_deg_s=(math.degrees(sol.bias_per_log[d])
                                     if drive.motion == "mcu" else None))
        logs.append(info)
    result = Calibration(estimates=estimates, config=out_cfg, start_config=cfg, logs=logs,
                         warnings=warnings, pose_model=pose_model,
                         residuals={"noise_scale": sol.noise_scale,
                                    "rms_normalised": sol.rms,
                                    "beyond_3_sigma": sol.outliers,
                                    "iterations": sol.iterations})
    if compare_with:
        from lgvtool.calibrate.compare import compare

        t0 = time.perf_counter()
        if progress is not None:
            progress.stage("compare", len(compare_with))
        rows, notes = compare(paths, compare_with, cfg, out_cfg, seed, start_at_truth)
        result.comparison = rows
        result.warnings.extend(notes)
        result.timings["compare"] = time.perf_counter() - t0
    result.timings.update(read=read_s, solve=solve_s)
    return result


def _pose_params(settings: Mapping[str, Mapping[str, object]]) -> PoseModelParams | None:
    """The starting ``[estimators.ekf]``'s pose-model parameters (its head period,
    ``pose_latency_s``, pose model), None when it has none."""
    from lgvtool.localize.pose_model import PoseModelParams
    from lgvtool.localize.registry import resolve_params

    params = resolve_params("ekf", settings, None)
    return params if isinstance(params, PoseModelParams) else None


def _skew_period(params: PoseModelParams | None) -> float | None:
    """The head period (s) when the pose model of ``params`` is the rotating head's (the poses
    carry a skew the calibration estimates beside the mounting), else None."""
    if params is not None and params.pose_model == "rotating-head":
        return float(params.pose_period_s)
    return None


def _pose_model(logs: Sequence[tuple[str, LogData]], vehicle: Vehicle,
                params: PoseModelParams | None) -> PoseModelEstimate | None:
    """The NAV poses' observation model of the logs with the calibrated ``vehicle``
    (:func:`lgvtool.calibrate.pose_calibration.estimate_pose_model`), with the head period,
    ``pose_latency_s`` and odometry of the starting ``[estimators.ekf]`` (``params``)."""
    from lgvtool.localize.registry import motion_params

    if params is None:
        return None
    return estimate_pose_model(logs, vehicle, params,
                               motion_params("ekf", params).motion_settings())


def scale_priors(settings: Mapping[str, Mapping[str, object]], estimates: Mapping[str, Estimate]
                 ) -> dict[str, dict[str, object]]:
    """The estimator settings of the calibrated configuration: ``settings`` (``[estimators.*]``
    of the starting configuration) with, for each estimator of :data:`SCALE_PRIORS` that
    carries the odometry scales in its state (``odometry_scales = true``), the prior 1-sigma of
    each estimated odometry scale set to the calibration's 1-sigma (dimensionless).

    The calibrated odometry is the starting one times the calibrated scales, so what is left of
    its scale error is what the calibration leaves uncertain: the state's scales start at 1
    with that uncertainty, not with the prior the settings give for odometry as logged (which
    would let the filter undo the calibration over its first metres). Returns new dicts;
    ``settings`` is not changed."""
    out = {name: dict(table) for name, table in settings.items()}
    for name, params in SCALE_PRIORS.items():
        table = out.get(name)
        if not table or not table.get("odometry_scales"):
            continue
        for quantity, param_name in params.items():
            e = estimates.get(quantity)
            if e is not None and e.status == "estimated" and e.sigma is not None:
                table[param_name] = float(e.sigma)
    return out


def _unobservable_line(sigma: dict[str, float]) -> str:
    parts = []
    for n, s in sigma.items():
        q = QUANTITIES[n]
        shown = f"{s * q.display:.3g} {q.unit}".strip() if math.isfinite(s) else "unbounded"
        parts.append(f"{n} (1-sigma {shown}; needs {q.needs})")
    return ("the drives cannot observe " + ", ".join(parts)
            + ": drive more, hold them with --fix, or --allow-unobservable")
