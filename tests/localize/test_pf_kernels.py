"""The particle filters' compiled kernels against their numpy path (the reference), and both
filters' compiled runs (the paper filter's blocks, pf's chunks) against their predict /
update / estimate steps.

Same seed, same machine: the random stream is the same on both paths (checked on the
generator's state after the run), the estimates agree within 1e-9 m (rad), and the paper
filter's ``run`` equals the step-by-step loop within the same tolerance on either path: the
run perturbs a block of motions at once, and numpy's vectorised trigonometry may round the
last bit otherwise than per step on another numpy version or processor (numpy 1.26: 4e-15 m)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from localize_synth import circle_log

from lgvtool.localize.estimator import EstimateRows, Estimator
from lgvtool.localize.kernel_choice import KERNELS_ENV, uses_kernels
from lgvtool.localize.motion import MotionTrack
from lgvtool.localize.particle_backend import NumpyParticles
from lgvtool.localize.registry import ESTIMATORS, motion_params, resolve_params
from lgvtool.localize.replay_driver import _observations, estimator_rng

pytest.importorskip("numba")

#: tolerance of kernel against numpy path: positions m, headings rad
TOL = 1e-9


def _inputs(name: str, settings: dict[str, Any], duration: float = 30.0
            ) -> tuple[Any, Any, Any, Any, Any, Any]:
    # reflector ids in the scans: the paper filter's block path takes each point's candidate
    # from its id (association stays by nearest neighbour)
    data, _, cfg = circle_log(duration, ids=True)
    cls = ESTIMATORS[name]
    params = resolve_params(name, {}, settings)
    ms = motion_params(name, params).motion_settings()
    track = MotionTrack(data.increments(ms, cfg.vehicle), ms.step_form)
    obs, _ = _observations(data, cls, params, track, cfg.vehicle, start_poses=False)
    times = np.array([o.t for o in obs])
    steps = track.deltas(times[:-1], times[1:])
    return data, cfg, cls, params, (times, list(obs)), steps


def _run(monkeypatch: pytest.MonkeyPatch, mode: str, name: str, settings: dict[str, Any], *,
         steps_only: bool = False, seed: int = 3) -> tuple[EstimateRows, Any, Estimator]:
    """Run filter ``name`` over the circle drive with the kernels (``mode`` numba) or the
    numpy path; ``steps_only``: predict / update / estimate in turn (the base class's run)."""
    monkeypatch.setenv(KERNELS_ENV, mode)
    data, cfg, cls, params, (times, obs), steps = _inputs(name, settings)
    est = cls(params, vehicle=cfg.vehicle, reflectors=data.reflectors, area=cfg.area,
              rng=estimator_rng(seed, name))
    assert isinstance(est.backend, NumpyParticles) == (mode == "numpy")
    run = Estimator.run if steps_only else type(est).run
    rows = run(est, times, obs, steps, cloud_size=20)
    return rows, est.rng.bit_generator.state, est


def _same_clouds(a: EstimateRows, b: EstimateRows) -> None:
    """The same clouds: their times and particle counts, and the particles within
    :data:`TOL`."""
    assert [c[0] for c in a.clouds] == [c[0] for c in b.clouds]
    for ca, cb in zip(a.clouds, b.clouds, strict=True):
        for u, v in zip(ca[1:], cb[1:], strict=True):
            assert len(u) == len(v)
            np.testing.assert_allclose(u, v, rtol=0, atol=TOL)


def _close(rows_a: EstimateRows, rows_b: EstimateRows) -> None:
    """Within :data:`TOL` (the covariance and ESS relatively)."""
    a, b = rows_a.poses, rows_b.poses
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.particles, b.particles)
    np.testing.assert_allclose(a.x, b.x, rtol=0, atol=TOL)
    np.testing.assert_allclose(a.y, b.y, rtol=0, atol=TOL)
    dh = np.remainder(a.heading - b.heading + math.pi, 2 * math.pi) - math.pi
    assert np.abs(dh).max() <= TOL
    np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(a.ess, b.ess, rtol=1e-9)


