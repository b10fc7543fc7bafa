"""Association of measured reflectors with the layout (:mod:`lgvtool.localize.association`): an
id is used only inside its gate, a reflector without a usable one goes to the nearest layout
reflector inside the gate, and none when the gate holds nothing or two alike; the fix from a
scan's geometry when its ids are missing or wrong (:func:`lgvtool.localize.fix.scan_fix`); and
the estimators' compiled kernels against their numpy path with ids missing or wrong (within
1e-9 m and rad, as the other kernel tests)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pytest
from device_ids import with_ids
from localize_synth import REFLECTORS, circle_log, small_config
from test_pf_scales import scan_from

from lgvtool.config import Config, Reflector
from lgvtool.localize.association import (
    AMBIGUOUS,
    BY_ID,
    NEAREST,
    NONE,
    associate,
    associate_points,
    safe_radius,
)
from lgvtool.localize.ekf import Ekf
from lgvtool.localize.fix import pose_fix, scan_fix
from lgvtool.localize.geometry import pose_from_correspondences
from lgvtool.localize.kernel_choice import KERNELS_ENV
from lgvtool.localize.observations import ReflectorMap, ScanObservation
from lgvtool.localize.particle_filter import ParticleFilter
from lgvtool.localize.replay_driver import LogData, replay_data
from lgvtool.trajectory import Trajectory

#: tolerance of the kernels against the numpy path: positions m, headings rad
TOL = 1e-9
#: a chi-square gate (2 dof, 0.99) for the unit cases, squared Mahalanobis distance
GATE2 = 9.21


# ------------------------------------------------------------------ the rule itself
def test_an_id_inside_its_gate_wins_over_a_nearer_reflector() -> None:
    d2 = np.array([[0.5, 2.0, 30.0]])
    j, how = associate(d2, np.array([1]), GATE2, 2.0)
    assert j.tolist() == [1] and how.tolist() == [BY_ID]


def test_an_id_outside_its_gate_is_set_aside_and_the_nearest_taken() -> None:
    """A wrong id (its reflector far outside the gate) does not drag: the measurement is
    associated as if it had none."""
    d2 = np.array([[0.2, 50.0, 40.0]])
    j, how = associate(d2, np.array([1]), GATE2, 2.0)
    assert j.tolist() == [0] and how.tolist() == [NEAREST]


def test_without_an_id_the_nearest_inside_the_gate() -> None:
    d2 = np.array([[40.0, 0.3, 12.0], [5.0, 60.0, 70.0]])
    j, how = associate(d2, np.array([-1, -1]), GATE2, 2.0)
    assert j.tolist() == [1, 0] and how.tolist() == [NEAREST, NEAREST]


def test_nothing_inside_the_gate_is_none() -> None:
    d2 = np.array([[10.0, 12.0, 40.0], [20.0, 9.3, 90.0]])
    j, how = associate(d2, np.array([-1, 1]), GATE2, 2.0)
    assert j.tolist() == [-1, -1] and how.tolist() == [NONE, NONE]


def test_two_alike_inside_the_gate_are_ambiguous() -> None:
    """Distances 1 and 1.41, or 1 and 1.73 (squared 1 and 2, 1 and 3): the second is nearer
    than twice the first, both inside the gate: dropped. Distances 0.71 and 2.83 (ratio 4), or
    a second outside the gate, or ratio 1 (never ambiguous): the nearest."""
    d2 = np.array([[1.0, 2.0, 40.0], [0.5, 8.0, 40.0], [1.0, 3.0, 40.0]])
    none = np.array([-1, -1, -1])
    j, how = associate(d2, none, GATE2, 2.0)
    assert j.tolist() == [-1, 0, -1] and how.tolist() == [AMBIGUOUS, NEAREST, AMBIGUOUS]
    j, how = associate(d2, none, 2.5, 2.0)  # the third's second outside a gate of 2.5
    assert j.tolist() == [-1, 0, 0] and how.tolist() == [AMBIGUOUS, NEAREST, NEAREST]
    j, how = associate(d2, none, GATE2, 1.0)
    assert j.tolist() == [0, 0, 0] and how.tolist() == [NEAREST] * 3
    # an id inside its gate is never ambiguous: the id tells the two apart
    j, how = associate(d2[:1], np.array([1]), GATE2, 2.0)
    assert j.tolist() == [1] and how.tolist() == [BY_ID]


def test_not_a_number_counts_as_infinite_and_unknown_ids_as_none() -> None:
    d2 = np.array([[math.nan, 1.0], [math.nan, math.nan]])
    j, how = associate(d2, np.array([0, 7]), GATE2, 2.0)
    assert j.tolist() == [1, -1] and how.tolist() == [NEAREST, NONE]
    j, how = associate(np.zeros((2, 0)), np.array([-1, 0]), GATE2, 2.0)
    assert j.tolist() == [-1, -1] and how.tolist() == [NONE, NONE]


def test_points_in_metres() -> None:
    """A close pair (0.3 m apart) and a lone reflector: a point 2 cm from one of the pair is
    the pair's, a point between the two is ambiguous, a wrong id of the pair's other (0.3 m,
    outside a 0.2 m gate) is set aside, a point 2.8 m from everything is none."""
    layout = np.array([0 + 0j, 0.3 + 0j, 5 + 5j])
    pts = np.array([0.02 + 0j, 0.16 + 0.02j, 0.01 + 0.01j, 2 + 2j])
    j, how = associate_points(pts, layout, np.array([-1, -1, 1, -1]), 0.2, 2.0)
    assert j.tolist() == [0, -1, 0, -1]
    assert how.tolist() == [NEAREST, AMBIGUOUS, NEAREST, NONE]


@pytest.mark.parametrize("ratio", [1.0, 2.0, 4.0])
def test_the_safe_radius_proves_the_association(ratio: float) -> None:
    """A point nearer to a layout reflector than its safe radius has that reflector as its
    nearest, inside the gate, unambiguously (checked by the rule on random layouts with close
    pairs)."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        layout = rng.uniform(0, 10, 12) + 1j * rng.uniform(0, 10, 12)
        layout[1] = layout[0] + 0.3 * np.exp(1j * rng.uniform(0, 6.3))
        half = ReflectorMap([Reflector(i, z.real, z.imag)
                             for i, z in enumerate(layout.tolist())]).half_sep
        gate = float(rng.uniform(0.05, 1.0))
        safe = safe_radius(half, gate, ratio)
        assert (safe <= np.minimum(half, gate) + 1e-15).all() and (safe >= 0).all()
        c = rng.integers(0, 12, 200)
        pts = layout[c] + safe[c] * rng.uniform(0, 0.999, 200) * np.exp(
            1j * rng.uniform(0, 6.3, 200))
        j, how = associate_points(pts, layout, np.full(200, -1), gate, ratio)
        assert (j == c).all() and (how == NEAREST).all()


