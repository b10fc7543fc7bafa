"""Estimators fed message by message, as a recording arrives (the live view's estimate).

:class:`OnlineEstimator` takes the log's own messages (``/mcu/frame`` or ``/odom/twist``,
``/nav/pose``, ``/nav/reflectors``, ``/map/reflectors``) one at a time, in arrival order, and
returns the messages replay would write for the estimate (``/estimate/NAME/pose``, ``/state``,
``/tf``, ``/covariance``, ``/particles``, same schemas and JSON layout, from the same builders,
:mod:`lgvtool.log.foxglove`). It uses the same estimators, parameters,
motion integration and observation geometry as ``lgvtool replay``; what differs is what an online
estimate cannot know:

- the motion between two observations comes from the MCU frames received so far (those after
  the last frame are not yet there; their motion is applied at the next observation, so none is
  lost);
- an observation older than the last one applied is applied at the last one's time;
- ``observations = auto`` uses reflector scans once one has arrived (and a map is known), NAV
  poses before;
- the paper filter's ``scans = nav-poll`` takes, at each NAV pose, the last scan received before
  it;
- a NAV pose is read through the rotating-head pose model as stated in the configuration
  (``pose_model = rotating-head``: the age ``pose_latency_s``, plus one head period when the
  vehicle states no pose age, after the vehicle's ``nav_time_offset + nav_pose_age``; the skew
  lever ``pose_skew_x_m``, ``pose_skew_y_m``; the odometry's motion at its reference instant,
  :func:`lgvtool.localize.pose_model.pose_observations`), never fitted: a log's age and lever
  are fitted over the whole log, which a live feed does not have (``lgvtool calibrate`` writes
  them into the configuration).

Times are the messages' own stamps (ns), as in replay. Processing time per update (s) is kept
in :attr:`OnlineEstimator.update_seconds`.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import orjson

from lgvtool.angles import wrap_scalar
from lgvtool.config import Config, Reflector, Vehicle
from lgvtool.json_types import JSONRecord, SettingValue, as_float, as_list, member
from lgvtool.localize.estimator import Estimator, Motion, Observation, cloud_sample
from lgvtool.localize.motion import (
    MotionTrack,
    increments_from_mcu,
    increments_from_twist,
)
from lgvtool.localize.observations import (
    PoseObservation,
    RawScan,
    ScanBatch,
    scan_observations,
    sources,
)
from lgvtool.localize.pose_model import (
    PoseFit,
    PoseModelParams,
    pose_observations,
    stated_fit,
    vehicle_states_age,
)
from lgvtool.localize.registry import (
    ESTIMATORS,
    check_names,
    motion_params,
    resolve_params,
    split_settings,
)
from lgvtool.localize.replay_driver import estimator_rng
from lgvtool.log import foxglove as fx
from lgvtool.log import messages, topics
from lgvtool.timestamps import message_stamp_ns, seconds_to_ns

__all__ = ["INPUT_TOPICS", "OnlineEstimator", "Output"]

#: the topics an online estimator reads
INPUT_TOPICS = frozenset({topics.MCU_FRAME, topics.ODOM, topics.NAV_POSE, topics.NAV_REFLECTORS,
                          topics.MAP})
#: motion samples kept behind the last applied motion, s (covers a revolution's de-skew)
_KEEP_S = 2.0


@dataclass(frozen=True, slots=True)
class Output:
    """One message to publish: topic, schema name, JSON bytes, time (ns since the epoch)."""

    topic: str
    schema: str
    data: bytes
    t_ns: int


class OnlineEstimator:
    """One estimator run on messages as they arrive.

    :param name: estimator name (``pf``, ``ekf``, ...; see ``lgvtool replay --help``).
    :param config: vehicle, area, reflectors and ``[estimators.*]`` settings; without reflectors
        the map is taken from ``/map/reflectors`` when it arrives.
    :param seed: seed of the estimator's random draws (as in replay).
    :param settings: ``{"<name>.<param>": value}`` overrides.
    :param cloud_period_s: publish one particle cloud per this many seconds of data, s.
    :param cloud_size: at most this many particles per cloud (0: none).
    """

    def __init__(self, name: str, config: Config, *, seed: int = 0,
                 settings: Mapping[str, SettingValue] | None = None, cloud_period_s: float = 0.5,
                 cloud_size: int = 100) -> None:
        check_names([name])
        self.name = name
        self.cls: type[Estimator[Any]] = ESTIMATORS[name]
        self.params = resolve_params(name, config.estimators, split_settings(settings).get(name))
        self.config = config
        self.seed = seed
        self.reflectors: tuple[Reflector, ...] = tuple(config.reflectors)
        self.motion = (motion_params(name, self.params).motion_settings() if self.cls.uses_motion
                       else None)
        self.cloud_period_s = cloud_period_s
        self.cloud_size = cloud_size
        self.est: Estimator[Any] | None = None
        self._mcu: list[tuple[float, int, int, int, int, float]] = []
        self._twist: list[tuple[float, float, float]] = []
        self._t0_ns: int | None = None
        self._motion_t: float | None = None
        self._scans_seen = False
        self._poses_seen = False
        self._last_scan: RawScan | None = None
        self._next_cloud = -math.inf
        self._topics = (topics.estimate_pose(name), topics.estimate_state(name),
                        topics.estimate_tf(name), topics.estimate_covariance(name),
                        topics.estimate_particles(name))
        self._mounting = fx.mounting_of(config.vehicle)
        self._pose_fit = _stated_pose_fit(self.params, config.vehicle)
        #: processing time of every observation applied, s
        self.update_seconds: list[float] = []

    @property
    def output_topics(self) -> tuple[str, ...]:
        """The topics this estimator publishes: pose, state, frames, covariance ellipse and
        (particle filters) cloud, as ``replay`` writes them."""
        return self._topics

    # ------------------------------------------------------------------ input
    def feed(self, topic: str, data: bytes, log_time_ns: int) -> list[Output]:
        """Take one message of the log (JSON bytes); return the estimate messages it caused."""
        if topic not in INPUT_TOPICS:
            return []
        doc = orjson.loads(data)
        t_ns = message_stamp_ns(doc, log_time_ns)
        if self._t0_ns is None:
            self._t0_ns = t_ns
        t = (t_ns - self._t0_ns) * 1e-9
        if topic == topics.MCU_FRAME:
            self._mcu.append((t, int(doc["seq"]), int(doc["mcu_time_ms"]), int(doc["enc_left"]),
                              int(doc["enc_right"]), float(doc["gyro_rate"])))
            return []
        if topic == topics.ODOM:
            self._twist.append((t, float(doc["v"]), float(doc["omega"])))
            return []
        if topic == topics.MAP:
            if not self.reflectors:
                self.reflectors = messages.reflectors_from_message(doc)
            return []
        if topic == topics.NAV_REFLECTORS:
            return self._on_scan(doc, t, (log_time_ns - self._t0_ns) * 1e-9)
        return self._on_pose(doc, t)

    def _uses(self) -> tuple[bool, bool]:
        has_scans = self.cls.uses_scans and self._scans_seen and bool(self.reflectors)
        has_poses = self.cls.uses_poses and self._poses_seen
        return sources(getattr(self.params, "observations", "both"), has_scans, has_poses)

    def _on_scan(self, doc: JSONRecord, t: float, received: float) -> list[Output]:
        obs = as_list(doc.get("observations") or [])
        scan = RawScan(t, as_float(doc.get("scan_period", 0.0)),
                       np.array([member(o, "range") for o in obs], dtype=np.float64),
                       np.array([member(o, "bearing") for o in obs], dtype=np.float64),
                       np.array([member(o, "time_in_scan") for o in obs], dtype=np.float64),
                       np.array([member(o, "id") for o in obs], dtype=np.int64))
        self._scans_seen = True
        if getattr(self.params, "scans", "all") == "nav-poll":
            self._last_scan = scan
            return []
        return self._apply_scan(scan)

    def _apply_scan(self, scan: RawScan) -> list[Output]:
        use_scans, _ = self._uses()
        if not use_scans:
            return []
        started = time.perf_counter()
        track = self._track()
        p = self.params
        o = scan_observations(ScanBatch.from_scans([scan]), self.config.vehicle.nav_x,
                              self.config.vehicle.nav_y, track=track,
                              deskew=bool(getattr(p, "deskew", False)),
                              min_range=float(getattr(p, "min_range_m", 0.0)),
                              max_range=float(getattr(p, "max_range_m", math.inf)))[0]
        return self._apply(o, o.t, track, started)

    def _on_pose(self, doc: JSONRecord, t: float) -> list[Output]:
        out: list[Output] = []
        if self._last_scan is not None:
            scan, self._last_scan = self._last_scan, None
            out.extend(self._apply_scan(scan))
        x, y, h = (as_float(doc.get(k) or math.nan) for k in ("x", "y", "heading"))
        if not (doc.get("valid") and math.isfinite(x) and math.isfinite(y) and math.isfinite(h)):
            return out
        self._poses_seen = True
        _, use_poses = self._uses()
        if use_poses:
            started = time.perf_counter()
            track = self._track()
            obs = self._pose(t, x, y, h, track)
            out.extend(self._apply(obs, obs.t, track, started))
        elif self.reflectors or not self.cls.uses_scans:
            # an estimator that does not update with NAV poses may still start from one
            obs = PoseObservation(t - float(getattr(self.params, "pose_latency_s", 0.0)), x, y, h)
            if self.est is None:
                self.est = self._build()
            if self.est.initialized:
                return out
            self.est.update(obs)
            self._motion_t = min(obs.t, max(self._motion_end(), -1e300))
        return out

    def _pose(self, t: float, x: float, y: float, h: float, track: MotionTrack | None
              ) -> PoseObservation:
        """A NAV head pose received at ``t`` (s) as the observation replay would make of it:
        through the stated pose model (rotating-head), else at ``t - pose_latency_s``."""
        fit = self._pose_fit
        if fit is None:
            return PoseObservation(t - float(getattr(self.params, "pose_latency_s", 0.0)), x, y,
                                   h)
        v = self.config.vehicle
        period = float(getattr(self.params, "pose_period_s", 0.125))
        return pose_observations(np.array([t - v.nav_time_offset - v.nav_pose_age]),
                                 np.array([x]), np.array([y]),
                                 np.array([wrap_scalar(h - v.nav_yaw)]), track, fit, period)[0]

    # ------------------------------------------------------------------ motion
    def _motion_end(self) -> float:
        """Time of the last motion sample received, s (-inf if none)."""
        if self._mcu:
            return self._mcu[-1][0]
        if self._twist:
            return self._twist[-1][0]
        return -math.inf

    def _track(self) -> MotionTrack | None:
        """The odometry of the motion samples kept, or None without motion input."""
        ms = self.motion
        if ms is None:
            return None
        if self._mcu:
            a = np.array(self._mcu, dtype=np.float64)
            inc = increments_from_mcu(a[:, 0], a[:, 1].astype(np.int64), a[:, 2].astype(np.int64),
                                      a[:, 3].astype(np.int64), a[:, 4].astype(np.int64), a[:, 5],
                                      self.config.vehicle, ms)
        elif self._twist:
            a = np.array(self._twist, dtype=np.float64)
            inc = increments_from_twist(a[:, 0], a[:, 1], a[:, 2])
        else:
            return None
        return MotionTrack(inc, ms.step_form) if len(inc.t) >= 2 else None

    def _trim(self) -> None:
        """Drop motion samples older than needed (keep :data:`_KEEP_S` behind the motion
        applied, and always the two last)."""
        if self._motion_t is None:
            return
        horizon = self._motion_t - _KEEP_S
        for buf in (self._mcu, self._twist):
            k = 0
            while k < len(buf) - 2 and buf[k + 1][0] < horizon:
                k += 1
            if k:
                del buf[:k]

    # ------------------------------------------------------------------ update
    def _build(self) -> Estimator[Any]:
        return self.cls(self.params, vehicle=self.config.vehicle, reflectors=self.reflectors,
                        area=self.config.area, rng=estimator_rng(self.seed, self.name))

    def _apply(self, obs: Observation, t_obs: float, track: MotionTrack | None,
               started: float) -> list[Output]:
        if self.est is None:
            self.est = self._build()
        est = self.est
        if est.uses_motion and track is not None and self._motion_t is not None:
            # all the motion received up to the observation (none beyond the last sample)
            upto = max(self._motion_t, min(t_obs, self._motion_end()))
            if upto > self._motion_t:
                d = track.deltas(np.array([self._motion_t]), np.array([upto]))
                est.predict(Motion(float(d.dx[0]), float(d.dy[0]), float(d.dth[0]),
                                   float(d.dist[0]), float(d.rot[0])))
                self._motion_t = upto
        elif self._motion_t is None:
            self._motion_t = min(t_obs, self._motion_end()) if track is not None else t_obs
        est.update(obs)
        self._trim()
        out = self._outputs(max(t_obs, self._motion_t))
        self.update_seconds.append(time.perf_counter() - started)
        return out

    def _outputs(self, t: float) -> list[Output]:
        assert self.est is not None and self._t0_ns is not None
        e = self.est.estimate()
        if e is None:
            return []
        t_ns = self._t0_ns + seconds_to_ns(t)
        heading = wrap_scalar(e.heading)
        cloud_t = self._topics[-1]
        out = [Output(m.topic, m.schema, m.data, t_ns) for m in fx.estimate_messages(
            self.name, t_ns, float(e.x), float(e.y), heading,
            np.asarray(e.covariance, dtype=np.float64).ravel().tolist(), self._mounting,
            particles=int(e.particles), ess=float(e.ess))]
        if self.cloud_size > 0 and t >= self._next_cloud:
            c = self.est.cloud()
            if c is not None:
                sel = cloud_sample(len(c[0]), self.cloud_size)
                poses = zip(c[0][sel].tolist(), c[1][sel].tolist(), c[2][sel].tolist(),
                            strict=True)
                out.append(Output(cloud_t, "foxglove.PosesInFrame",
                                  orjson.dumps(messages.poses_in_frame(t_ns, poses)), t_ns))
                self._next_cloud = t + self.cloud_period_s
        return out


def _stated_pose_fit(params: object, vehicle: Vehicle) -> PoseFit | None:
    """The pose model as the configuration states it (nothing fitted:
    :func:`lgvtool.localize.pose_model.stated_fit`) for an estimator with the rotating-head
    model, else None (a pose is then taken at its receive time minus ``pose_latency_s``)."""
    if not (isinstance(params, PoseModelParams) and params.pose_model == "rotating-head"):
        return None
    configured = vehicle_states_age(vehicle.nav_time_offset, vehicle.nav_pose_age)
    return stated_fit(params, float(getattr(params, "pose_latency_s", 0.0)), configured)