PAPER_SETTINGS = [
    {},  # uniform start of 5000, shrinking to 150 after 10 updates
    {"start_updates": 0, "particles": 300},  # the paper: no separate start
    {"noise_dist": 0.02, "noise_rot": 0.02},  # motion noise: one draw per update
    {"spread_m": 0.05, "top_fraction": 0.5, "sigma_m": 0.2},
]


@pytest.mark.parametrize("mode", ["numba", "numpy"])
@pytest.mark.parametrize("settings", PAPER_SETTINGS)
def test_paper_run_equals_its_steps(monkeypatch: pytest.MonkeyPatch, mode: str,
                                    settings: dict[str, Any]) -> None:
    """PaperParticleFilter.run (packed blocks) against predict / update / estimate: the same
    random numbers, the estimates and clouds within :data:`TOL`."""
    block, block_state, _ = _run(monkeypatch, mode, "pf-paper", settings)
    steps, steps_state, _ = _run(monkeypatch, mode, "pf-paper", settings, steps_only=True)
    assert block_state == steps_state
    _close(block, steps)
    _same_clouds(block, steps)


PF_SETTINGS = [
    {},  # the defaults: KLD, recovery, outlier mixture, association by id
    {"kld": False, "particles": 500},  # fixed count: low-variance resampling in the kernel
    {"kld": False, "use_ids": False, "outlier": False, "resample": "always"},
    {"log_weights": False, "resampler": "multinomial"},
]


@pytest.mark.parametrize(("name", "settings"), [("pf-paper", s) for s in PAPER_SETTINGS]
                         + [("pf", s) for s in PF_SETTINGS])
def test_kernels_match_the_numpy_path(monkeypatch: pytest.MonkeyPatch, name: str,
                                      settings: dict[str, Any]) -> None:
    fast, fast_state, fast_est = _run(monkeypatch, "numba", name, settings)
    ref, ref_state, ref_est = _run(monkeypatch, "numpy", name, settings)
    assert len(ref.poses) > 50
    assert fast_state == ref_state  # the same random numbers were drawn
    if name == "pf":
        assert fast_est.resamplings == ref_est.resamplings > 0  # type: ignore[attr-defined]
    _close(fast, ref)


PF_RUN_SETTINGS = [
    *PF_SETTINGS[:3],
    # recovery re-draws particles at most resamplings here: the kernel hands them back
    {"alpha_fast": 0.5, "alpha_slow": 0.01, "particles": 400},
    {"init": "uniform", "start_particles": 3000, "start_updates": 5},
]


@pytest.mark.parametrize("settings", PF_RUN_SETTINGS)
def test_pf_run_equals_its_steps(monkeypatch: pytest.MonkeyPatch,
                                 settings: dict[str, Any]) -> None:
    """pf's run with its tracking in compiled chunks against predict / update / estimate in
    turn (the kernels in both): the same random stream, resamplings and re-drawn particles,
    the estimates within :data:`TOL` (the same kernels, compiled into one loop: bit for bit
    on the machines measured, but a compiler may vectorise a loop differently once
    inlined)."""
    from lgvtool.localize import pf_run
    from lgvtool.localize.particle_filter import ParticleFilter

    chunks, chunks_state, chunks_est = _run(monkeypatch, "numba", "pf", settings)
    steps, steps_state, steps_est = _run(monkeypatch, "numba", "pf", settings, steps_only=True)
    assert isinstance(chunks_est, ParticleFilter) and isinstance(steps_est, ParticleFilter)
    assert pf_run.tracker(chunks_est, None, 2) is not None
    assert chunks_state == steps_state
    assert chunks_est.resamplings == steps_est.resamplings > 0
    assert chunks_est.injected == steps_est.injected
    assert chunks_est.w_slow == pytest.approx(steps_est.w_slow, rel=1e-9)
    assert len(chunks.poses) > 50
    _close(chunks, steps)
    _same_clouds(chunks, steps)