# ------------------------------------------------------------------ the fix without ids
POSE = (5.0, 4.0, 0.4)
"""Where the vehicle is in the fix tests, m, m, rad."""


def _no_ids(obs: ScanObservation) -> ScanObservation:
    return ScanObservation(obs.t, obs.q, obs.u, obs.ranges, np.full(len(obs), -1))


def test_a_scan_without_ids_fixes_the_pose_by_its_geometry() -> None:
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    obs = _no_ids(scan_from(POSE, [r.id for r in REFLECTORS]))
    fix = scan_fix(obs, rmap)
    assert fix is not None and fix.inliers == len(REFLECTORS)
    assert fix.pose == pytest.approx(POSE, abs=1e-9)
    assert fix.index.tolist() == list(range(len(REFLECTORS)))
    assert pose_fix(obs, 0.0, 0.0, rmap, use_ids=False) == pytest.approx(POSE, abs=1e-9)
    # four reflectors suffice; two without ids fix nothing
    assert scan_fix(_no_ids(scan_from(POSE, [2, 4, 6, 9])), rmap) is not None
    assert scan_fix(_no_ids(scan_from(POSE, [2, 4])), rmap) is None


def test_a_wrong_id_does_not_drag_the_fix() -> None:
    """Least squares on the ids would put the pose tens of cm off; the fix sees that the ids
    disagree and matches the geometry, with the right reflector for the misread one."""
    rmap = ReflectorMap(small_config(nav_x=0.0).reflectors)
    obs = scan_from(POSE, [1, 2, 3, 4, 6, 9])
    obs.ids[2] = 5  # reflector 3 read as 5
    j = obs.map_index(rmap)
    naive = pose_from_correspondences(obs.qx, obs.qy, rmap.x[j], rmap.y[j])
    assert naive is not None and math.hypot(naive[0] - POSE[0], naive[1] - POSE[1]) > 0.2
    fix = scan_fix(obs, rmap)
    assert fix is not None and fix.pose == pytest.approx(POSE, abs=1e-9)
    assert fix.index[2] == 2  # reflector 3 (index 2), not the id's


