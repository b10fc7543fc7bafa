"""The rotating-head pose observation model (lgvtool.localize.pose_model): its covariance, its
fits on poses made by a rotating head written here (not the simulator's), the robust gate of
``ekf``, ``pf`` and ``pf-paper``, and poses-only ``ekf`` and ``pf`` against the laser on
simulated runs."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from inprocess import run_command
from localize_synth import T0_NS
from numpy.typing import NDArray
from simlogs import simulate_log, write_topic_log

from lgvtool.config import Area, Config, Vehicle
from lgvtool.declared import make
from lgvtool.errors import ConfigError
from lgvtool.evaluate.log_evaluation import evaluate_log
from lgvtool.localize.ekf import Ekf, EkfParams
from lgvtool.localize.estimator import Motion
from lgvtool.localize.motion import Increments, MotionTrack
from lgvtool.localize.observations import PoseObservation
from lgvtool.localize.paper_pf import PaperParticleFilter, PaperPfParams
from lgvtool.localize.particle_filter import ParticleFilter, PfParams
from lgvtool.localize.pose_model import (
    PoseGate,
    PoseModelParams,
    fit_age,
    pose_covariance,
    pose_covariances,
    prepare_poses,
    time_variance,
)
from lgvtool.localize.replay_driver import LogData, replay_data
from lgvtool.trajectory import Trajectory

FloatArray = NDArray[np.float64]

# ---------------------------------------------------------------- a rotating head, written here

#: the head of this test's device: period (s), where its revolution starts in the head frame
#: (rad: to the right, unlike the simulator's NAV200), its processing delay and the host's
#: read (s), the poll period (s)
PERIOD = 0.1
START = -0.5 * math.pi
LATENCY = 0.03
READ = 0.01
POLL = 0.4
NAV_X, NAV_Y = 1.0, 0.0
DT = 0.001


class Drive:
    """A vehicle driving at a varying speed and turn rate (m/s, rad/s), integrated every
    millisecond: the true pose of O and of the head at any time (s)."""

    def __init__(self, duration: float) -> None:
        self.t = np.arange(0.0, duration + DT / 2, DT)
        v = 0.9 + 0.3 * np.sin(2.0 * math.pi * self.t / 17.0)
        w = 0.5 * np.sin(2.0 * math.pi * self.t / 11.0) + 0.1
        th = np.concatenate([[0.0], np.cumsum(w[:-1] * DT)])
        self.x = np.concatenate([[0.0], np.cumsum(v[:-1] * np.cos(th[:-1]) * DT)])
        self.y = np.concatenate([[0.0], np.cumsum(v[:-1] * np.sin(th[:-1]) * DT)])
        self.th, self.v, self.w = th, v, w

    def head(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The head's pose (m, m, rad) at times ``t`` (s)."""
        th = np.interp(t, self.t, self.th)
        x = np.interp(t, self.t, self.x) + NAV_X * np.cos(th) - NAV_Y * np.sin(th)
        y = np.interp(t, self.t, self.y) + NAV_X * np.sin(th) + NAV_Y * np.cos(th)
        return x, y, th

    def track(self) -> MotionTrack:
        """Exact odometry every 10 ms."""
        k = np.arange(0, len(self.t), 10)
        ds = np.hypot(np.diff(self.x[k]), np.diff(self.y[k]))
        return MotionTrack(Increments(self.t[k], ds, np.diff(self.th[k])))


def _fit(mx: FloatArray, my: FloatArray, r: FloatArray, b: FloatArray,
         guess: tuple[float, float, float]) -> tuple[float, float, float]:
    """The head pose (m, m, rad) that best explains ranges ``r`` (m) and bearings ``b`` (rad,
    head frame) of the reflectors at ``(mx, my)`` as if all were measured at once: weighted
    Gauss-Newton, 12 mm and 0.05 deg."""
    x, y, th = guess
    wr, wb = 1.0 / 0.012, 1.0 / math.radians(0.05)
    for _ in range(8):
        ex, ey = mx - x, my - y
        rr = np.hypot(ex, ey)
        res = np.concatenate([(r - rr) * wr,
                              np.angle(np.exp(1j * (b - (np.arctan2(ey, ex) - th)))) * wb])
        jr = np.stack([-ex / rr, -ey / rr, np.zeros_like(rr)], 1) * wr
        jb = np.stack([ey / rr ** 2, -ex / rr ** 2, -np.ones_like(rr)], 1) * wb
        jac = np.concatenate([jr, jb])
        step = np.linalg.lstsq(jac, res, rcond=None)[0]
        x, y, th = x + step[0], y + step[1], th + step[2]
    return x, y, th


