"""The EKF's odometry scale states (``odometry_scales``): the corrected motion, its Jacobian, and
recovery of known scale factors from biased odometry and landmark range/bearing observations."""

from __future__ import annotations

import math

import numpy as np
import pytest
from localize_synth import REFLECTORS, small_config

from lgvtool.localize.ekf import Ekf, scaled_motion
from lgvtool.localize.estimator import Estimator, Motion
from lgvtool.localize.observations import ScanObservation

TRUE_SCALE_V = 0.92
"""The robot travels this fraction of the commanded distance."""
TRUE_SCALE_W = 0.88
"""The robot turns this fraction of the commanded heading change."""


def arc(ds: float, dth: float) -> Motion:
    """The body-frame motion of an arc of length ``ds`` (m) turning by ``dth`` (rad)."""
    chord = ds * np.sinc(dth / (2.0 * math.pi))
    return Motion(chord * math.cos(dth / 2), chord * math.sin(dth / 2), dth, abs(ds), abs(dth))


def compose(pose: tuple[float, float, float], m: Motion) -> tuple[float, float, float]:
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    return x + c * m.dx - s * m.dy, y + s * m.dx + c * m.dy, th + m.dth


# ------------------------------------------------------------------ the corrected motion


def test_unit_scales_leave_the_motion_unchanged() -> None:
    for dx, dy, dth in [(0.3, 0.02, 0.1), (-0.2, 0.01, -0.3), (0.0, 0.0, 0.5), (0.1, -0.4, 2.0)]:
        got = scaled_motion(dx, dy, dth, 1.0, 1.0)
        assert got[:3] == pytest.approx((dx, dy, dth), abs=1e-12)


def test_turn_drive_turn_is_scaled_exactly() -> None:
    # turn 0.4 rad, drive 2 m, turn -0.1 rad: dx, dy of the chord, dth the total turn
    a, d, b = 0.4, 2.0, -0.1
    motion = (d * math.cos(a), d * math.sin(a), a + b)
    dx, dy, dth, a_out, d_out = scaled_motion(*motion, 0.9, 0.8)
    assert (a_out, d_out) == pytest.approx((a, d))
    assert (dx, dy) == pytest.approx((0.9 * d * math.cos(0.8 * a), 0.9 * d * math.sin(0.8 * a)))
    assert dth == pytest.approx(0.8 * (a + b))
    # a backwards chord is driven backwards, not turned round
    dx, dy, dth, a_out, d_out = scaled_motion(-1.0, 0.0, 0.0, 0.5, 0.5)
    assert (dx, dy, dth, a_out, d_out) == pytest.approx((-0.5, 0.0, 0.0, 0.0, -1.0))


def test_a_scaled_arc_stays_close_to_the_exact_arc() -> None:
    for ds, dth in [(0.05, 0.02), (0.5, 0.3), (1.0, 1.0)]:
        m = arc(ds, dth)
        dx, dy, th = scaled_motion(m.dx, m.dy, m.dth, TRUE_SCALE_V, TRUE_SCALE_W)[:3]
        exact = arc(TRUE_SCALE_V * ds, TRUE_SCALE_W * dth)
        assert th == pytest.approx(exact.dth)
        # the chord's length differs by sinc(s_w dth / 2) / sinc(dth / 2) - 1 (< 1 % at 1 rad)
        assert math.hypot(dx - exact.dx, dy - exact.dy) <= 0.01 * ds


def test_prediction_jacobian_matches_finite_differences() -> None:
    ekf = Ekf(Ekf.configure(odometry_scales=True, noise_dist=0.0, noise_lat=0.0, noise_rot=0.0,
                            noise_rot_per_m=0.0), initial_pose=(1.0, 2.0, 0.7))
    state = np.array([1.0, 2.0, 0.7, 0.93, 0.87])
    motion = Motion(0.4, 0.05, 0.25, 0.41, 0.25)

    def step(s: np.ndarray) -> np.ndarray:
        ekf.mu, ekf.P = s.copy(), np.zeros((5, 5))
        ekf.predict(motion)
        return ekf.mu.copy()

    base = step(state)
    numeric = np.empty((5, 5))
    for i in range(5):
        h = np.zeros(5)
        h[i] = 1e-6
        numeric[:, i] = (step(state + h) - step(state - h)) / 2e-6
    ekf.mu, ekf.P = state.copy(), np.eye(5)
    ekf.predict(motion)
    # with no motion noise and no random walk, P+ = F P F^T = F F^T for P = I
    np.testing.assert_allclose(ekf.P, numeric @ numeric.T, atol=1e-6)
    assert base[3:] == pytest.approx([0.93, 0.87])


def test_the_scales_are_off_by_default() -> None:
    ekf = Ekf(initial_pose=(0.0, 0.0, 0.0))
    assert ekf.P.shape == (3, 3) and ekf.odometry_calibration == {}
    on = Ekf(Ekf.configure(odometry_scales=True, scale_sigma_v=0.1, scale_sigma_w=0.2),
             initial_pose=(0.0, 0.0, 0.0))
    assert on.P.shape == (5, 5)
    assert on.odometry_calibration == {"s_v": 1.0, "s_w": 1.0}
    assert np.diag(on.P)[3:] == pytest.approx([0.01, 0.04])
    assert on.estimate() is not None and on.estimate().covariance.shape == (3, 3)


# ------------------------------------------------------------------ recovering known scales


