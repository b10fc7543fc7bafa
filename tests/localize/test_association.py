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
from lgvtool.localize.fix import pose_fix, scan_fix
from lgvtool.localize.geometry import pose_from_correspondences
from lgvtool.localize.kernel_choice import KERNELS_ENV
from lgvtool.localize.observations import ReflectorMap, ScanObservation
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
