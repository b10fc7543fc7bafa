"""``pf`` Rao-Blackwellised over the pose (``proposal = marginal``): each particle keeps the
Gaussian of its frame's Kalman step instead of a draw from it; its start is the EKF's; the
Gaussians follow resampling and add to the estimate's covariance; with few particles it tracks
a drive whose heading noise loses the drawn proposal, and learns the odometry's scales."""

from __future__ import annotations

import numpy as np
import pytest
from localize_synth import small_config
from test_ekf_scales import TRUE_SCALE_V, TRUE_SCALE_W, run_biased
from test_pf_proposal import run_both_paths, run_turning, scan_from

from lgvtool.localize.estimator import Motion
from lgvtool.localize.particle_filter import ParticleFilter


def one_particle(proposal: str = "marginal", **settings: object) -> ParticleFilter:
    """A one-particle ``pf`` (``proposal`` marginal unless said) at (5, 5, 0.3) with the
    camera-like noise of ``test_pf_proposal``'s one-particle case."""
    cfg = small_config(nav_x=0.0)
    return ParticleFilter(ParticleFilter.configure(particles=1, kld=False, proposal=proposal,
                                                   sigma_range_m=0.05, sigma_bearing_rad=0.01,
                                                   noise_dist=0.1, noise_lat=0.05, noise_rot=0.5,
                                                   noise_rot_per_m=0.1, recovery=False,
                                                   **settings),
                          vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                          initial_pose=(5.0, 5.0, 0.3), rng=np.random.default_rng(0))


def test_the_start_is_the_ekf_start_one_gaussian_per_particle() -> None:
    """Every particle at the start pose, each carrying the start spread as its covariance."""
    cfg = small_config(nav_x=0.0)
    pf = ParticleFilter(ParticleFilter.configure(particles=50, proposal="marginal",
                                                 init_sigma_xy_m=0.4, init_sigma_heading_rad=0.2),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=(2.0, 3.0, 0.5), rng=np.random.default_rng(1))
    np.testing.assert_allclose(pf.z, 2.0 + 3.0j, atol=0.0)
    np.testing.assert_allclose(pf.th, 0.5, atol=0.0)
    assert pf._pcov is not None and pf._pcov.shape == (50, 3, 3)
    np.testing.assert_allclose(pf._pcov, np.diag([0.16, 0.16, 0.04])[None].repeat(50, axis=0),
                               atol=1e-15)
    e = pf.estimate()
    assert e is not None
    np.testing.assert_allclose(np.asarray(e.covariance).reshape(3, 3),
                               np.diag([0.16, 0.16, 0.04]), atol=1e-12)


def test_a_frame_moves_the_particle_to_its_kalman_posterior_and_keeps_its_covariance() -> None:
    """After a frame, the particle is the Kalman step's posterior mean and carries its
    posterior covariance (no draw), and the estimate's covariance is that covariance."""
    pf = one_particle(init_sigma_xy_m=0.0, init_sigma_heading_rad=0.0)
    pf.predict(Motion(0.5, 0.0, 0.2, 0.5, 0.2))
    prior = np.array([pf.z[0].real, pf.z[0].imag, pf.th[0]])
    obs = scan_from((5.5, 5.1, 0.45), [4, 5, 9])
    prop, _ = pf.ekf_proposal(obs)
    state = pf.rng.bit_generator.state
    assert pf.update(obs)
    got = np.array([pf.z[0].real, pf.z[0].imag, pf.th[0]])
    np.testing.assert_allclose(got, prior + prop.d[0], rtol=0.0, atol=1e-12)
    assert pf._pcov is not None
    np.testing.assert_allclose(pf._pcov[0], prop.cov[0], rtol=0.0, atol=1e-15)
    # the posterior is narrower than the prediction in every direction
    assert np.linalg.eigvalsh(prop.cov[0]).max() < 0.05 ** 2 * 10
    assert pf.rng.bit_generator.state == state  # nothing drawn
    e = pf.estimate()
    assert e is not None
    np.testing.assert_allclose(np.asarray(e.covariance).reshape(3, 3), prop.cov[0],
                               rtol=0.0, atol=1e-12)
    # the drawn proposal of the same frame puts the particle off that mean, with no spread
    drawn = one_particle("ekf", init_sigma_xy_m=0.0, init_sigma_heading_rad=0.0)
    drawn.predict(Motion(0.5, 0.0, 0.2, 0.5, 0.2))
    assert drawn.update(obs)
    off = np.array([drawn.z[0].real, drawn.z[0].imag, drawn.th[0]]) - got
    assert np.abs(off).max() > 1e-4
    assert drawn._pcov is None