def test_a_symmetric_layout_fixes_nothing_without_ids() -> None:
    """Four reflectors on a square's corners look alike from its centre in four headings:
    no fix without ids (ambiguous), the fix with them."""
    square = [Reflector(i + 1, x, y) for i, (x, y) in enumerate(
        [(0.0, 0.0), (8.0, 0.0), (8.0, 8.0), (0.0, 8.0)])]
    rmap = ReflectorMap(square)
    pose = (4.0, 4.0, 0.3)
    ranges = [math.hypot(r.x - 4.0, r.y - 4.0) for r in square]
    bearings = [math.atan2(r.y - 4.0, r.x - 4.0) - 0.3 for r in square]
    with_ids_obs = ScanObservation.simple(0.0, ranges, bearings, [r.id for r in square])
    fix = scan_fix(with_ids_obs, rmap)
    assert fix is not None and fix.pose == pytest.approx(pose, abs=1e-9)
    assert scan_fix(_no_ids(with_ids_obs), rmap) is None


# ------------------------------------------------------------------ kernels against numpy
def _replay(monkeypatch: pytest.MonkeyPatch, mode: str, data: LogData, cfg: Config,
            names: list[str], settings: Mapping[str, object] | None = None
            ) -> dict[str, Trajectory]:
    monkeypatch.setenv(KERNELS_ENV, mode)
    return replay_data(data, names, config=cfg, seed=3, settings=settings).estimates


def _same_rows(a: Trajectory, b: Trajectory) -> None:
    assert len(a.x) == len(b.x) > 0
    assert np.array_equal(a.t_ns, b.t_ns)
    for col in ("x", "y"):
        np.testing.assert_allclose(getattr(a, col), getattr(b, col), rtol=0, atol=TOL)
    dh = np.remainder(a.heading - b.heading + math.pi, 2 * math.pi) - math.pi
    assert np.abs(dh).max() <= TOL


@pytest.mark.parametrize("ids", ["wrong", "none"])
def test_ekf_kernels_match_numpy_with_device_ids(monkeypatch: pytest.MonkeyPatch,
                                                 ids: str) -> None:
    """The EKF from a scan fix (``init = landmarks``) with 30 % of the ids wrong, or none."""
    pytest.importorskip("numba")
    data, _, cfg = circle_log(20.0, ids=True)
    data = with_ids(data, ids, fraction=0.3, seed=1)
    settings = {"ekf.init": "landmarks"}
    ref = _replay(monkeypatch, "numpy", data, cfg, ["ekf"], settings)
    fast = _replay(monkeypatch, "numba", data, cfg, ["ekf"], settings)
    _same_rows(ref["ekf"], fast["ekf"])
    np.testing.assert_allclose(ref["ekf"].covariance, fast["ekf"].covariance, rtol=1e-9,
                               atol=1e-15)


@pytest.mark.parametrize(("ids", "settings"), [
    ("wrong", {}),
    ("none", {}),
    ("wrong", {"pf.kld": False, "pf.particles": 400, "pf.ambiguity_ratio": 4.0}),
    ("wrong", {"pf.id_error_prob": 0.0, "pf.outlier": False, "pf.resample": "always"}),
])
def test_pf_kernels_match_numpy_with_device_ids(monkeypatch: pytest.MonkeyPatch, ids: str,
                                                settings: dict[str, object]) -> None:
    """``pf`` from its uniform start over a circle drive with 30 % of the ids wrong, or none:
    the same rows on both paths."""
    pytest.importorskip("numba")
    data, _, cfg = circle_log(20.0, ids=True)
    data = with_ids(data, ids, fraction=0.3, seed=2)
    ref = _replay(monkeypatch, "numpy", data, cfg, ["pf"], settings)
    fast = _replay(monkeypatch, "numba", data, cfg, ["pf"], settings)
    _same_rows(ref["pf"], fast["pf"])
    assert np.array_equal(ref["pf"].particles, fast["pf"].particles)


@pytest.mark.parametrize("ids", ["wrong", "none"])
def test_pf_finds_and_tracks_the_vehicle_with_device_ids(ids: str) -> None:
    """From the uniform start, without ids or with 30 % wrong: within 5 cm of the truth from
    2 s on (the exact circle drive: measured 0.3-0.5 mm, seeds 0-2)."""
    data, circle, cfg = circle_log(20.0, ids=True)
    data = with_ids(data, ids, fraction=0.3, seed=3)
    for seed in range(3):
        traj = replay_data(data, ["pf"], config=cfg, seed=seed).trajectories["pf"]
        t = traj.t - data.t0_ns * 1e-9
        x, y, _ = circle.pose(t)
        err = np.hypot(traj.x - x, traj.y - y)
        assert err[t >= 2.0].max() < 0.05, (seed, float(err[t >= 2.0].max()))


