"""The calibration's factors: the analytic Jacobian against finite differences, the arc terms
against their closed form, and the MCU sampling instants."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from calibrate_cases import ERRORS

from lgvtool.calibrate.drive import mcu_sample_times, prepare
from lgvtool.calibrate.model import arc_terms
from lgvtool.calibrate.quantities import QUANTITIES, default_names
from lgvtool.calibrate.solve import Problem, SolveSettings
from lgvtool.localize.logdata import LogData
from lgvtool.sim.logfile import write_log
from lgvtool.sim.simulation import simulate


def test_arc_terms_match_closed_form_and_derivatives() -> None:
    a = np.array([-1.0, -0.3, -1e-5, 0.0, 2e-5, 0.2, 0.9])
    big_a, big_b, da, db = arc_terms(a)
    safe = np.where(a == 0, 1.0, a)
    assert big_a == pytest.approx(np.where(a == 0, 1.0, np.sin(safe) / safe), abs=1e-12)
    assert big_b == pytest.approx(np.where(a == 0, 0.0, (1 - np.cos(safe)) / safe), abs=1e-12)
    h = 1e-6
    fa, fb, _, _ = arc_terms(a + h)
    ga, gb, _, _ = arc_terms(a - h)
    assert da == pytest.approx((fa - ga) / (2 * h), abs=1e-6)
    assert db == pytest.approx((fb - gb) / (2 * h), abs=1e-6)


def _problem(tmp_path: Path, use_poses: bool) -> Problem:
    """The least squares of a 14 s warehouse drive with installation errors, linked."""
    from lgvtool.localize.logdata import load_log
    from lgvtool.log import LogReader

    sim = simulate("warehouse", seed=21, duration=14.0, overrides=ERRORS)
    path = tmp_path / "w.mcap"
    write_log(sim, path)
    reader = LogReader(path)
    cfg = reader.config()
    data: LogData = load_log(reader, cfg.reflectors)
    drive = prepare("w", data, cfg.reflectors, observations="poses" if use_poses else "auto")
    start = {n: float(getattr(cfg.vehicle, n)) for n in QUANTITIES}
    names = [n for n in default_names("mcu", not use_poses, use_poses) if n != "nav_pose_age"]
    problem = Problem([drive], names, start, cfg.reflectors, cfg.vehicle.encoder_ppr,
                      SolveSettings(bias_stretch_s=5.0,
                                    pose_period_s=0.125 if use_poses else None), [use_poses])
    problem.relink()
    return problem


@pytest.mark.parametrize("use_poses", [False, True])
def test_jacobian_matches_finite_differences(tmp_path: Path, use_poses: bool) -> None:
    problem = _problem(tmp_path, use_poses)
    # the poses' skew lever is in the state when poses are observed
    assert ("pose_lever_y:0" in problem.layout.names) == use_poses
    x = problem.x.copy()
    x[: len(problem.layout.names)] += 1e-4  # away from the prior's minimum
    r0, jac, _, _, _ = problem.evaluate(x)
    assert jac is not None
    dense = jac.toarray()
    rng = np.random.default_rng(0)
    n_glob = len(problem.layout.names)
    columns = [*range(n_glob), *rng.choice(np.arange(n_glob, len(x)), 40, replace=False)]
    for c in columns:
        h = 1e-7 * max(1.0, abs(x[c]))
        xp, xm = x.copy(), x.copy()
        xp[c] += h
        xm[c] -= h
        rp = problem.evaluate(xp, jac=False)[0]
        rm = problem.evaluate(xm, jac=False)[0]
        numeric = (rp - rm) / (2 * h)
        ok = np.abs(numeric) < 1e6  # a bearing wrapping at +-pi in between is no derivative
        scale = max(1.0, float(np.abs(numeric[ok]).max()))
        assert dense[ok, c] == pytest.approx(numeric[ok], abs=2e-4 * scale), c
    assert np.isfinite(r0).all()


@pytest.mark.parametrize("use_poses", [False, True])
def test_observation_blocks_give_the_same_normal_equations(tmp_path: Path, use_poses: bool,
                                                          monkeypatch: pytest.MonkeyPatch
                                                          ) -> None:
    """The measurements' factors computed a few at a time give the same rows (in another
    order): the same cost, normal matrix and gradient."""
    from lgvtool.calibrate import model

    problem = _problem(tmp_path, use_poses)
    r0, j0, g0, _, _ = problem.evaluate(problem.x)
    monkeypatch.setattr(model, "OBSERVATION_BLOCK", 7)
    r1, j1, g1, _, _ = problem.evaluate(problem.x)
    assert j0 is not None and j1 is not None
    assert len(r1) == len(r0) and sorted(g1.tolist()) == sorted(g0.tolist())
    assert r1 @ r1 == pytest.approx(r0 @ r0, rel=1e-12)
    h0, h1 = (j0.T @ j0).toarray(), (j1.T @ j1).toarray()
    assert h1 == pytest.approx(h0, rel=1e-9, abs=1e-9 * float(np.abs(h0).max()))
    assert j1.T @ r1 == pytest.approx(j0.T @ r0, rel=1e-9, abs=1e-9 * float(np.abs(h0).max()))


def test_elimination_order_keeps_the_factor_a_band(tmp_path: Path) -> None:
    """Nodes in time order, each gyro bias after its stretch's nodes, the quantities last; the
    factor of the normal matrix in that order stays within a small multiple of the matrix
    (eliminating the quantities first would fill it), and solves it."""
    import scipy.sparse as sp

    from lgvtool.sparse_normal import Factor, scaled_normal

    problem = _problem(tmp_path, use_poses=False)
    layout = problem.layout
    order = problem.elimination_order()
    assert sorted(order.tolist()) == list(range(layout.size))
    n_glob = len(layout.names)
    assert order[-n_glob:].tolist() == list(range(n_glob))
    assert layout.bias_count[0] >= 2
    node_of = {c: (c - layout.pose_offset[0]) // 3 for c in order.tolist()
               if layout.pose_offset[0] <= c < layout.bias_offset[0]}
    nodes = [node_of[c] for c in order.tolist() if c in node_of]
    assert nodes == sorted(nodes)
    drive = problem.drives[0]
    place = {c: i for i, c in enumerate(order.tolist())}
    for b in range(layout.bias_count[0] - 1):
        last = int(np.searchsorted(drive.t, drive.t[0] + 5.0 * (b + 1))) - 1
        first_after = last + 1
        at = place[layout.bias_offset[0] + b]
        assert place[layout.pose_offset[0] + 3 * last + 2] < at
        assert at < place[layout.pose_offset[0] + 3 * first_after]
    _, j, _, _, _ = problem.evaluate(problem.x)
    assert j is not None
    h, _ = scaled_normal(j)
    h = (h + sp.identity(layout.size) * 1e-6).tocsc()
    factor = Factor(h, order)
    assert factor.lu.L.nnz + factor.lu.U.nnz <= 3 * h.nnz
    glob_first = np.concatenate([order[-n_glob:], order[:-n_glob]])
    assert Factor(h, glob_first).lu.L.nnz + Factor(h, glob_first).lu.U.nnz > 3 * h.nnz
    rng = np.random.default_rng(3)
    rhs = rng.standard_normal((layout.size, 2))
    dense = np.linalg.solve(h.toarray(), rhs)
    tol = 1e-9 * float(np.abs(dense).max())
    assert factor.solve(rhs) == pytest.approx(dense, rel=1e-6, abs=tol)
    assert factor.solve(rhs[:, 0]) == pytest.approx(dense[:, 0], rel=1e-6, abs=tol)


def test_mcu_sampling_instants_follow_the_mcu_clock() -> None:
    rng = np.random.default_rng(1)
    n = 3000
    true = 0.05 + 0.1 * np.arange(n)
    clock_ms = np.floor((7.0 + true * (1 + 25e-6)) * 1000).astype(np.int64)
    wire = 30 * 10 / 115_200
    recv = true + wire + 0.001 + rng.uniform(0, 0.002, n)
    t, clock = mcu_sample_times(recv, clock_ms, 115_200)
    assert clock == "mcu"
    # within the host's read latency (1 ms here) and the clock's ms steps
    assert np.median(t - true) == pytest.approx(0.001, abs=4e-4)
    assert np.abs(t - true).max() < 0.0025
    jumpy = recv.copy()
    jumpy[::7] += 0.2
    assert mcu_sample_times(jumpy, clock_ms[::-1].copy(), 115_200)[1] == "host"


def test_growing_arrays_join_blocks_across_their_capacity() -> None:
    """Blocks appended past the capacity (none, too little, enough) come back joined in
    order; widening keeps the values."""
    from lgvtool.calibrate.model import _Growing

    rng = np.random.default_rng(5)
    blocks = [rng.integers(0, 1000, size=int(k)) for k in rng.integers(0, 700, size=12)]
    joined = np.concatenate(blocks)
    for capacity in (0, 10, len(joined)):
        grow = _Growing(np.int32, capacity)
        for i, b in enumerate(blocks):
            if i == 6:
                grow.widen(np.int64)
            grow.extend(b)
        out = grow.take()
        assert out.dtype == np.int64 and out.tolist() == joined.tolist()
        assert grow.take().tolist() == []


def test_the_jacobian_made_with_room_up_front_is_the_same(tmp_path: Path) -> None:
    """The second evaluation makes room for the first one's rows and entries: the same
    Jacobian (the same entries, and values to 1e-14 relative: the same arithmetic in the same
    order, only written elsewhere) and residuals."""
    problem = _problem(tmp_path, use_poses=False)
    problem.factors.capacity = (0, 0)
    r0, j0, _, _, _ = problem.evaluate(problem.x)
    assert j0 is not None and problem.factors.capacity == (j0.shape[0], j0.nnz)
    r1, j1, _, _, _ = problem.evaluate(problem.x)
    assert j1 is not None
    assert r1 == pytest.approx(r0, rel=1e-14, abs=0.0)
    assert j1.indptr.tolist() == j0.indptr.tolist()
    assert j1.indices.tolist() == j0.indices.tolist()
    assert j1.data == pytest.approx(j0.data, rel=1e-14, abs=0.0)


@pytest.mark.parametrize("use_poses", [False, True])
def test_normal_matrix_and_covariance_formed_a_slice_of_rows_at_a_time(
        tmp_path: Path, use_poses: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Slices of a few rows give the normal matrix ``jᵀj`` and the formal and cluster-robust
    covariances of one slice; the slices cover the rows once, in order."""
    from lgvtool import sparse_normal

    problem = _problem(tmp_path, use_poses)
    _, j, _, _, _ = problem.evaluate(problem.x)
    assert j is not None
    whole = (j.T @ j).toarray()
    formal0, robust0 = problem.covariance()
    monkeypatch.setattr(sparse_normal, "NORMAL_SLICE_ENTRIES", 37)
    slices = list(sparse_normal.row_slices(j))
    assert len(slices) > 100
    assert [s[0] for s in slices[1:]] == [s[1] for s in slices[:-1]]
    assert slices[0][0] == 0 and slices[-1][1] == j.shape[0]
    assert sum(s.nnz for _, _, s in slices) == j.nnz
    tol = 1e-12 * float(np.abs(whole).max())
    assert sparse_normal.normal_matrix(j).toarray() == pytest.approx(whole, rel=1e-12, abs=tol)
    import scipy.sparse as sp

    assert sparse_normal.normal_matrix(sp.csr_matrix((0, 5))).toarray().tolist() == [[0.0] * 5] * 5
    formal1, robust1 = problem.covariance()
    # inverses of the normal matrix, whose conditioning turns the sums' other rounding (1e-16
    # relative) into about 1e-7 here; a row lost or counted twice moves them by far more
    assert formal1 == pytest.approx(formal0, rel=1e-5, abs=1e-9 * float(np.abs(formal0).max()))
    assert robust1 == pytest.approx(robust0, rel=1e-5, abs=1e-9 * float(np.abs(robust0).max()))
