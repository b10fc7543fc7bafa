"""The one trajectory type (lgvtool/trajectory.py): each operation, its units, edge cases."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
import pytest

from lgvtool.errors import InputError
from lgvtool.trajectory import FloatArray, Trajectory

TOL = 1e-12
"""Tolerance of computed positions (m) and angles (rad)."""


def _f(v: Sequence[float] | FloatArray) -> FloatArray:
    return np.asarray(v, dtype=np.float64)


def _traj(t: Sequence[float], x: Sequence[float], y: Sequence[float],
          heading: Sequence[float] | FloatArray, t0_ns: int = 0) -> Trajectory:
    """A trajectory of plain numbers (s, m, m, rad)."""
    return Trajectory(_f(t), _f(x), _f(y), _f(heading), t0_ns)


def _line(n: int = 5, t0_ns: int = 0) -> Trajectory:
    """O driving along x at 1 m/s, heading 0, one pose a second from t = 10 s."""
    t = 10.0 + np.arange(n, dtype=float)
    return Trajectory(t, t - 10.0, np.zeros(n), np.zeros(n), t0_ns)


def test_columns_are_float_arrays_of_one_length() -> None:
    tr = _traj([1, 2], [0, 1], [0, 0], [0.0, 0.5])
    assert tr.t.dtype == np.float64 and len(tr) == 2
    with pytest.raises(ValueError, match="shape"):
        _traj([1.0, 2.0], [0.0], [0.0, 0.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="covariance"):
        Trajectory(_f([1.0]), _f([0.0]), _f([0.0]), _f([0.0]), covariance=np.zeros((1, 3)))


def test_unsorted_times_are_refused_equal_times_kept() -> None:
    with pytest.raises(ValueError, match="decrease at row 2"):
        _traj([0.0, 1.0, 0.5], [0, 0, 0], [0, 0, 0], [0, 0, 0])
    assert len(_traj([0.0, 1.0, 1.0], [0, 0, 0], [0, 0, 0], [0, 0, 0])) == 3


def test_empty_and_one_row() -> None:
    empty = Trajectory.empty()
    assert len(empty) == 0 and empty.duration == 0.0 and empty.path_length() == 0.0
    assert len(empty.between(0.0, 1e12)) == 0
    with pytest.raises(ValueError, match="empty"):
        empty.interpolate([1.0])
    one = _traj([5.0], [1.0], [2.0], [0.3])
    assert one.duration == 0.0 and one.path_length() == 0.0
    at = one.interpolate([4.0, 5.0, 6.0])  # the one pose everywhere
    assert np.allclose(at.x, 1.0, atol=TOL) and np.allclose(at.heading, 0.3, atol=TOL)
    mine, ref = _line().sync(one)
    assert len(mine) == 0 and len(ref) == 0


def test_cleaned_sorts_drops_and_keeps_the_last_of_equal_times() -> None:
    tr = Trajectory.cleaned([3.0, 1.0, math.nan, 1.0, 2.0], [30, 10, 0, 11, math.inf],
                            [0, 0, 0, 0, 0], None)
    assert tr.t.tolist() == [1.0, 3.0]
    assert tr.x.tolist() == [11.0, 30.0]  # the later of the two rows at t = 1 s
    assert np.all(np.isnan(tr.heading))  # no heading given
    assert len(Trajectory.cleaned([], [], [])) == 0


def test_extras_follow_the_rows() -> None:
    cov = np.arange(5 * 9, dtype=np.float64).reshape(5, 9)
    line = _line()
    tr = Trajectory(line.t, line.x, line.y, line.heading, covariance=cov,
                    particles=np.arange(5, dtype=np.int64), ess=np.arange(5, dtype=np.float64) * 2.0)
    part = tr.between(11.0, 12.5)
    assert part.t.tolist() == [11.0, 12.0]
    assert part.covariance is not None and part.covariance[0, 0] == 9.0
    assert part.particles is not None and part.particles.tolist() == [1, 2]
    assert part.ess is not None and part.ess.tolist() == [2.0, 4.0]


def test_times_in_ns_and_on_the_epoch() -> None:
    t0 = 1_704_067_200_000_000_000  # 2024-01-01T00:00:00Z
    tr = _traj([0.0, 0.5, 1.000000001], [0, 0, 0], [0, 0, 0], [0, 0, 0], t0)
    assert tr.t_ns.tolist() == [t0, t0 + 500_000_000, t0 + 1_000_000_001]
    epoch = tr.on_epoch()
    assert epoch.t0_ns == 0
    assert epoch.t == pytest.approx(tr.t_ns * 1e-9, abs=1e-6)
    assert epoch.on_epoch() is epoch


def test_interpolate_unwraps_the_heading_then_wraps_it() -> None:
    # turning through +pi: 3.0 rad, then -3.0 rad (3.28 rad continuous)
    tr = _traj([0.0, 1.0], [0.0, 2.0], [0.0, -2.0], [3.0, -3.0])
    at = tr.interpolate([0.5, 2.0])
    assert at.x[0] == pytest.approx(1.0, abs=TOL) and at.y[0] == pytest.approx(-1.0, abs=TOL)
    mid = 0.5 * (3.0 + (2 * math.pi - 3.0))  # the middle of the short way round: pi
    assert abs(math.remainder(at.heading[0] - mid, 2 * math.pi)) < TOL
    assert -math.pi < at.heading[0] <= math.pi
    assert at.x[1] == pytest.approx(2.0, abs=TOL)  # after the end: the last pose


def test_between_is_inclusive() -> None:
    assert _line().between(11.0, 13.0).t.tolist() == [11.0, 12.0, 13.0]
    assert len(_line().between(20.0, 30.0)) == 0


def test_sync_keeps_rows_inside_the_reference_and_out_of_its_gaps() -> None:
    ref = _traj([0.0, 1.0, 2.0, 10.0, 11.0], [0, 1, 2, 10, 11], [0] * 5, [0.0] * 5)
    est = _traj([-1.0, 0.5, 1.5, 5.0, 10.5, 12.0], [9] * 6, [0] * 6, [0.0] * 6)
    mine, at = est.sync(ref, max_gap=0.5)
    # -1 and 12 s lie outside; 5 s inside the 8 s gap (longer than 0.5 s and 5 x 1 s)
    assert mine.t.tolist() == [0.5, 1.5, 10.5]
    assert at.t.tolist() == mine.t.tolist()
    assert at.x == pytest.approx([0.5, 1.5, 10.5], abs=TOL)
    with pytest.raises(ValueError, match="different clocks"):
        est.sync(_line(t0_ns=1))


def test_path_length_in_metres() -> None:
    assert _line(5).path_length() == pytest.approx(4.0, abs=TOL)
    square = _traj([0, 1, 2, 3, 4], [0, 1, 1, 0, 0], [0, 0, 1, 1, 0], [0.0] * 5)
    assert square.path_length() == pytest.approx(4.0, abs=TOL)


def test_wrapped_and_unwrapped() -> None:
    h = np.array([0.0, 3.0, 3.0 + 1.0, 3.0 + 2.0])
    tr = Trajectory(np.arange(4.0), np.zeros(4), np.zeros(4), h)
    w = tr.wrapped()
    assert np.all((w.heading > -math.pi) & (w.heading <= math.pi))
    assert w.unwrapped().heading == pytest.approx(h, abs=1e-9)


def test_frame_round_trip_and_missing_columns() -> None:
    tr = _line(3)
    back = Trajectory.from_frame(tr.to_frame())
    assert back.t.tolist() == tr.t.tolist() and back.x.tolist() == tr.x.tolist()
    unordered = pd.DataFrame({"t": [2.0, 1.0], "x": ["3", "bad"], "y": [0.0, 0.0]})
    got = Trajectory.from_frame(unordered)
    assert got.t.tolist() == [2.0] and got.x.tolist() == [3.0]  # "bad" is no number
    with pytest.raises(InputError, match="trajectory 'pf' lacks column"):
        Trajectory.from_frame(pd.DataFrame({"t": [1.0], "x": [0.0]}), name="pf")
