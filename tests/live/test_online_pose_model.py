"""The live view reads a NAV pose through the pose model as the configuration states it (the
age, the skew lever, the odometry's motion at the reference instant), as replay does with a
calibrated configuration, and never fits it."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import orjson
import pytest

from lgvtool.config import default_config
from lgvtool.live.online import OnlineEstimator
from lgvtool.localize.ekf import Ekf
from lgvtool.localize.motion import Increments, MotionTrack
from lgvtool.localize.observations import PoseObservation
from lgvtool.localize.pose_model import PoseFit, pose_observations
from lgvtool.log import topics
from lgvtool.timestamps import stamp

T0_NS = 1_704_067_200_000_000_000
V, OMEGA = 1.0, 0.5
"""The drive: forward speed (m/s) and turn rate (rad/s), steady."""


def _feed(est: OnlineEstimator, t: float, topic: str, doc: dict[str, object]) -> None:
    ns = T0_NS + round(t * 1e9)
    est.feed(topic, orjson.dumps(dict(doc, timestamp=stamp(ns))), ns)


@pytest.mark.parametrize("pose_age", [0.0, 0.1])
def test_a_live_pose_is_at_its_stated_age_with_its_skew_taken_off(
        monkeypatch: pytest.MonkeyPatch, pose_age: float) -> None:
    seen: list[PoseObservation] = []

    def capture(self: Ekf, obs: object) -> None:
        if isinstance(obs, PoseObservation):
            seen.append(obs)

    monkeypatch.setattr(Ekf, "update", capture)
    base = default_config()
    cfg = replace(base, vehicle=replace(base.vehicle, nav_pose_age=pose_age),
                  estimators={"ekf": {"observations": "poses", "pose_latency_s": 0.02,
                                      "pose_skew_x_m": -0.5, "pose_skew_y_m": 4.0}})
    est = OnlineEstimator("ekf", cfg, cloud_size=0)
    for k in range(151):  # 3 s of generic odometry at 50 Hz
        _feed(est, k * 0.02, topics.ODOM, {"v": V, "omega": OMEGA})
    x, y, h = 10.0, 5.0, 0.7
    _feed(est, 2.5, topics.NAV_POSE, {"x": x, "y": y, "heading": h, "quality": 100,
                                      "reflectors_used": 5, "valid": True})
    assert len(seen) == 1
    obs = seen[0]
    period = 0.125
    # the vehicle states a pose age: the latency after it; else the latency plus one period
    age = pose_age + 0.02 if pose_age else 0.02 + period
    assert obs.t == pytest.approx(2.5 - age, abs=1e-9)
    # over the revolution about that instant (the chord's projection: within 0.1 %)
    assert obs.v == pytest.approx(V, rel=1e-3) and obs.omega == pytest.approx(OMEGA, rel=1e-6)
    # the skew (omega T / pi) R(h) s taken off
    gain = OMEGA * period / math.pi
    bx = gain * (math.cos(h) * -0.5 - math.sin(h) * 4.0)
    by = gain * (math.sin(h) * -0.5 + math.cos(h) * 4.0)
    assert obs.x == pytest.approx(x - bx, abs=1e-6) and obs.y == pytest.approx(y - by, abs=1e-6)
    # the same as replay's function on the same stated model
    t = np.arange(0.0, 3.0 + 1e-9, 0.02)
    track = MotionTrack(Increments(t, np.full(len(t) - 1, V * 0.02),
                                   np.full(len(t) - 1, OMEGA * 0.02)))
    fit = PoseFit(0.02 + (0.0 if pose_age else period), math.nan, False, -0.5, 4.0, math.nan,
                  False)
    ref = pose_observations(np.array([2.5 - pose_age]), np.array([x]), np.array([y]),
                            np.array([h]), track, fit, period)[0]
    assert (obs.t, obs.x, obs.y, obs.heading) == pytest.approx(
        (ref.t, ref.x, ref.y, ref.heading), abs=1e-9)