def test_the_gaussians_follow_resampling() -> None:
    """Resampling copies each particle's covariance with it, and a particle recovery re-draws
    starts with none of its own."""
    cfg = small_config(nav_x=0.0)
    pf = ParticleFilter(ParticleFilter.configure(particles=20, kld=False, proposal="marginal",
                                                 recovery=False),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=(5.0, 5.0, 0.3), rng=np.random.default_rng(2))
    assert pf._pcov is not None
    pf._pcov = np.arange(1.0, 21.0)[:, None, None] * np.eye(3)[None]
    pf.z = pf.z + np.arange(20) * 0.01
    pf.w = np.zeros(20)
    pf.w[7] = 1.0
    obs = scan_from((5.0, 5.0, 0.3), [4, 5, 9])
    pf._resample("scan", obs, 0.0)
    np.testing.assert_allclose(pf.z, 5.07 + 5.0j, atol=1e-12)
    np.testing.assert_allclose(pf._pcov, 8.0 * np.eye(3)[None].repeat(20, axis=0), atol=0.0)
    # recovery: a quarter re-drawn around the scan's fix, with no covariance of their own
    rec = ParticleFilter(ParticleFilter.configure(particles=20, kld=False, proposal="marginal"),
                         vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                         initial_pose=(5.0, 5.0, 0.3), rng=np.random.default_rng(3))
    rec._resample("scan", obs, 0.25)
    assert rec.injected == 5
    assert rec._pcov is not None
    np.testing.assert_allclose(rec._pcov[:5], 0.0, atol=0.0)
    assert (rec._pcov[5:, 0, 0] > 0.0).all()


def test_the_marginal_filter_tracks_where_the_prior_proposal_fails() -> None:
    """The drive of ``test_pf_proposal`` whose heading noise nearly resets the heading at every
    turn: the marginal filter tracks it as the drawn EKF proposal does (measured 0.08-0.11 m
    against 0.09-0.10 m; the prior proposal 0.4-1.4 m), and with 20 particles it still tracks
    (0.08-0.16 m) where 20 drawn ones lose it on seed 1 (2.9 m)."""
    for seed in (0, 1, 2):
        marginal = run_turning("marginal", 200, seed)
        assert marginal < 0.15
        assert marginal < 1.5 * run_turning("ekf", 200, seed)
        assert run_turning("marginal", 20, seed) < 0.25
    assert run_turning("ekf", 20, 1) > 1.0


def test_the_marginal_filter_learns_the_odometry_scales() -> None:
    """The biased drive of ``test_ekf_scales`` with a camera frame every 5 s: the weighted
    scales come out at the true ones, and the track beats the filter without scales."""
    def run(scales: bool) -> tuple[ParticleFilter, float]:
        cfg = small_config(nav_x=0.0)
        start = (5.0, 5.0, 0.3)
        pf = ParticleFilter(ParticleFilter.configure(odometry_scales=scales, particles=200,
                                                     kld=False, proposal="marginal",
                                                     sigma_range_m=0.03, sigma_range_per_m=0.02,
                                                     sigma_bearing_rad=0.01, noise_dist=0.03,
                                                     noise_lat=0.02, noise_rot=0.03,
                                                     noise_rot_per_m=0.02, scale_sigma_v=0.1,
                                                     scale_sigma_w=0.1, scale_walk_v=0.002,
                                                     scale_walk_w=0.002, recovery=False),
                            vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                            initial_pose=start, rng=np.random.default_rng(5))
        return pf, run_biased(pf, start, 400.0, np.random.default_rng(11), every=20)

    pf, rmse = run(True)
    cal = pf.odometry_calibration
    assert cal["s_v"] == pytest.approx(TRUE_SCALE_V, abs=0.02)
    assert cal["s_w"] == pytest.approx(TRUE_SCALE_W, abs=0.03)
    _, plain_rmse = run(False)
    assert rmse < 0.8 * plain_rmse


def test_the_compiled_marginal_step_matches_the_numpy_path(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Same seed: the kernels' Kalman step and posterior covariance give the numpy path's
    estimates within 1e-9 m (rad) and covariances within 1e-12, with the same random
    stream."""
    got = run_both_paths(monkeypatch, "marginal", 100)
    a, b = got["numba"], got["numpy"]
    assert b.resamplings > 0
    np.testing.assert_allclose(np.array(a.trace), np.array(b.trace), rtol=0.0, atol=1e-9)
    assert a._pcov is not None and b._pcov is not None
    np.testing.assert_allclose(a._pcov, b._pcov, rtol=0.0, atol=1e-12)
    assert a.rng.bit_generator.state == b.rng.bit_generator.state