def rotating_head_poses(drive: Drive, seed: int) -> tuple[FloatArray, ...]:
    """NAV poses as a rotating head makes them: each reflector measured when the beam passes
    it, one pose fitted per revolution, the newest solution read by a poll every 0.4 s.
    Returns receive times (s), head x, y, heading (m, rad) and each pose's revolution middle
    (s)."""
    rng = np.random.default_rng(seed)
    gx, gy = np.meshgrid(np.arange(-30.0, 80.0, 7.0), np.arange(-40.0, 60.0, 7.0))
    mx, my = gx.ravel() + rng.uniform(-2, 2, gx.size), gy.ravel() + rng.uniform(-2, 2, gx.size)
    polls = np.arange(0.37, drive.t[-1] - 1.0, POLL)
    out: list[tuple[float, ...]] = []
    for p in polls:
        k = math.floor((p - LATENCY) / PERIOD) - 1  # the newest revolution finished by then
        t0 = k * PERIOD
        hx, hy, hth = (float(a[0]) for a in drive.head(np.array([t0 + PERIOD / 2])))
        near = np.argsort(np.hypot(mx - hx, my - hy))[:8]
        tau = np.full(len(near), t0 + PERIOD / 2)
        for _ in range(6):  # the instant the beam passes each reflector
            x, y, th = drive.head(tau)
            bearing = np.arctan2(my[near] - y, mx[near] - x) - th
            tau = t0 + np.mod(bearing - START, 2 * math.pi) / (2 * math.pi) * PERIOD
        x, y, th = drive.head(tau)
        r = np.hypot(mx[near] - x, my[near] - y) + rng.normal(0.0, 0.01, len(near))
        b = (np.arctan2(my[near] - y, mx[near] - x) - th
             + rng.normal(0.0, math.radians(0.05), len(near)))
        fx, fy, fth = _fit(mx[near], my[near], r, b, (hx, hy, hth))
        out.append((p + READ, fx, fy, fth, t0 + PERIOD / 2))
    a = np.array(out)
    return a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4]


def _params(**kw: Any) -> PoseModelParams:
    return make(PoseModelParams, "ekf", {"pose_period_s": PERIOD, **kw})


# ---------------------------------------------------------------- the model


def test_covariance_is_the_standstill_noise_at_rest_and_grows_with_the_motion() -> None:
    p = _params()
    rest = pose_covariance(0.3, 0.0, 0.0, NAV_X, NAV_Y, 0.02, 0.004, p)
    np.testing.assert_allclose(rest, np.diag([0.02 ** 2, 0.02 ** 2, 0.004 ** 2]), atol=1e-15)
    # driving straight along +x at 1 m/s: only the along-track variance grows, by v^2 var(t)
    straight = pose_covariance(0.0, 1.0, 0.0, NAV_X, NAV_Y, 0.02, 0.004, p)
    assert straight[0, 0] == pytest.approx(0.02 ** 2 + time_variance(p), rel=1e-12)
    assert straight[1, 1] == pytest.approx(0.02 ** 2, rel=1e-12)
    assert time_variance(p) == pytest.approx(PERIOD ** 2 / 12 + 0.005 ** 2, rel=1e-12)
    # turning on the spot: the head 1 m ahead moves sideways, its heading turns with it,
    # fully correlated, and the skew's spread adds to the position
    turn = pose_covariance(0.0, 0.0, 0.5, NAV_X, NAV_Y, 0.02, 0.004, p)
    skew = p.pose_skew_sigma_m * 0.5 * PERIOD / math.pi
    assert turn[1, 1] == pytest.approx(0.02 ** 2 + skew ** 2 + 0.25 * time_variance(p),
                                       rel=1e-12)
    assert turn[1, 2] == pytest.approx(0.25 * time_variance(p), rel=1e-12)
    assert turn[2, 2] == pytest.approx(0.004 ** 2 + 0.25 * time_variance(p), rel=1e-12)
    many = pose_covariances(np.array([0.3, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]),
                            np.array([0.0, 0.0, 0.5]), NAV_X, NAV_Y, 0.02, 0.004, p)
    np.testing.assert_allclose(many, np.stack([rest, straight, turn]), rtol=1e-12, atol=1e-15)


