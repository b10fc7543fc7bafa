"""Every estimator tracks the truth within 1 mm on exact synthetic data (circle drive with the
tricycle kinematics, exact odometry, exact NAV poses and reflector observations)."""

from __future__ import annotations

import numpy as np
import pytest
from localize_synth import T0_NS, circle_log

from lgvtool.localize.replay_driver import replay_data

TIGHT_PAPER = {
    "pf-paper.init": "laser", "pf-paper.init_sigma_xy_m": 0.0005,
    "pf-paper.init_sigma_heading_rad": 0.0001, "pf-paper.spread_m": 0.001,
    "pf-paper.heading_spread_rad": 0.0001, "pf-paper.sigma_m": 0.001,
    "pf-paper.deskew": True, "pf-paper.scans": "all",
}
TIGHT_PF = {
    "pf.init": "laser", "pf.init_sigma_xy_m": 0.0005, "pf.init_sigma_heading_rad": 0.0001,
    "pf.kld": False, "pf.particles": 300,
}


def max_error(result, name: str, circle) -> float:
    tab = result.estimates[name]
    assert len(tab.x) > 10, f"{name} produced too few estimates"
    t = (tab.t_ns - T0_NS) * 1e-9
    x, y, th = circle.pose(t)
    dth = np.angle(np.exp(1j * (tab.heading - th)))
    assert np.abs(dth).max() < 2e-3, f"{name} heading error {np.abs(dth).max()}"
    return float(np.hypot(tab.x - x, tab.y - y).max())


@pytest.mark.parametrize("motion", ["mcu", "twist"])
def test_all_estimators_with_scans_and_poses(motion: str) -> None:
    data, circle, cfg = circle_log(15.0, motion=motion)
    res = replay_data(data, None, config=cfg, seed=3, settings=TIGHT_PAPER | TIGHT_PF)
    assert not res.skipped
    for name in ("laser", "deadreckoning", "ekf", "pf-paper", "pf"):
        assert max_error(res, name, circle) < 1e-3, name


def test_pose_only_log() -> None:
    """Exact NAV poses, as no rotating head makes them (no age, no skew): the filters take them
    with the plain pose model."""
    data, circle, cfg = circle_log(15.0, scans="none")
    res = replay_data(data, None, config=cfg, seed=3, settings=TIGHT_PAPER | TIGHT_PF | {
        "pf.sigma_pose_xy_m": 0.002, "pf.sigma_pose_heading_rad": 0.001,
        "ekf.pose_model": "plain", "pf.pose_model": "plain", "pf-paper.pose_model": "plain"})
    for name in ("laser", "deadreckoning", "ekf", "pf-paper", "pf"):
        assert max_error(res, name, circle) < 1e-3, name


def test_sensor_at_centre_with_known_ids_and_odometry() -> None:
    """A camera-like sensor at O reporting landmark ids, generic odometry, no NAV poses."""
    data, circle, cfg = circle_log(15.0, nav_x=0.0, motion="twist", scans="snapshot",
                                   poses=False, ids=True)
    settings = TIGHT_PF | {"pf.init": "uniform", "pf.kld": True, "pf.particles": 2000,
                           "pf.sigma_range_m": 0.005, "pf.sigma_bearing_rad": 0.001,
                           "ekf.init": "landmarks"}
    res = replay_data(data, ["deadreckoning", "ekf", "pf"], config=cfg, seed=3,
                      settings=settings | {"deadreckoning.init": "landmarks"})
    for name in ("deadreckoning", "ekf"):
        assert max_error(res, name, circle) < 1e-3, name
    tab = res.estimates["pf"]
    t = (tab.t_ns - T0_NS) * 1e-9
    x, y, _ = circle.pose(t)
    err = np.hypot(tab.x - x, tab.y - y)
    assert err[t > 2.0].max() < 1e-3


def test_wrapping_counters_and_lost_frames_are_bridged() -> None:
    """Counts start near the int32 limit, sequence numbers wrap, and frames are lost."""
    data, circle, cfg = circle_log(15.0, drop_frames=(7, 8, 9, 40, 41))
    res = replay_data(data, ["deadreckoning"], config=cfg, seed=3)
    assert max_error(res, "deadreckoning", circle) < 1e-3
