"""The EKF's iterated reflector update (``update_iterations``): the relinearised update lands on
the frame's posterior mode, and a near-linear frame gives the single update's result (the single
update itself, the default, is checked against the compiled kernels in test_ekf_kernels)."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from localize_synth import REFLECTORS, small_config

from lgvtool.errors import ConfigError
from lgvtool.localize.ekf import Ekf
from lgvtool.localize.observations import ScanObservation

TRUE_POSE = (4.0, 3.0, 0.4)
"""Where the vehicle is (x, y m, heading rad)."""
SIGMA_RANGE_M = 0.1
SIGMA_BEARING_RAD = 0.0125
"""A camera's noise: ranges poor, bearings good (m, rad)."""
SEEN = (2, 4, 9)
"""The reflector ids of the frame (all ahead of the vehicle)."""


def frame(pose: tuple[float, float, float]) -> ScanObservation:
    """Range and bearing, without noise, of :data:`SEEN` from a sensor at the vehicle's origin
    at ``pose``."""
    x, y, th = pose
    refl = {r.id: r for r in REFLECTORS}
    ex = np.array([refl[i].x - x for i in SEEN])
    ey = np.array([refl[i].y - y for i in SEEN])
    bx, by = math.cos(th) * ex + math.sin(th) * ey, -math.sin(th) * ex + math.cos(th) * ey
    q = (bx + 1j * by).astype(np.complex128)
    ranges = np.abs(q)
    u = (q / ranges).astype(np.complex128)
    return ScanObservation(10.0, q, u, ranges, np.array(SEEN, dtype=np.int64))


def filter_at(prior: tuple[float, float, float], sigma_xy_m: float, sigma_heading_rad: float,
              iterations: int) -> Ekf:
    """An EKF on :func:`small_config`'s layout with the sensor at the vehicle's origin, its
    mean at ``prior`` with the given standard deviations (m, rad)."""
    config = small_config(nav_x=0.0)
    params = Ekf.configure(sigma_range_m=SIGMA_RANGE_M, sigma_bearing_rad=SIGMA_BEARING_RAD,
                           gate_probability=0.999999, update_iterations=iterations)
    ekf = Ekf(params, vehicle=config.vehicle, reflectors=config.reflectors,
              initial_pose=prior)
    ekf.P = np.diag([sigma_xy_m ** 2, sigma_xy_m ** 2, sigma_heading_rad ** 2])
    return ekf


def posterior_cost(ekf: Ekf, pose: np.ndarray, prior: np.ndarray, P0: np.ndarray,
                   obs: ScanObservation) -> float:
    """Minus twice the log posterior of ``pose`` (up to a constant): the prior's squared
    Mahalanobis distance plus the frame's, each reflector at its id."""
    d = pose - prior
    d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
    nr, nb, _, _ = ekf._scan_geometry((float(pose[0]), float(pose[1]), float(pose[2])), obs)
    j = obs.map_index(ekf.map)
    k = np.arange(len(obs))
    return float(d @ np.linalg.solve(P0, d)
                 + (nr[k, j] ** 2 / SIGMA_RANGE_M ** 2).sum()
                 + (nb[k, j] ** 2 / SIGMA_BEARING_RAD ** 2).sum())


def gradient(f: Callable[[np.ndarray], float], x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of ``f`` at ``x``."""
    out = np.empty(3)
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        out[i] = (f(x + e) - f(x - e)) / (2.0 * h)
    return out


def test_the_iterated_update_lands_on_the_posterior_mode() -> None:
    # a metre and 0.3 rad off, with a prior as wide: far from linear over the prior
    prior = (TRUE_POSE[0] + 0.7, TRUE_POSE[1] - 0.6, TRUE_POSE[2] + 0.3)
    obs = frame(TRUE_POSE)
    results = {}
    for iterations in (1, 20):
        ekf = filter_at(prior, 1.0, 0.5, iterations)
        P0, mu0 = ekf.P.copy(), np.array(prior)
        assert ekf.update(obs)
        assert ekf.mu is not None

        def cost(x: np.ndarray, ekf: Ekf = ekf, P0: np.ndarray = P0,
                 mu0: np.ndarray = mu0) -> float:
            return posterior_cost(ekf, x, mu0, P0, obs)

        results[iterations] = (ekf.mu.copy(), cost(ekf.mu), gradient(cost, ekf.mu))
    single, iterated = results[1], results[20]
    # the mode: the gradient of the cost vanishes there (its scale: 1 / sigma^2 per m or rad)
    assert np.abs(iterated[2]).max() < 1e-3
    assert np.abs(single[2]).max() > 10.0
    assert iterated[1] < single[1]
    # and with noise-free bearings the mode is the true pose, to well within the noise
    err = np.hypot(iterated[0][0] - TRUE_POSE[0], iterated[0][1] - TRUE_POSE[1])
    assert err < 0.01
    assert np.hypot(single[0][0] - TRUE_POSE[0], single[0][1] - TRUE_POSE[1]) > 5 * err


def test_a_near_linear_frame_gives_the_single_update() -> None:
    # 2 cm and 5 mrad off with a prior as narrow: one linearisation is already the mode
    prior = (TRUE_POSE[0] + 0.02, TRUE_POSE[1] - 0.01, TRUE_POSE[2] + 0.005)
    obs = frame(TRUE_POSE)
    means = []
    for iterations in (1, 20):
        ekf = filter_at(prior, 0.02, 0.005, iterations)
        assert ekf.update(obs)
        assert ekf.mu is not None
        means.append(ekf.mu.copy())
    assert means[1] == pytest.approx(means[0], abs=2e-5)


@pytest.mark.parametrize("value", [0, 51, 2.5])
def test_an_iteration_count_out_of_range_is_refused(value: object) -> None:
    with pytest.raises(ConfigError, match=r"ekf\.update_iterations"):
        Ekf.configure(update_iterations=value)