def test_pf_run_hands_back_what_it_does_not_track(monkeypatch: pytest.MonkeyPatch) -> None:
    """The chunks hand recovery's resamplings to the filter (some particles re-drawn on this
    drive), and a run over NAV poses and scans mixed (``observations = both``) goes step by
    step for the poses: the random stream of the step-by-step loop, its rows within
    :data:`TOL`."""
    settings = {"alpha_fast": 0.5, "alpha_slow": 0.01, "particles": 400}
    _, _, est = _run(monkeypatch, "numba", "pf", settings)
    assert est.injected > 0  # type: ignore[attr-defined]
    monkeypatch.setenv(KERNELS_ENV, "numba")
    data, _, cfg = circle_log(30.0, ids=True)
    cls = ESTIMATORS["pf"]
    params = resolve_params("pf", {}, {"observations": "both"})
    ms = motion_params("pf", params).motion_settings()
    track = MotionTrack(data.increments(ms, cfg.vehicle), ms.step_form)
    obs, _ = _observations(data, cls, params, track, cfg.vehicle, start_poses=False)
    kinds = {type(o).__name__ for o in obs}
    assert kinds == {"PoseObservation", "ScanObservation"}
    times = np.array([o.t for o in obs])
    steps = track.deltas(times[:-1], times[1:])
    out = []
    for run in (cls.run, Estimator.run):
        est = cls(params, vehicle=cfg.vehicle, reflectors=data.reflectors, area=cfg.area,
                  rng=estimator_rng(5, "pf"))
        out.append((run(est, times, list(obs), steps, cloud_size=20),
                    est.rng.bit_generator.state))
    assert out[0][1] == out[1][1]
    _close(out[0][0], out[1][0])
    _same_clouds(out[0][0], out[1][0])


def test_pf_run_without_motion_noise(monkeypatch: pytest.MonkeyPatch) -> None:
    """Motions without noise (a vehicle standing still: every sigma 0) are the filter's
    noise-free step in the chunks too (within :data:`TOL`: NumPy's complex product may fuse
    its multiply-adds)."""
    settings = {"noise_dist": 0.0, "noise_lat": 0.0, "noise_rot": 0.0, "noise_rot_per_m": 0.0}
    chunks, chunks_state, _ = _run(monkeypatch, "numba", "pf", settings)
    steps, steps_state, _ = _run(monkeypatch, "numba", "pf", settings, steps_only=True)
    assert chunks_state == steps_state
    _close(chunks, steps)


def test_permutation_kernel_is_numpys() -> None:
    """The kernels' permutation: NumPy's numbers, and the generator left in NumPy's state."""
    from lgvtool.localize import pf_kernels as k

    for n in (1, 2, 3, 255, 256, 2000, 70_000):
        a, b = np.random.default_rng(n), np.random.default_rng(n)
        assert np.array_equal(k._permutation(a, n), b.permutation(n))
        assert a.bit_generator.state == b.bit_generator.state


def test_pf_draws_in_the_kernel(monkeypatch: pytest.MonkeyPatch) -> None:
    """The prediction's normal numbers drawn inside the kernel (as for large sets): the same
    stream and estimates as the numpy path."""
    from lgvtool.localize.pf_compiled import CompiledParticles

    settings = {"kld": False, "particles": 300}
    ref, ref_state, _ = _run(monkeypatch, "numpy", "pf", settings)
    monkeypatch.setattr(CompiledParticles, "DRAW_IN_KERNEL", 1)
    fast, fast_state, _ = _run(monkeypatch, "numba", "pf", settings)
    assert fast_state == ref_state
    _close(fast, ref)