def drive(seconds: float, rng: np.random.Generator) -> list[tuple[float, Motion, Motion]]:
    """A drive around the 10 m x 10 m room of ``localize_synth``: per 0.25 s step the true
    motion and the commanded one (what the odometry reports, biased by the true scales)."""
    out = []
    t = 0.0
    v = 0.3
    while t < seconds:
        t += 0.25
        omega = 0.35 * math.sin(0.11 * t) + 0.25 * math.sin(0.023 * t + 1.0)
        cmd = arc(v * 0.25, omega * 0.25)
        true = arc(TRUE_SCALE_V * v * 0.25 + 0.002 * rng.standard_normal(),
                   TRUE_SCALE_W * omega * 0.25 + 0.002 * rng.standard_normal())
        out.append((t, true, cmd))
    return out


def camera(t: float, pose: tuple[float, float, float], rng: np.random.Generator
           ) -> ScanObservation:
    """Range (2 cm + 2 %) and bearing (5 mrad) of the landmarks within 7 m and +-0.6 rad."""
    x, y, th = pose
    ranges, bearings, ids = [], [], []
    for r in REFLECTORS:
        d = math.hypot(r.x - x, r.y - y)
        b = math.remainder(math.atan2(r.y - y, r.x - x) - th, 2 * math.pi)
        if 0.3 < d < 7.0 and abs(b) < 0.6:
            ranges.append(d + (0.02 + 0.02 * d) * rng.standard_normal())
            bearings.append(b + 0.005 * rng.standard_normal())
            ids.append(r.id)
    return ScanObservation.simple(t, ranges, bearings, ids)


def run_ekf(scales: bool, seconds: float = 600.0) -> tuple[Ekf, float]:
    """The EKF over the drive, bouncing off the room's walls by turning in place; returns the
    filter and its position RMSE (m)."""
    rng = np.random.default_rng(7)
    cfg = small_config(nav_x=0.0)
    start = (5.0, 5.0, 0.3)
    ekf = Ekf(Ekf.configure(odometry_scales=scales, sigma_range_m=0.02, sigma_range_per_m=0.02,
                            sigma_bearing_rad=0.005, noise_dist=0.02, noise_lat=0.01,
                            noise_rot=0.02, noise_rot_per_m=0.01, scale_sigma_v=0.1,
                            scale_sigma_w=0.1),
              vehicle=cfg.vehicle, reflectors=cfg.reflectors, area=cfg.area, initial_pose=start)
    return ekf, run_biased(ekf, start, seconds, rng, every=2)


def run_biased(filt: Estimator, start: tuple[float, float, float], seconds: float,
               rng: np.random.Generator, every: int) -> float:
    """Drive ``filt`` over the biased drive from ``start``, bouncing off the room's walls by
    turning in place, with a camera frame every ``every`` steps of 0.25 s; its position RMSE
    over the second half (m)."""
    pose = start
    errors = []
    for t, true, cmd in drive(seconds, rng):
        x, y, _ = compose(pose, true)
        if not (1.0 < x < 9.0 and 1.0 < y < 9.0):
            # turn in place towards the room's centre (commanded and true alike scaled)
            turn = math.remainder(math.atan2(5.0 - pose[1], 5.0 - pose[0]) - pose[2],
                                  2 * math.pi)
            true = Motion(0.0, 0.0, TRUE_SCALE_W * turn, 0.0, abs(TRUE_SCALE_W * turn))
            cmd = Motion(0.0, 0.0, turn, 0.0, abs(turn))
        pose = compose(pose, true)
        filt.predict(cmd)
        if round(t / 0.25) % every == 0:
            filt.update(camera(t, pose, rng))
        e = filt.estimate()
        assert e is not None
        errors.append(math.hypot(e.x - pose[0], e.y - pose[1]))
    return float(np.sqrt(np.mean(np.square(errors[len(errors) // 2:]))))


def test_the_scales_are_recovered_from_biased_odometry() -> None:
    ekf, rmse = run_ekf(scales=True)
    cal = ekf.odometry_calibration
    assert cal["s_v"] == pytest.approx(TRUE_SCALE_V, abs=0.01)
    assert cal["s_w"] == pytest.approx(TRUE_SCALE_W, abs=0.02)
    sd = np.sqrt(np.diag(ekf.P)[3:])
    assert (sd < 0.02).all()
    plain, plain_rmse = run_ekf(scales=False)
    assert plain.odometry_calibration == {}
    assert rmse < 0.7 * plain_rmse


def test_a_tight_prior_at_one_gives_the_plain_ekf() -> None:
    """With the scales pinned at 1 the augmented filter is the 3-state EKF."""
    rng = np.random.default_rng(3)
    cfg = small_config(nav_x=0.0)
    where = {"vehicle": cfg.vehicle, "reflectors": cfg.reflectors, "area": cfg.area,
             "initial_pose": (5.0, 5.0, 0.3)}
    plain = Ekf(Ekf.configure(sigma_range_per_m=0.02), **where)
    pinned = Ekf(Ekf.configure(sigma_range_per_m=0.02, odometry_scales=True, scale_sigma_v=1e-6,
                               scale_sigma_w=1e-6), **where)
    pose = (5.0, 5.0, 0.3)
    for t, true, cmd in drive(60.0, rng):
        pose = compose(pose, true)
        obs = camera(t, pose, rng)
        for f in (plain, pinned):
            f.predict(cmd)
            f.update(obs)
        assert pinned.mu[:3] == pytest.approx(plain.mu, abs=1e-6)
        np.testing.assert_allclose(pinned.P[:3, :3], plain.P, rtol=1e-5, atol=1e-9)
