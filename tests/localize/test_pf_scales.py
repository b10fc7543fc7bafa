"""``pf`` with the odometry's errors in its state (``odometry_scales``): per-particle distance
and turn scales learnt from biased odometry and landmark range/bearing observations; and the
weighted landmark fix its start and the EKF's can use."""

from __future__ import annotations

import math

import numpy as np
import pytest
from localize_synth import REFLECTORS, small_config
from test_ekf_scales import TRUE_SCALE_V, TRUE_SCALE_W, run_biased

from lgvtool.localize.camera_fix import start_fix, weighted_fix
from lgvtool.localize.observations import ReflectorMap, ScanObservation
from lgvtool.localize.particle_filter import ParticleFilter


def run_pf(scales: bool, seconds: float = 400.0) -> tuple[ParticleFilter, float]:
    """``pf`` over the biased drive of ``test_ekf_scales`` (turning in place at the room's
    walls); returns the filter and its position RMSE over the second half (m)."""
    rng = np.random.default_rng(11)
    cfg = small_config(nav_x=0.0)
    start = (5.0, 5.0, 0.3)
    pf = ParticleFilter(ParticleFilter.configure(odometry_scales=scales, particles=1000, kld=False,
                                                 sigma_range_m=0.03, sigma_range_per_m=0.02,
                                                 sigma_bearing_rad=0.01, noise_dist=0.03,
                                                 noise_lat=0.02, noise_rot=0.03,
                                                 noise_rot_per_m=0.02, scale_sigma_v=0.1,
                                                 scale_sigma_w=0.1, scale_walk_v=0.002,
                                                 scale_walk_w=0.002, recovery=False),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=start, rng=np.random.default_rng(5))
    # a camera frame every 5 s: the odometry's bias matters in between
    return pf, run_biased(pf, start, seconds, rng, every=20)


def test_pf_learns_the_odometry_scales() -> None:
    pf, rmse = run_pf(scales=True)
    cal = pf.odometry_calibration
    assert cal["s_v"] == pytest.approx(TRUE_SCALE_V, abs=0.03)
    assert cal["s_w"] == pytest.approx(TRUE_SCALE_W, abs=0.04)
    plain, plain_rmse = run_pf(scales=False)
    assert plain.odometry_calibration == {}
    assert rmse < 0.8 * plain_rmse


def test_the_scales_follow_resampling() -> None:
    """Every particle keeps its own scales through resampling: after updates the set holds
    as many scales as particles, and they are no longer the prior's spread around 1."""
    pf, _ = run_pf(scales=True, seconds=60.0)
    assert len(pf.s_v) == len(pf.z) == len(pf.s_w)
    assert pf.resamplings > 0
    # the prior's spread is 0.1: resampling keeps the scales that explain the landmarks
    assert float(np.std(pf.s_v)) < 0.06


def scan_from(pose: tuple[float, float, float], ids: list[int]) -> ScanObservation:
    """Exact ranges and bearings of the landmarks ``ids`` seen from ``pose``."""
    x, y, th = pose
    by_id = {r.id: r for r in REFLECTORS}
    ranges = [math.hypot(by_id[i].x - x, by_id[i].y - y) for i in ids]
    bearings = [math.remainder(math.atan2(by_id[i].y - y, by_id[i].x - x) - th, 2 * math.pi)
                for i in ids]
    return ScanObservation.simple(0.0, ranges, bearings, ids)


def test_weighted_fix_recovers_the_pose_with_a_covariance_from_the_geometry() -> None:
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    pose = (5.0, 4.0, 0.4)
    by_dist = sorted(REFLECTORS, key=lambda r: math.hypot(r.x - 5.0, r.y - 4.0))
    ids = [r.id for r in by_dist[:3]]
    fix = weighted_fix(scan_from(pose, ids), rmap, 0.1, 0.1, 0.01)
    assert fix is not None
    assert fix[0] == pytest.approx(pose, abs=1e-6)
    sd = np.sqrt(np.diag(fix[1]))
    assert (sd > 0.0).all()
    # two landmarks only: a less certain fix than three
    two = weighted_fix(scan_from(pose, ids[:2]), rmap, 0.1, 0.1, 0.01)
    assert two is not None
    assert np.linalg.det(two[1]) > np.linalg.det(fix[1])


def test_start_fix_refuses_a_fix_worse_than_the_limit() -> None:
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    obs = scan_from((5.0, 4.0, 0.4), [r.id for r in REFLECTORS[:2]])

    class P:
        use_ids = True
        init_fix = "weighted"
        sigma_range_m, sigma_range_per_m, sigma_bearing_rad = 0.1, 0.3, 0.01
        init_max_sigma_xy_m = 0.0

    got = start_fix(obs, 0.0, 0.0, rmap, P())
    assert got is not None and got[1] is not None
    worst = math.sqrt(float(np.linalg.eigvalsh(got[1][:2, :2])[-1]))
    P.init_max_sigma_xy_m = 0.5 * worst
    assert start_fix(obs, 0.0, 0.0, rmap, P()) is None
    P.init_max_sigma_xy_m = 2.0 * worst
    assert start_fix(obs, 0.0, 0.0, rmap, P()) is not None