def test_paper_redistribution_kernel_matches_numpy() -> None:
    """One weighing and redistribution from the same uniform numbers: eq. 11's sums and the
    covariance and ESS within rounding of the numpy path, the positions bit for bit, the
    rotors within an ulp (the kernel's small-angle series)."""
    from lgvtool.config import Area
    from lgvtool.localize import pf_kernels as kern
    from lgvtool.localize.particle_backend import covariances_and_ess
    from lgvtool.localize.resampling import RedistributionPlan

    rng = np.random.default_rng(5)
    for m, local in ((400, 0.95), (7, 1.0), (9, 0.0)):
        s = np.empty((m, 3), dtype=np.complex128)
        s[:, 0] = rng.uniform(0, 20, m) + 1j * rng.uniform(0, 10, m)
        s[:, 1] = np.exp(1j * rng.uniform(-math.pi, math.pi, m))
        s[:, 2] = 1.0
        s2 = np.ascontiguousarray(s[:, :2])  # the kernels' layout, without the ones
        exponent = -rng.random(m) * 30.0
        plan = RedistributionPlan(m, Area(0.0, 20.0, 0.0, 10.0), top_fraction=0.25,
                                  local_fraction=local, spread_m=0.25, heading_spread_rad=0.01)
        ref_draws = plan.draw(np.random.default_rng(9), 3, packed=True)
        raw_draws = plan.draw(np.random.default_rng(9), 3, packed=True, raw=True)
        for b in range(3):
            e_ref = exponent - exponent.max()
            w_ref = np.exp(e_ref)
            sx, sy, sc, ss, total, _ = (w_ref @ s.view(np.float64)).tolist()
            e_fast, w, sums = exponent.copy(), np.empty(m), np.empty(5)
            assert kern.paper_weights(s2, e_fast, w, sums) == sums[4]
            assert np.array_equal(e_fast, e_ref)
            np.testing.assert_allclose(w, w_ref, rtol=1e-15, atol=0)
            np.testing.assert_allclose(sums, [sx, sy, sc, ss, total], rtol=1e-12)
            w = w_ref.copy()  # the same weights on both paths from here
            kern.paper_sums(s2, w, sums)
            ref = np.empty_like(s)
            fast = np.empty_like(s2)
            plan.apply_packed(s, w, ref_draws, b, ref)
            cov = np.empty((3, 3))
            ess = kern.paper_resample(s2, w, plan.top(w), raw_draws.u[b], plan.kernel_plan,
                                      sums, fast, cov, kern.paper_scratch())
            assert np.array_equal(fast[:, 0], ref[:, 0])
            assert np.abs(fast[:, 1] - ref[:, 1]).max() <= 2.5e-16
            c_ref, e_ref2 = covariances_and_ess(s[None], w[None], sums[4:5],
                                                 np.array([complex(*sums[:2])]),
                                                 np.array([complex(*sums[2:4])]))
            np.testing.assert_allclose(cov, c_ref[0], rtol=1e-12, atol=1e-15)
            assert abs(ess - e_ref2[0]) <= 1e-12 * e_ref2[0]


def test_paper_weigh_is_its_parts() -> None:
    """The fused weighing (motion, association, exponents, weights and sums in one call)
    equals the motion, the exponents and the weights called one after the other, bit for
    bit, with points both near and far from their candidates (the whole-map search)."""
    from lgvtool.localize import pf_kernels as kern
    from lgvtool.localize.pf_compiled import kernel_scan

    rng = np.random.default_rng(8)
    map_z = rng.uniform(0, 20, 12) + 1j * rng.uniform(0, 10, 12)
    sep = np.abs(map_z[:, None] - map_z[None, :])
    np.fill_diagonal(sep, np.inf)
    half = 0.5 * sep.min(axis=1)
    for m in (1, 300, 700):
        prev = np.empty((m, 2), dtype=np.complex128)
        prev[:, 0] = 10 + 5j + rng.normal(0, 0.3, m) + 1j * rng.normal(0, 0.3, m)
        prev[:, 1] = np.exp(1j * rng.normal(0.4, 0.05, m))
        j = rng.integers(0, 12, 9)
        pose, turn = 10 + 5j, np.exp(0.4j)
        q = (map_z[j] - pose) / turn + rng.normal(0, 0.05, 9)
        scan = kernel_scan(q, map_z[j], half[j])
        step_z, step_rot = 0.02 + 0.001j, np.exp(0.003j)
        cur, e, w, sums = (np.empty_like(prev), np.empty(m), np.empty(m), np.empty(5))
        total = kern.paper_weigh(prev, cur, step_z, step_rot, scan, map_z, -0.5, e, w, sums,
                                 kern.paper_scratch())
        moved = np.empty_like(prev)
        kern.paper_move(prev, moved, step_z, step_rot)
        e2, w2, sums2 = np.empty(m), np.empty(m), np.empty(5)
        kern.paper_exponents(moved, moved, 0j, 1 + 0j, scan, map_z, -0.5, e2,
                             kern.paper_scratch())
        assert kern.paper_weights(moved, e2, w2, sums2) == total == sums[4]
        assert np.array_equal(cur, moved)
        assert np.array_equal(e, e2) and np.array_equal(w, w2) and np.array_equal(sums, sums2)
        assert e.max() == 0.0