def test_a_parameter_out_of_range_is_refused() -> None:
    with pytest.raises(ConfigError, match="pose_period_s"):
        make(EkfParams, "ekf", {"pose_period_s": 0.0})
    with pytest.raises(ConfigError, match="pose_skew_sigma_m"):
        make(PfParams, "pf", {"pose_skew_sigma_m": -1.0})
    with pytest.raises(ConfigError, match="pose_model"):
        make(PaperPfParams, "pf-paper", {"pose_model": "sideways"})


def test_the_fits_hold_on_poses_made_by_another_rotating_head() -> None:
    """Age and skew fitted on this test's device (another period, another start of the
    revolution, another delay than the simulator's NAV200): the poses at their reference
    instants, the skew taken off, are within the model's covariance of the truth."""
    drive = Drive(120.0)
    t, x, y, h, middle = rotating_head_poses(drive, seed=11)
    true_age = float(np.mean(t - middle))
    p = _params()
    obs, fit = prepare_poses(t, x, y, h, drive.track(), NAV_X, NAV_Y, p, 0.0, False)
    assert fit.age_fitted and fit.skew_fitted
    assert fit.age_s == pytest.approx(true_age, abs=0.008)
    # the revolution starts to the right: the skew moves the head along its -y axis
    assert fit.skew_y_m < -1.0
    tr = np.array([o.t for o in obs])
    ox, oy = np.array([o.x for o in obs]), np.array([o.y for o in obs])
    hx, hy, _ = drive.head(tr)
    corrected = np.hypot(ox - hx, oy - hy)
    raw_x, raw_y, _ = drive.head(tr)
    raw = np.hypot(x - raw_x, y - raw_y)
    late_x, late_y, _ = drive.head(t)
    at_receipt = np.hypot(x - late_x, y - late_y)
    rms = {k: float(np.sqrt(np.mean(e * e))) for k, e in
           (("corrected", corrected), ("skewed", raw), ("received", at_receipt))}
    assert rms["corrected"] < 0.6 * rms["skewed"], rms
    assert rms["corrected"] < 0.2 * rms["received"], rms
    # normalised squared errors of the positions: about 2 (two dof) on average
    v = np.array([o.v for o in obs])
    w = np.array([o.omega for o in obs])
    cov = pose_covariances(h, v, w, NAV_X, NAV_Y, 0.01, 0.002, p)
    e = np.stack([ox - hx, oy - hy], 1)
    nees = np.einsum("ni,nij,nj->n", e, np.linalg.inv(cov[:, :2, :2]), e)
    assert 0.5 < float(np.mean(nees)) < 4.0


def test_no_fit_without_turn_changes_falls_back_to_the_configured_age() -> None:
    drive = Drive(60.0)
    t, x, y, h, _ = rotating_head_poses(drive, seed=3)
    # a track that never turns determines no age from the headings
    flat = MotionTrack(Increments(drive.t[::10], np.full(len(drive.t[::10]) - 1, 0.01),
                                  np.zeros(len(drive.t[::10]) - 1)))
    _, sigma = fit_age(t, np.zeros(len(t)), flat)
    assert not sigma <= 0.010
    p = _params(pose_age_fit=False, pose_skew_fit=False, pose_skew_x_m=1.0, pose_skew_y_m=2.0)
    obs, fit = prepare_poses(t, x, y, h, drive.track(), NAV_X, NAV_Y, p, 0.05, False)
    assert not fit.age_fitted and fit.age_s == pytest.approx(0.05 + PERIOD)
    assert (fit.skew_x_m, fit.skew_y_m) == (1.0, 2.0)
    assert obs[3].t == pytest.approx(t[3] - 0.05 - PERIOD)
    _, configured = prepare_poses(t, x, y, h, drive.track(), NAV_X, NAV_Y, p, 0.05, True)
    assert configured.age_s == pytest.approx(0.05)