# ------------------------------------------------------------------ a wrong id and the gate
#: a second reflector 0.15 m beside reflector 9 (7.1, 7.7): a pair a device may confuse
PAIRED = (*REFLECTORS, Reflector(10, 7.25, 7.7))
#: the squared gate of ``ekf`` (chi-square, 2 dof, its default gate_probability 0.99)
EKF_GATE2 = 9.21


def _scan(pose: tuple[float, float, float], seen: list[int], reported: list[int]
          ) -> ScanObservation:
    """Exact ranges and bearings of the layout reflectors ``seen`` (ids of :data:`PAIRED`)
    from ``pose`` (m, m, rad), by a sensor at O, reported with the ids ``reported``."""
    by_id = {r.id: r for r in PAIRED}
    x, y, th = pose
    ranges = [math.hypot(by_id[i].x - x, by_id[i].y - y) for i in seen]
    bearings = [math.remainder(math.atan2(by_id[i].y - y, by_id[i].x - x) - th, 2 * math.pi)
                for i in seen]
    return ScanObservation.simple(0.0, ranges, bearings, reported)


def _ekf(prior: tuple[float, float, float], sigma_xy: float, sigma_th: float) -> Ekf:
    cfg = small_config(nav_x=0.0)
    return Ekf(Ekf.configure(init_sigma_xy_m=sigma_xy, init_sigma_heading_rad=sigma_th),
               vehicle=cfg.vehicle, reflectors=PAIRED, area=cfg.area, initial_pose=prior)


PRIOR = (POSE[0] + 0.04, POSE[1] - 0.03, POSE[2] + 0.01)
"""The filters' belief before the scan: 5 cm and 0.01 rad off :data:`POSE`."""


def test_ekf_a_wrong_id_outside_its_gate_moves_nothing_beyond_the_right_one() -> None:
    """A scan of five reflectors, one reported with the id of a reflector metres away: the id
    fails its gate, the reflector goes to its nearest, and the update is that of the scan
    with the right id (within 1e-12 m, rad)."""
    seen = [1, 2, 4, 6, 9]
    right, wrong = _ekf(PRIOR, 0.1, 0.02), _ekf(PRIOR, 0.1, 0.02)
    assert right.update(_scan(POSE, seen, seen))
    assert wrong.update(_scan(POSE, seen, [1, 2, 7, 6, 9]))
    assert right.mu is not None and wrong.mu is not None
    np.testing.assert_allclose(wrong.mu, right.mu, rtol=0, atol=1e-12)
    np.testing.assert_allclose(wrong.P, right.P, rtol=0, atol=1e-12)
    assert (wrong.id_rejected, right.id_rejected) == (1, 0)
    assert math.hypot(right.mu[0] - POSE[0], right.mu[1] - POSE[1]) < 0.01


@pytest.mark.parametrize("sigma_xy", [0.03, 0.1, 0.3])
def test_ekf_a_wrong_id_moves_the_estimate_no_more_than_the_gate_allows(
        sigma_xy: float) -> None:
    """Reflector 9 reported as its neighbour 10 (0.15 m away), or as any reflector put
    anywhere from 2 cm to 1 m beside it: an id inside the gate is used, and the one reflector
    moves the estimate by ``d`` with ``d^T P^-1 d`` at most the gate (9.21), whatever the id;
    an id outside it is set aside (the reflector then goes to its nearest, as without an
    id)."""
    cfg = small_config(nav_x=0.0)
    rng = np.random.default_rng(11)
    used = set_aside = 0
    for k in range(60):
        if k == 0:
            layout = PAIRED
        else:
            off = rng.uniform(0.02, 1.0) * np.exp(1j * rng.uniform(0.0, 2 * math.pi))
            layout = (*REFLECTORS, Reflector(10, 7.1 + off.real, 7.7 + off.imag))
        filt = Ekf(Ekf.configure(init_sigma_xy_m=sigma_xy, init_sigma_heading_rad=0.02),
                   vehicle=cfg.vehicle, reflectors=layout, area=cfg.area, initial_pose=PRIOR)
        assert filt.mu is not None
        before, P = filt.mu.copy(), filt.P.copy()
        obs = _scan(POSE, [9], [10])
        filt.update(obs)
        d = filt.mu - before
        d[2] = math.remainder(d[2], 2 * math.pi)
        assert float(d @ np.linalg.solve(P, d)) <= EKF_GATE2 * (1 + 1e-9), (k, d)
        used += filt.id_rejected == 0
        set_aside += filt.id_rejected
        if filt.id_rejected:
            # set aside: the same update as without the id
            bare = Ekf(Ekf.configure(init_sigma_xy_m=sigma_xy, init_sigma_heading_rad=0.02),
                       vehicle=cfg.vehicle, reflectors=layout, area=cfg.area,
                       initial_pose=PRIOR)
            bare.update(_scan(POSE, [9], [-1]))
            assert bare.mu is not None
            np.testing.assert_allclose(filt.mu, bare.mu, rtol=0, atol=1e-12)
    assert used > 0 and set_aside > 0  # both sides of the gate were tried


