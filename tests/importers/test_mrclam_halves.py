"""The rule fixed before scoring (``benchmarks/mrclam_halves.py``, docs/mrclam.md "A rule fixed
before scoring"): halves split at the midpoint of the scored span, a half replayed from the
ground truth at its start, the apportioned reference giving back the whole-run figure, and the
choice by the least fit score with ties to the earlier candidate. On the synthetic dataset of
``conftest.py`` (no real data needed)."""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from benchmark_modules import benchmark


def _halves() -> ModuleType:
    """``benchmarks/mrclam_halves.py``."""
    return benchmark("mrclam_halves")


def _log(synthetic: Any, tmp_path: Path) -> Any:
    from lgvtool.importers.mrclam_log import import_robot

    out = tmp_path / "r1.mcap"
    import_robot(synthetic.root, 1, out)
    return _halves().RobotLog.read(out)


def test_the_second_half_starts_at_the_truth_at_the_midpoint(synthetic: Any,
                                                            tmp_path: Path) -> None:
    h = _halves()
    log = _log(synthetic, tmp_path)
    span = h.span_of(log.data)
    # first scan 1.0 s after the first truth stamp; the truth ends at 10.0 s, before the
    # odometry (12.0 s): the span is 1.0 .. 10.0 s after T0
    t0 = synthetic.t0 - log.t0_s
    assert math.isclose(span.start, t0 + 1.0, abs_tol=1e-6)
    assert math.isclose(span.end, t0 + 10.0, abs_tol=1e-6)
    assert math.isclose(span.mid, t0 + 5.5, abs_tol=1e-6)
    b = h.replay(log, "ekf", {}, span.mid, span.end + 1.0, seed=0)
    first = b.iloc[0]
    assert math.isclose(first["t"] - log.t0_s, span.mid, abs_tol=1e-6)
    # synthetic truth: 0.1 m/s along x from (1, 0.5) at T0, heading 0
    assert math.isclose(first["x"], 1.55, abs_tol=1e-6)
    assert math.isclose(first["y"], 0.5, abs_tol=1e-6)
    assert math.isclose(first["heading"], 0.0, abs_tol=1e-6)
    # the scans after the midpoint (6.0 s: one landmark; 11.0 s is past the truth) update it
    assert len(b) >= 2


def test_the_apportioned_halves_give_back_the_whole_run(synthetic: Any, tmp_path: Path) -> None:
    """ref(A)^2 n_A + ref(B)^2 n_B = ref(run)^2 (n_A + n_B) when ref(h) = ref x plain(h) /
    plain(run): the halves partition the odometry steps of the plain EKF's run."""
    h = _halves()
    log = _log(synthetic, tmp_path)
    span = h.span_of(log.data)
    # odometry that says 1.5 times the distance driven: the plain EKF drifts between scans
    log.data.twist["v"] = log.data.twist["v"] * 1.5
    log.odometry["v"] *= 1.5
    p = h.plain_scores(log, span, 0)
    t = log.odometry["t"].to_numpy() - log.t0_s
    n_a = int(((t >= span.start) & (t < span.mid)).sum())
    n_b = int(((t >= span.mid) & (t <= span.end)).sum())
    assert p["run"] > 0.0 and p["A"] != p["B"]
    assert math.isclose(p["A"] ** 2 * n_a + p["B"] ** 2 * n_b, p["run"] ** 2 * (n_a + n_b),
                        rel_tol=1e-9)


def test_the_choice_is_the_least_fit_score_ties_to_the_earlier() -> None:
    h = _halves()
    # fit = worst + 0.25 x mean: 0.9 + 0.2 = 1.1; 0.85 + 0.2125 = 1.0625; the same again
    ratio = np.array([[0.7, 0.9], [0.85, 0.85], [0.85, 0.85]])
    assert h.choose(ratio) == 1
    assert h.choose(ratio[[0, 2, 1]]) == 1
    assert h.choose(ratio[[0]]) == 0


def test_a_change_goes_under_every_candidate_of_its_estimator_only() -> None:
    m = _halves()
    changed = m.with_change(list(m.CANDIDATES), {"ekf.update_iterations": 10})
    assert [c.label for c in changed] == [c.label for c in m.CANDIDATES]
    for before, after in zip(m.CANDIDATES, changed, strict=True):
        if before.estimator == "ekf":
            assert after.settings == {**before.settings, "ekf.update_iterations": 10}
        else:
            assert after.settings == before.settings
    # the plain EKF that apportions the reference is no candidate: it stays as it is
    assert "ekf.update_iterations" not in m.PLAIN_EKF