# ---------------------------------------------------------------- the robust gate


def test_the_gate_refuses_then_reanchors_after_the_stated_time() -> None:
    gate = PoseGate(11.3, 2.0)
    assert gate.judge(0.0, 1.0) == "accept"
    assert gate.judge(0.5, 50.0) == "refuse"
    assert gate.judge(1.0, 50.0) == "refuse"
    assert gate.judge(2.4, 50.0) == "refuse"
    assert gate.judge(2.6, 50.0) == "reanchor"
    assert gate.judge(3.0, 50.0) == "refuse"  # a new count starts
    assert gate.judge(3.5, 2.0) == "accept"
    assert PoseGate(11.3, 0.0).judge(100.0, 50.0) == "refuse"  # 0: never


def _vehicle() -> Vehicle:
    return replace(Vehicle(), nav_x=NAV_X, nav_y=NAV_Y)


def _head(pose: tuple[float, float, float], t: float, dx: float = 0.0) -> PoseObservation:
    x, y, th = pose
    return PoseObservation(t, x + NAV_X * math.cos(th) + dx, y + NAV_X * math.sin(th), th,
                           0.5, 0.1)


def _position(est: Any) -> tuple[float, float]:
    e = est.estimate()
    assert e is not None
    return e.x, e.y


@pytest.mark.parametrize("cls", [Ekf, ParticleFilter, PaperParticleFilter])
def test_a_wrong_pose_does_not_move_the_estimate(cls: Any) -> None:
    """A pose 1.5 m off (a corrupt reply, a wrong solution) is refused: the estimate stays
    where the good poses put it (within 5 mm: the particle filters' own noise), and poses
    refused for longer than pose_reanchor_s re-anchor it at them."""
    start = (4.0, 2.0, 0.3)
    est = cls(cls.Params(), vehicle=_vehicle(), rng=np.random.default_rng(5),
              initial_pose=start)
    still = Motion(0.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(5):
        est.predict(still)
        est.update(_head(start, 0.4 * k))
    before = _position(est)
    est.predict(still)
    assert not est.update(_head(start, 2.0, dx=1.5))
    after = _position(est)
    assert math.dist(before, after) < 0.005
    # the device was right after all (the vehicle was moved): re-anchored once refused 3 s
    t = 2.0
    while t < 6.0:
        t += 0.4
        est.predict(still)
        est.update(_head(start, t, dx=1.5))
    assert math.dist(_position(est), (start[0] + 1.5, start[1])) < 0.1


# ---------------------------------------------------------------- on simulated NAV200 recordings


@pytest.mark.parametrize("scenario", ["warehouse", "fast"])
def test_poses_only_ekf_and_pf_are_never_worse_than_the_laser(tmp_path: Path,
                                                              scenario: str) -> None:
    """A NAV200 recording (poses only) of 40 s, seed 45: ``ekf`` and ``pf`` from their own
    start are within 0.6 x the laser's truth RMSE, and within its p95 and its largest error."""
    log = simulate_log(tmp_path / f"{scenario}.mcap", 40.0, 45, scenario, paper_scans=False)
    res = evaluate_log(log, estimators=["laser", "ekf", "pf"])
    laser = res.estimators["laser"].truth
    assert laser is not None
    for name in ("ekf", "pf"):
        mine = res.estimators[name].truth
        assert mine is not None
        assert mine.position_rmse <= 0.6 * laser.position_rmse, (name, mine, laser)
        assert mine.position_p95 <= laser.position_p95, (name, mine, laser)
        assert mine.position_max <= laser.position_max, (name, mine, laser)


# ---------------------------------------------------------------- bad input


def test_bad_input_is_one_line_and_exit_2(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """A pose-model parameter out of range, and a log whose NAV poses carry no time stamp
    (neither their own nor a log time): one line on stderr, exit 2."""
    log = simulate_log(tmp_path / "w.mcap", 5.0, 45, "warehouse", paper_scans=False)
    code, _, err = run_command(capsys, "evaluate", log, "--set", "ekf.pose_period_s=0")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "pose_period_s" in err, err
    code, _, err = run_command(capsys, "evaluate", log, "--set", "pf.pose_model=fixed")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "pose_model" in err, err
    poses = [json.dumps({"x": 1.0 + 0.01 * i, "y": 2.0, "heading": 0.1, "valid": True,
                         "quality": 80, "reflectors_used": 5}).encode() for i in range(20)]
    bare = write_topic_log(tmp_path / "bare.mcap", "/nav/pose", "lgvtool.NavPose", poses,
                           start_ns=0, step_ns=0)
    code, _, err = run_command(capsys, "evaluate", bare)
    lines = [ln for ln in err.strip().splitlines() if "warning" not in ln]
    assert code == 2 and len(lines) == 1 and "/nav/pose" in lines[0], err


def test_a_pose_keeps_the_particle_count_that_kld_would_cut() -> None:
    """After a NAV pose the particle set keeps ``particles``: the belief a pose leaves is far
    inside KLD-sampling's bins, which would cut it to about ``min_particles``."""
    start = (4.0, 2.0, 0.3)
    pf = ParticleFilter(PfParams(), vehicle=_vehicle(), rng=np.random.default_rng(2),
                        initial_pose=start)
    still = Motion(0.0, 0.0, 0.0, 0.0, 0.0)
    for k in range(12):
        pf.predict(still)
        pf.update(_head(start, 0.4 * k))
    assert pf.resamplings > 0
    assert len(pf.z) == PfParams().particles


def test_ekf_and_pf_beat_the_laser_on_poses_made_by_another_rotating_head() -> None:
    """The whole replay on this test's device (period 0.1 s, its revolution starting to the
    right), exact generic odometry: ``ekf`` and ``pf`` within 0.6 x the laser's truth RMSE and
    within its p95, with only the device's period configured."""
    drive = Drive(90.0)
    t, x, y, h, _ = rotating_head_poses(drive, seed=7)
    data = LogData(T0_NS, ())
    tm = drive.t[::10]
    data.twist = {"t": tm, "v": drive.v[::10], "omega": drive.w[::10]}
    data.nav = {"t": t, "x": x, "y": y, "heading": np.angle(np.exp(1j * h)),
                "valid": np.ones(len(t), dtype=bool)}
    data.truth = Trajectory(drive.t[::10], drive.x[::10], drive.y[::10], drive.th[::10],
                            T0_NS)
    cfg = Config(vehicle=_vehicle(), area=Area(-40.0, 90.0, -50.0, 70.0))
    res = replay_data(data, ["laser", "ekf", "pf"], config=cfg, seed=4,
                      settings={"ekf.pose_period_s": PERIOD, "pf.pose_period_s": PERIOD})
    errors = {}
    for name in ("laser", "ekf", "pf"):
        tab = res.estimates[name]
        ts = (tab.t_ns - T0_NS) * 1e-9
        keep = ts > 5.0
        tx = np.interp(ts[keep], drive.t, drive.x)
        ty = np.interp(ts[keep], drive.t, drive.y)
        errors[name] = np.hypot(tab.x[keep] - tx, tab.y[keep] - ty)
    rms = {k: float(np.sqrt(np.mean(e * e))) for k, e in errors.items()}
    p95 = {k: float(np.percentile(e, 95)) for k, e in errors.items()}
    for name in ("ekf", "pf"):
        assert rms[name] <= 0.6 * rms["laser"], rms
        assert p95[name] <= p95["laser"], p95
