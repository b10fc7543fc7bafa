"""The compiled loops of the EKF and dead reckoning give the numpy path's rows."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from localize_synth import circle_log

from lgvtool.localize.kernel_choice import KERNELS_ENV
from lgvtool.localize.replay_driver import replay_data

pytest.importorskip("numba")

NAMES = ["ekf", "deadreckoning"]


def _tables(monkeypatch: pytest.MonkeyPatch, mode: str, **log: object) -> dict[str, Any]:
    monkeypatch.setenv(KERNELS_ENV, mode)
    data, _, cfg = circle_log(6.0, **log)
    return replay_data(data, NAMES, config=cfg, seed=3).estimates


@pytest.mark.parametrize("log", [{}, {"ids": True}, {"scans": "none"}, {"scans": "snapshot"}])
def test_kernels_match_numpy(monkeypatch: pytest.MonkeyPatch, log: dict[str, object]) -> None:
    ref = _tables(monkeypatch, "numpy", **log)
    fast = _tables(monkeypatch, "numba", **log)
    for name in NAMES:
        a, b = ref[name], fast[name]
        assert len(a.x) == len(b.x) > 0
        assert np.array_equal(a.t_ns, b.t_ns)
        for col in ("x", "y", "heading"):
            assert np.allclose(getattr(a, col), getattr(b, col), rtol=0, atol=1e-9), col
        assert np.allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-15)


def test_poses_and_scans_match(monkeypatch: pytest.MonkeyPatch) -> None:
    """NAV pose updates (numpy) between compiled scan updates."""
    monkeypatch.setenv(KERNELS_ENV, "numpy")
    data, _, cfg = circle_log(6.0, ids=True)
    settings = {"ekf.observations": "both"}
    a = replay_data(data, ["ekf"], config=cfg, seed=3, settings=settings).estimates["ekf"]
    monkeypatch.setenv(KERNELS_ENV, "numba")
    b = replay_data(data, ["ekf"], config=cfg, seed=3, settings=settings).estimates["ekf"]
    assert len(a.x) == len(b.x) > 0
    assert np.allclose(a.x, b.x, rtol=0, atol=1e-9)
    assert np.allclose(a.heading, b.heading, rtol=0, atol=1e-9)
    assert np.allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("settings", [{}, {"ekf.observations": "both"}])
def test_chunks_across_their_bounds(monkeypatch: pytest.MonkeyPatch,
                                    settings: dict[str, str]) -> None:
    """A drive of several chunks of observations (:data:`lgvtool.localize.chunks.CHUNK`),
    scans alone or with NAV poses between them: the numpy path's rows."""
    from lgvtool.localize.chunks import CHUNK

    data, _, cfg = circle_log(150.0, ids=True)
    tables = []
    for mode in ("numpy", "numba"):
        monkeypatch.setenv(KERNELS_ENV, mode)
        tables.append(replay_data(data, NAMES, config=cfg, seed=3, settings=settings).estimates)
    for name in NAMES:
        a, b = tables[0][name], tables[1][name]
        assert len(a.x) == len(b.x) > 2 * CHUNK
        assert np.array_equal(a.t_ns, b.t_ns)
        for col in ("x", "y", "heading"):
            assert np.allclose(getattr(a, col), getattr(b, col), rtol=0, atol=1e-9), col
        assert np.allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-15)


def test_kernel_wrap_is_the_one_convention() -> None:
    """The EKF kernel's copy of the wrap gives lgvtool.angles' bits, -pi mapped to +pi."""
    import math

    from lgvtool.angles import wrap_angle, wrap_scalar
    from lgvtool.localize import ekf_kernels as k

    th = np.concatenate((np.random.default_rng(5).uniform(-20.0, 20.0, 2000),
                         [0.0, -math.pi, math.pi, 2 * math.pi, -3 * math.pi]))
    wrapped = np.array([k._wrap(float(v)) for v in th])
    assert np.array_equal(wrapped, np.array([wrap_scalar(float(v)) for v in th]))
    np.testing.assert_allclose(wrapped, wrap_angle(th), rtol=0, atol=1e-15)
    assert k._wrap(-math.pi) == math.pi