def test_paper_exponents_search_the_map_for_far_particles() -> None:
    """Eq. 10's exponents of a set whose far particles (uniform over the hall: every point
    searched in the whole map, more of them than a chunk) are weighed together: the summed
    distances to the nearest map reflector of every point, found by brute force."""
    from lgvtool.localize import pf_kernels as kern
    from lgvtool.localize.pf_compiled import kernel_scan

    rng = np.random.default_rng(12)
    map_z = rng.uniform(0, 25, 30) + 1j * rng.uniform(0, 20, 30)
    sep = np.abs(map_z[:, None] - map_z[None, :])
    np.fill_diagonal(sep, np.inf)
    half = 0.5 * sep.min(axis=1)
    pose, turn = 12 + 9j, np.exp(0.4j)
    j = rng.choice(30, 11, replace=False)
    q = (map_z[j] - pose) / turn + rng.normal(0, 0.03, 11)
    scan = kernel_scan(q, map_z[j], half[j])
    m = 3000
    s = np.empty((m, 2), dtype=np.complex128)
    s[:, 0] = pose + rng.normal(0, 0.1, m) + 1j * rng.normal(0, 0.1, m)
    s[:, 1] = turn * np.exp(1j * rng.normal(0, 0.01, m))
    far = rng.random(m) < 0.2  # about 600 far particles, in every chunk
    s[far, 0] = rng.uniform(0, 25, far.sum()) + 1j * rng.uniform(0, 20, far.sum())
    s[far, 1] = np.exp(1j * rng.uniform(-math.pi, math.pi, far.sum()))
    e = np.empty(m)
    top = kern.paper_exponents(s, s, 0j, 1 + 0j, scan, map_z, -0.5, e, kern.paper_scratch())
    zr, zi, rr, ri = s[:, 0].real, s[:, 0].imag, s[:, 1].real, s[:, 1].imag
    px = zr[:, None] + (rr[:, None] * q.real - ri[:, None] * q.imag)
    py = zi[:, None] + (rr[:, None] * q.imag + ri[:, None] * q.real)
    ex = map_z.real[None, None, :] - px[:, :, None]
    ey = map_z.imag[None, None, :] - py[:, :, None]
    d = np.sqrt((ex * ex + ey * ey).min(axis=2))
    total = np.cumsum(d, axis=1)[:, -1]  # summed in point order
    ref = total * total * -0.5
    # (elementwise IEEE arithmetic and square roots on both sides: equal here; a tolerance
    # for another compiler's choices)
    np.testing.assert_allclose(e, ref, rtol=1e-13, atol=0)
    assert top == pytest.approx(ref.max(), rel=1e-13)


