"""``pf`` with the measurement-informed proposal (``proposal = ekf``): the Kalman step and the
importance weight against their textbook forms, the ray residual's Jacobian, a drive the
prior proposal loses and the EKF proposal tracks with as many particles, and the default
(``proposal = prior``) unchanged."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from localize_synth import REFLECTORS, small_config
from test_ekf_scales import run_biased

from lgvtool.localize.estimator import Estimate, Motion
from lgvtool.localize.observations import ScanObservation
from lgvtool.localize.particle_backend import NumpyParticles
from lgvtool.localize.particle_filter import ParticleFilter, PfParams
from lgvtool.localize.pf_proposal import (
    gaussian_offsets,
    kalman_proposal,
    log_weight_correction,
    predict_covariance,
    ray_residuals,
)


def log_normal(x: np.ndarray, mean: np.ndarray, cov: np.ndarray) -> float:
    """Log density of ``N(mean, cov)`` at ``x``."""
    d = x - mean
    _, logdet = np.linalg.slogdet(2.0 * math.pi * cov)
    return float(-0.5 * (d @ np.linalg.solve(cov, d) + logdet))


def random_case(rng: np.random.Generator, k: int) -> tuple[np.ndarray, ...]:
    """One particle: a prior covariance (3 x 3), residuals (1, k, 2), Jacobians (1, k, 2, 3)
    and the noise along and across each ray (k)."""
    g = rng.standard_normal((3, 3))
    cov = g @ g.T * 0.05 + np.diag([0.01, 0.02, 0.03])
    r = rng.standard_normal((1, k, 2)) * 0.2
    jac = rng.standard_normal((1, k, 2, 3))
    sr = 0.05 + 0.1 * rng.random(k)
    st = 0.02 + 0.05 * rng.random(k)
    return cov, r, jac, sr, st


def test_the_proposal_is_the_kalman_update_in_the_linear_gaussian_case() -> None:
    rng = np.random.default_rng(1)
    for k in (1, 2, 4):
        cov, r, jac, sr, st = random_case(rng, k)
        prop = kalman_proposal(cov[None], r, jac, sr, st, math.inf)
        h = jac[0].reshape(2 * k, 3)
        noise = np.diag(np.column_stack((sr, st)).reshape(-1) ** 2)
        s = h @ cov @ h.T + noise
        gain = cov @ h.T @ np.linalg.inv(s)
        # residual r = h(x) - z: the update moves the mean by -K r
        np.testing.assert_allclose(prop.d[0], -gain @ r[0].reshape(-1), rtol=0.0, atol=1e-9)
        np.testing.assert_allclose(prop.cov[0], (np.eye(3) - gain @ h) @ cov, rtol=0.0,
                                   atol=1e-9)
        const = -float(np.sum(np.log(2.0 * math.pi * sr * st)))
        evidence = log_normal(r[0].reshape(-1), np.zeros(2 * k), s)
        assert prop.log_evidence[0] + const == pytest.approx(evidence, abs=1e-9)


def test_the_weight_is_prior_times_likelihood_over_proposal() -> None:
    """The weight of a draw x is p(z | x) N(x; 0, P) / q(x); the correction is its factor
    N(x; 0, P) / q(x) (= N(r; 0, S) / p_lin(z | x) for the linearised model), at any x."""
    rng = np.random.default_rng(2)
    cov, r, jac, sr, st = random_case(rng, 3)
    prop = kalman_proposal(cov[None], r, jac, sr, st, math.inf)
    for _ in range(5):
        x = rng.standard_normal(3) * 0.3
        want = log_normal(x, np.zeros(3), cov) - log_normal(x, prop.d[0], prop.cov[0])
        got = float(log_weight_correction(prop, x[None])[0])
        assert got == pytest.approx(want, abs=1e-9)


def test_the_gate_leaves_a_far_landmark_out_of_the_proposal_only() -> None:
    rng = np.random.default_rng(3)
    cov, r, jac, sr, st = random_case(rng, 2)
    r[0, 1] = [50.0, -40.0]     # a misread landmark
    prop = kalman_proposal(cov[None], r, jac, sr, st, 13.8)
    assert prop.used.tolist() == [[True, False]]
    alone = kalman_proposal(cov[None], r[:, :1], jac[:, :1], sr[:1], st[:1], 13.8)
    np.testing.assert_allclose(prop.d, alone.d, rtol=0.0, atol=1e-12)
    np.testing.assert_allclose(prop.cov, alone.cov, rtol=0.0, atol=1e-12)


def test_ray_residual_jacobian_matches_finite_differences() -> None:
    obs = ScanObservation.simple(0.0, [3.0, 5.5], [0.3, -0.8], [1, 4], nav_x=0.4, nav_y=0.1)
    landmarks = np.array([[2.0 + 1.0j, 6.0 + 4.0j]])
    pose = np.array([1.2, 0.7, 0.5])

    def resid(p: np.ndarray) -> np.ndarray:
        z = np.array([p[0] + 1j * p[1]])
        rot = np.exp(1j * np.array([p[2]]))
        return ray_residuals(z, rot, landmarks, obs.q, obs.u)[0][0].reshape(-1)

    _, jac = ray_residuals(np.array([pose[0] + 1j * pose[1]]), np.exp(1j * pose[2:]),
                           landmarks, obs.q, obs.u)
    numeric = np.empty((4, 3))
    for i in range(3):
        h = np.zeros(3)
        h[i] = 1e-6
        numeric[:, i] = (resid(pose + h) - resid(pose - h)) / 2e-6
    np.testing.assert_allclose(jac[0].reshape(4, 3), numeric, rtol=0.0, atol=1e-7)


def test_one_step_covariance_is_the_motion_noise_and_draws_follow_it() -> None:
    rot = np.exp(1j * np.array([0.0, 0.7]))
    step = rot * complex(0.5, 0.1)
    cov = predict_covariance(np.zeros((2, 3, 3)), rot, step, (0.1, 0.05, 0.2))
    c, s = math.cos(0.7), math.sin(0.7)
    rmat = np.array([[c, -s], [s, c]])
    np.testing.assert_allclose(cov[1, :2, :2], rmat @ np.diag([0.01, 0.0025]) @ rmat.T,
                               atol=1e-15)
    assert cov[1, 2, 2] == pytest.approx(0.04)
    # F P F^T for a prior heading variance: the heading's uncertainty swings the position
    prior = np.zeros((1, 3, 3))
    prior[0, 2, 2] = 0.01
    f = np.array([[1.0, 0.0, -step[1].imag], [0.0, 1.0, step[1].real], [0.0, 0.0, 1.0]])
    got = predict_covariance(prior, rot[1:], step[1:], (0.0, 0.0, 0.0))
    np.testing.assert_allclose(got[0], f @ prior[0] @ f.T, atol=1e-15)
    # draws: the sample covariance of many draws, and a singular covariance drawn inside
    g = np.random.default_rng(4).standard_normal((20000, 3))
    d = gaussian_offsets(np.broadcast_to(cov[1], (20000, 3, 3)), g)
    np.testing.assert_allclose(np.cov(d.T), cov[1], atol=2e-3)
    flat = np.zeros((1, 3, 3))
    flat[0, 0, 0] = flat[0, 0, 1] = flat[0, 1, 0] = flat[0, 1, 1] = 1.0
    x = gaussian_offsets(flat, np.array([[1.0, 2.0, 3.0]]))
    assert x[0, 0] == pytest.approx(x[0, 1]) and x[0, 2] == 0.0


def test_one_particle_filter_proposal_is_the_kalman_update_of_its_frame() -> None:
    """The filter's own proposal for one particle equals a Kalman update computed here from
    the ray residual and its finite-difference Jacobian."""
    cfg = small_config(nav_x=0.0)
    pf = ParticleFilter(ParticleFilter.configure(particles=1, kld=False, proposal="ekf",
                                                 init_sigma_xy_m=0.0, init_sigma_heading_rad=0.0,
                                                 sigma_range_m=0.05, sigma_bearing_rad=0.01,
                                                 noise_dist=0.1, noise_lat=0.05, noise_rot=0.5,
                                                 noise_rot_per_m=0.1),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=(5.0, 5.0, 0.3), rng=np.random.default_rng(0))
    pf.predict(Motion(0.5, 0.0, 0.2, 0.5, 0.2))
    prior_mean = np.array([pf.z[0].real, pf.z[0].imag, pf.th[0]])
    assert pf._pcov is not None
    prior_cov = pf._pcov[0].copy()
    truth = (5.5, 5.1, 0.45)
    obs = scan_from(truth, [4, 5, 9])
    prop, cov = pf.ekf_proposal(obs)
    np.testing.assert_allclose(cov[0], prior_cov, atol=0.0)
    sr, st = pf.ray_sigmas(obs)
    lm = np.array([[complex(r.x, r.y) for r in REFLECTORS if r.id in (4, 5, 9)]])

    def resid(p: np.ndarray) -> np.ndarray:
        return ray_residuals(np.array([p[0] + 1j * p[1]]), np.exp(1j * p[2:]), lm, obs.q,
                             obs.u)[0][0].reshape(-1)

    h = np.empty((6, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = 1e-6
        h[:, i] = (resid(prior_mean + e) - resid(prior_mean - e)) / 2e-6
    noise = np.diag(np.column_stack((sr, st)).reshape(-1) ** 2)
    gain = prior_cov @ h.T @ np.linalg.inv(h @ prior_cov @ h.T + noise)
    np.testing.assert_allclose(prop.d[0], -gain @ resid(prior_mean), rtol=0.0, atol=1e-7)
    np.testing.assert_allclose(prop.cov[0], (np.eye(3) - gain @ h) @ prior_cov, rtol=0.0,
                               atol=1e-9)


def scan_from(pose: tuple[float, float, float], ids: list[int],
              rng: np.random.Generator | None = None, sigma_b: float = 0.0,
              sigma_r: float = 0.0) -> ScanObservation:
    """Ranges and bearings of the landmarks ``ids`` seen from ``pose`` (with noise from
    ``rng``: ``sigma_r`` m, ``sigma_b`` rad)."""
    x, y, th = pose
    by_id = {r.id: r for r in REFLECTORS}
    ranges = np.array([math.hypot(by_id[i].x - x, by_id[i].y - y) for i in ids])
    bearings = np.array([math.remainder(math.atan2(by_id[i].y - y, by_id[i].x - x) - th,
                                        2 * math.pi) for i in ids])
    if rng is not None:
        ranges = ranges + sigma_r * rng.standard_normal(len(ids))
        bearings = bearings + sigma_b * rng.standard_normal(len(ids))
    return ScanObservation.simple(0.0, ranges, bearings, ids)


def run_turning(proposal: str, particles: int, seed: int) -> float:
    """``pf`` with a large heading noise (every turn nearly resets the heading), sharp bearings
    (5 mrad) and the odometry scales over 200 s of the biased drive of ``test_ekf_scales``,
    a camera frame every 2 s; its position RMSE over the second half, m."""
    cfg = small_config(nav_x=0.0)
    start = (5.0, 5.0, 0.3)
    pf = ParticleFilter(ParticleFilter.configure(particles=particles, kld=False, recovery=False,
                                                 proposal=proposal, odometry_scales=True,
                                                 sigma_range_m=0.05, sigma_range_per_m=0.02,
                                                 sigma_bearing_rad=0.005, noise_dist=0.2,
                                                 noise_lat=0.2, noise_rot=3.0,
                                                 noise_rot_per_m=0.3),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=start, rng=np.random.default_rng(seed + 100))
    return run_biased(pf, start, 200.0, np.random.default_rng(seed), every=8)


def test_the_ekf_proposal_tracks_where_the_prior_proposal_with_as_many_particles_fails() -> None:
    for seed in (0, 1):
        ekf = run_turning("ekf", 200, seed)
        prior = run_turning("prior", 200, seed)
        assert ekf < 0.15
        assert prior > 0.3
        assert ekf < 0.4 * prior


def run_default(**settings: object) -> float:
    """``pf`` with its defaults (but for 300 particles, the camera's noise, motion noise that
    covers the odometry's bias, and ``settings``) over 60 s of the biased drive of
    ``test_ekf_scales``; its position RMSE, m."""
    cfg = small_config(nav_x=0.0)
    start = (5.0, 5.0, 0.3)
    pf = ParticleFilter(ParticleFilter.configure(particles=300, sigma_range_m=0.05,
                                                 sigma_range_per_m=0.02, sigma_bearing_rad=0.005,
                                                 noise_dist=0.1, noise_lat=0.05, noise_rot=0.15,
                                                 noise_rot_per_m=0.05, **settings),
                        vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                        initial_pose=start, rng=np.random.default_rng(22))
    return run_biased(pf, start, 60.0, np.random.default_rng(21), every=8)


#: ``run_default()`` with the default prior proposal, m (before the association checked ids
#: against their gate and weighed a mismatch, lgvtool.localize.association: 0.5686558564748148;
#: before the prior proposal's jitter, ``jitter_m``, ``jitter_rad``: 0.5686885599951229)
DEFAULT_RMSE = 0.5017012149958955


def test_the_default_proposal_leaves_pf_unchanged() -> None:
    assert ParticleFilter().params.proposal == "prior"
    got = run_default()
    # a pin against an unintended change of the default filter, to 3 cm (the ekf and marginal
    # proposals give 0.64 and 0.63 m here, the prior without its jitter 0.57 m): on another CPU
    # the last bits of numpy's vectorised trigonometry may send a resampling another way
    assert got == pytest.approx(DEFAULT_RMSE, abs=0.03)
    assert run_default(proposal="prior") == got


class Traced(ParticleFilter):
    """``pf`` recording every estimate (m, m, rad)."""

    def __init__(self, params: PfParams | None = None, **context: Any) -> None:
        super().__init__(params, **context)
        self.trace: list[tuple[float, float, float]] = []

    def estimate(self) -> Estimate | None:
        e = super().estimate()
        if e is not None:
            self.trace.append((e.x, e.y, e.heading))
        return e


def run_both_paths(monkeypatch: pytest.MonkeyPatch, proposal: str,
                   particles: int) -> dict[str, Traced]:
    """The biased drive of ``test_ekf_scales`` (40 s, a frame every 8 steps) with ``proposal``,
    seed 8, once on the numpy path and once on the kernels: the two filters by path."""
    pytest.importorskip("numba")
    from lgvtool.localize.kernel_choice import KERNELS_ENV

    got = {}
    for mode in ("numpy", "numba"):
        monkeypatch.setenv(KERNELS_ENV, mode)
        cfg = small_config(nav_x=0.0)
        start = (5.0, 5.0, 0.3)
        pf = Traced(Traced.configure(particles=particles, kld=False, proposal=proposal,
                                     odometry_scales=True, sigma_range_m=0.05,
                                     sigma_bearing_rad=0.005, noise_rot=1.0),
                    vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                    initial_pose=start, rng=np.random.default_rng(8))
        assert isinstance(pf.backend, NumpyParticles) == (mode == "numpy")
        run_biased(pf, start, 40.0, np.random.default_rng(9), every=8)
        assert len(pf.trace) > 100
        got[mode] = pf
    return got


def test_the_compiled_proposal_matches_the_numpy_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """Same seed: the kernels' Kalman step, draw and correction give the numpy path's
    estimates within 1e-9 m (rad), with the same random stream."""
    got = run_both_paths(monkeypatch, "ekf", 200)
    np.testing.assert_allclose(np.array(got["numba"].trace), np.array(got["numpy"].trace),
                               rtol=0.0, atol=1e-9)
    assert got["numba"].rng.bit_generator.state == got["numpy"].rng.bit_generator.state