def _pf(seed: int, sigma_xy: float = 0.01, sigma_th: float = 0.002,
        start: tuple[float, float, float] = POSE,
        layout: tuple[Reflector, ...] = PAIRED) -> ParticleFilter:
    """``pf`` with 500 particles (no KLD) drawn around ``start`` with the spreads ``sigma_xy``
    (m), ``sigma_th`` (rad), on ``layout``."""
    cfg = small_config(nav_x=0.0)
    return ParticleFilter(
        ParticleFilter.configure(particles=500, kld=False, init_sigma_xy_m=sigma_xy,
                                 init_sigma_heading_rad=sigma_th),
        vehicle=cfg.vehicle, reflectors=layout, area=cfg.area, initial_pose=start,
        rng=np.random.default_rng(seed))


SEEN = [1, 2, 4, 6, 9]
"""The reflectors of the scans of the ``pf`` tests."""


def test_pf_a_wrong_id_outside_the_gate_moves_nothing_beyond_the_right_one() -> None:
    """A cloud that has the measured reflector inside the gate of every particle and its wrong
    id's reflector (metres away) outside all of them: each particle associates it with its
    nearest, at the same cost of the id for every particle, so the weights, the estimate and
    the next draws are those of the right id's (within 1e-9 m, rad), over five scans with one
    id wrong in each."""
    right, wrong = _pf(3), _pf(3)
    for step in range(5):
        reported = list(SEEN)
        reported[step] = 7
        assert right.update(_scan(POSE, SEEN, SEEN))
        assert wrong.update(_scan(POSE, SEEN, reported))
        a, b = right.estimate(), wrong.estimate()
        assert a is not None and b is not None
        assert (b.x, b.y, b.heading) == pytest.approx((a.x, a.y, a.heading), abs=1e-9)
    assert math.hypot(a.x - POSE[0], a.y - POSE[1]) < 0.02


@pytest.mark.parametrize(("reported", "moved_m"), [(7, 0.01), (10, 0.03)])
def test_pf_a_wrong_id_moves_the_estimate_at_most_the_gate(reported: int,
                                                           moved_m: float) -> None:
    """A wider cloud (5 cm, 0.01 rad, about 5 cm off), reflector 9 reported as reflector 7
    (metres away: outside every gate; the particles that put 9 outside its own gate too weigh
    it as an outlier, the others pay the id's cost) or as a neighbour 10 put 6 cm beside it
    (inside the gate of most of the cloud, which it then pulls): the estimate moves from that
    of the right id by less than the gate radius of the reflector (0.09 m), and by less than
    ``moved_m`` (measured, seeds 0-4: at most 5 mm with 7, the id set aside and 9 then
    ambiguous beside 10 for part of the cloud; 21 mm with 10)."""
    gate = float(_pf(0).gate_radii(_scan(POSE, [9], [9]))[0])
    assert 0.08 < gate < 0.1
    ids = [*SEEN[:-1], reported]
    layout = (*REFLECTORS, Reflector(10, 7.16, 7.7))
    for seed in range(5):
        right = _pf(seed, 0.05, 0.01, PRIOR, layout)
        wrong = _pf(seed, 0.05, 0.01, PRIOR, layout)
        assert right.update(_scan(POSE, SEEN, SEEN))
        assert wrong.update(_scan(POSE, SEEN, ids))
        a, b = right.estimate(), wrong.estimate()
        assert a is not None and b is not None
        moved = math.hypot(b.x - a.x, b.y - a.y)
        assert moved <= min(gate, moved_m), (seed, moved)
