"""``pf``'s global localisation aids: a large uniform start that shrinks
(``start_particles``, ``start_updates``), the reset around a landmark fix that contradicts a
confident cloud (``fix_reset_probability``), and the fix's own residual that decides whether a
fix can be trusted (:func:`lgvtool.localize.camera_fix.residual_chi2`)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from localize_synth import REFLECTORS, small_config
from test_pf_scales import scan_from

from lgvtool.localize.camera_fix import residual_chi2, weighted_fix
from lgvtool.localize.observations import ReflectorMap
from lgvtool.localize.particle_filter import ParticleFilter

TRUE_POSE = (5.0, 4.0, 0.4)
"""Where the vehicle is, m, m, rad."""
NOISE = (0.1, 0.1, 0.02)
"""sigma_range_m, sigma_range_per_m, sigma_bearing_rad of the filters and fixes here."""


def nearest_ids(n: int) -> list[int]:
    """The ``n`` landmarks nearest :data:`TRUE_POSE`."""
    by_dist = sorted(REFLECTORS, key=lambda r: math.hypot(r.x - TRUE_POSE[0],
                                                          r.y - TRUE_POSE[1]))
    return [r.id for r in by_dist[:n]]


def test_residual_chi2_is_zero_at_the_pose_and_grows_away_from_it() -> None:
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    obs = scan_from(TRUE_POSE, nearest_ids(3))
    assert residual_chi2(TRUE_POSE, obs, rmap, *NOISE) == pytest.approx(0.0, abs=1e-9)
    near = residual_chi2((5.1, 4.0, 0.4), obs, rmap, *NOISE)
    far = residual_chi2((6.0, 4.0, 0.4), obs, rmap, *NOISE)
    assert 0.0 < near < far


def test_a_scan_with_a_misread_id_fits_no_pose() -> None:
    """Landmarks that contradict each other (one id swapped for another's) leave a large
    residual at the weighted fix; consistent ones leave none."""
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    ids = nearest_ids(3)
    good = scan_from(TRUE_POSE, ids)
    fix = weighted_fix(good, rmap, *NOISE)
    assert fix is not None
    assert residual_chi2(fix[0], good, rmap, *NOISE) == pytest.approx(0.0, abs=1e-6)
    misread = scan_from(TRUE_POSE, ids)
    other = next(r.id for r in REFLECTORS if r.id not in ids)
    misread.ids[0] = other
    bad = weighted_fix(misread, rmap, *NOISE)
    assert bad is not None
    # far beyond the 99.9 % quantile of chi-square with 3 degrees of freedom (16.3)
    assert residual_chi2(bad[0], misread, rmap, *NOISE) > 16.3


def filter_at(pose: tuple[float, float, float], **kw: object) -> ParticleFilter:
    """A ``pf`` around ``pose`` with a tight start and the weighted fix."""
    cfg = small_config(nav_x=0.0)
    settings: dict[str, object] = dict(
        particles=1000, kld=False, init_fix="weighted", init_max_sigma_xy_m=1.5,
        init_sigma_xy_m=0.05, init_sigma_heading_rad=0.02, sigma_range_m=NOISE[0],
        sigma_range_per_m=NOISE[1], sigma_bearing_rad=NOISE[2], reset_likelihood=0.0,
        alpha_slow=0.0)
    settings.update(kw)
    return ParticleFilter(ParticleFilter.configure(**settings),
                          vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                          initial_pose=pose, rng=np.random.default_rng(3))


def position_error(pf: ParticleFilter) -> float:
    est = pf.estimate()
    assert est is not None
    return math.hypot(est.x - TRUE_POSE[0], est.y - TRUE_POSE[1])


def test_a_fix_that_contradicts_a_confident_cloud_resets_it() -> None:
    wrong = (7.0, 6.0, 0.4)  # 2.8 m off, and confident (5 cm)
    obs = scan_from(TRUE_POSE, nearest_ids(3))
    on = filter_at(wrong, fix_reset_probability=0.99, fix_reset_fraction=0.5)
    off = filter_at(wrong, fix_reset_probability=0.0)
    for _ in range(3):
        assert on.update(obs) and off.update(obs)
    assert on.injected > 0 and off.injected == 0
    assert position_error(on) < 0.2
    assert position_error(off) > 2.0


def test_a_fix_that_agrees_or_fits_nothing_resets_nothing() -> None:
    ids = nearest_ids(3)
    right = filter_at(TRUE_POSE, fix_reset_probability=0.99)
    for _ in range(3):
        assert right.update(scan_from(TRUE_POSE, ids))
    assert right.injected == 0
    misread = scan_from(TRUE_POSE, ids)
    misread.ids[0] = next(r.id for r in REFLECTORS if r.id not in ids)
    wrong = filter_at((7.0, 6.0, 0.4), fix_reset_probability=0.99)
    assert wrong.update(misread)
    assert wrong.injected == 0


def uniform_pf(seed: int, **kw: object) -> ParticleFilter:
    """A ``pf`` with 500 particles and a uniform start over the 10 m x 10 m room."""
    cfg = small_config(nav_x=0.0)
    return ParticleFilter(ParticleFilter.configure(init="uniform", particles=500, kld=False,
                                                   sigma_range_m=NOISE[0],
                                                   sigma_range_per_m=NOISE[1],
                                                   sigma_bearing_rad=NOISE[2],
                                                   reset_likelihood=0.0, alpha_slow=0.0, **kw),
                          vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area,
                          rng=np.random.default_rng(seed))


def test_a_large_uniform_start_shrinks_after_its_updates() -> None:
    obs = scan_from(TRUE_POSE, nearest_ids(3))
    pf = uniform_pf(1, start_particles=8000, start_updates=3)
    assert len(pf.z) == 8000
    for _ in range(2):
        assert pf.update(obs)
        assert len(pf.z) == 8000
    assert pf.update(obs)
    assert len(pf.z) == 500
    assert len(uniform_pf(1).z) == 500


def test_a_large_uniform_start_lands_nearer_the_truth() -> None:
    """Over five seeds, 8000 start particles end nearer the pose than 500 from the start."""
    obs = scan_from(TRUE_POSE, nearest_ids(3))
    large: list[float] = []
    plain: list[float] = []
    for seed in range(5):
        for errors, kw in ((large, {"start_particles": 8000, "start_updates": 3}),
                           (plain, {})):
            pf = uniform_pf(seed, **kw)
            for _ in range(3):
                pf.update(obs)
            errors.append(position_error(pf))
    assert float(np.mean(large)) < 0.5 * float(np.mean(plain))


def test_a_misread_id_of_two_landmarks_resets_nothing() -> None:
    """Two landmarks, the second's id misread as another's: their fix fits its own
    measurements (one degree of freedom cannot tell) and lies metres from a cloud that is
    right; the cloud explains the first landmark, so the frame contradicts nothing."""
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    misread = scan_from(TRUE_POSE, [2, 3])
    misread.ids[1] = 1
    fix = weighted_fix(misread, rmap, *NOISE)
    assert fix is not None
    # the fix a reset would re-draw around: exact on its own measurements, 7 m off
    assert residual_chi2(fix[0], misread, rmap, *NOISE) < 0.1
    assert math.hypot(fix[0][0] - TRUE_POSE[0], fix[0][1] - TRUE_POSE[1]) > 5.0
    pf = filter_at(TRUE_POSE, fix_reset_probability=0.99)
    for _ in range(3):
        pf.update(misread)
    assert pf.injected == 0
    assert position_error(pf) < 0.2