def test_numpy_mode_needs_no_numba(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(KERNELS_ENV, "numpy")
    assert not uses_kernels()
    monkeypatch.setenv(KERNELS_ENV, "numba")
    assert uses_kernels()


def test_kernel_pieces_against_numpy() -> None:
    """The wrap bit for bit, the resampling's indices exactly, the series (and the
    exponential of the mixture) within ulps."""
    from lgvtool.angles import wrap_angle
    from lgvtool.localize import pf_kernels as k
    from lgvtool.localize.resampling import low_variance

    rng = np.random.default_rng(11)
    th = np.concatenate((rng.uniform(-20.0, 20.0, 2000), [0.0, -math.pi, math.pi, 2 * math.pi]))
    wrapped = np.array([k._wrap_pi(float(v)) for v in th])
    assert np.array_equal(wrapped, wrap_angle(th))  # the one convention, (-pi, pi]
    assert k._wrap_pi(-math.pi) == math.pi and k._wrap_pi(math.pi) == math.pi
    y = rng.uniform(-0.05, 0.05, 2000)
    h = np.array([k._heading(float(v), 1.0) for v in y])
    np.testing.assert_allclose(h, np.arctan2(y, 1.0), rtol=5e-16, atol=0)
    t = np.concatenate((rng.uniform(0.0, 38.0, 5000), rng.uniform(38.0, 708.0, 5000),
                        [0.0, 38.0, 708.0, 5e-324, math.log(2) / 2]))
    e = np.array([k._exp_neg(float(v)) for v in t])
    np.testing.assert_allclose(e, [math.exp(-v) for v in t], rtol=2.5e-16, atol=0)
    x = rng.uniform(-0.2, 0.2, 2000)
    r = np.array([k._rotor(float(v)) for v in x])
    assert np.abs(r - np.exp(1j * x)).max() <= 2.5e-16
    for m, n in ((1, 5), (7, 7), (300, 120), (1000, 4000)):
        w = rng.random(m) ** 4
        w /= w.sum()
        ref = low_variance(w, n, np.random.default_rng(m))
        z = rng.random(m) + 1j * rng.random(m)
        ths = rng.uniform(-math.pi, math.pi, m)
        out = (np.empty(n, dtype=np.complex128), np.empty(n), np.empty(n, dtype=np.complex128),
               np.empty(n, dtype=np.intp))
        k.low_variance_gather(w, np.random.default_rng(m).random(), n, z, ths, np.exp(1j * ths),
                              *out, True)
        assert np.array_equal(out[3], ref)
        assert np.array_equal(out[0], z[ref])
        assert np.array_equal(out[1], np.remainder(ths[ref] + math.pi, 2 * math.pi) - math.pi)


def test_kld_resampling_kernel_against_numpy() -> None:
    """KLD resampling in one pass: the same count and indices as low-variance draws, the
    permutation, the bin keys and the sequential count of the numpy path, from the same
    generator (its state equal afterwards)."""
    from lgvtool.localize import pf_kernels as k
    from lgvtool.localize.kld import bin_keys, kld_bound, kld_count
    from lgvtool.localize.resampling import low_variance

    rng = np.random.default_rng(21)
    for m, cap, spread, n_min in ((1, 50, 1.0, 10), (105, 2000, 0.3, 100), (300, 2000, 40.0, 100),
                                  (2000, 2000, 5.0, 1), (50, 400, 1e4, 20)):
        w = rng.random(m) ** 3
        w /= w.sum()
        z = rng.normal(0.0, spread, m) + 1j * rng.normal(-3.0, spread, m)
        th = rng.uniform(-math.pi, math.pi, m)
        a, b = np.random.default_rng(m), np.random.default_rng(m)
        idx = low_variance(w, cap, a)
        idx = idx[a.permutation(cap)]
        keys = bin_keys(z.real[idx], z.imag[idx], th[idx], 0.25, 0.1)
        n_ref = kld_count(keys, 0.02, 0.01, n_min, cap)
        out = (np.empty(cap, dtype=np.complex128), np.empty(cap),
               np.empty(cap, dtype=np.complex128), np.empty(cap, dtype=np.intp))
        u0 = b.random()
        n = k.pf_kld_resample(w, u0, b.permutation(cap),
                              kld_bound(np.arange(1, cap + 1), 0.02, 0.01), n_min, 0.25, 0.1,
                              z, th, np.exp(1j * th), *out)
        assert a.bit_generator.state == b.bit_generator.state
        assert n == n_ref
        assert np.array_equal(out[3][:n], idx[:n])
        assert np.array_equal(out[0][:n], z[idx[:n]])
        assert np.array_equal(out[1][:n], np.remainder(th[idx[:n]] + math.pi, 2 * math.pi)
                              - math.pi)
