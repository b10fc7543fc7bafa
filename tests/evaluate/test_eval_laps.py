"""Rotation segmentation by the unwrapped angle about the centre."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from evaluate_synth import CENTRE, PERIOD, T0, circle_drive

from lgvtool.circle import Circle
from lgvtool.evaluate.laps import segment_laps, swept_angle

C = Circle(CENTRE[0], CENTRE[1], 0.7)


@pytest.mark.parametrize("direction", [1, -1])
def test_complete_and_partial_rotations(direction: int) -> None:
    df = circle_drive(rotations=3.4, dt=0.05, direction=direction, phase=1.0)
    laps = segment_laps(df["t"], df["x"], df["y"], C, source="truth")
    assert laps.complete == 3
    assert laps.partial == 1
    assert laps.partial_fraction == pytest.approx(0.4, abs=0.01)
    assert laps.direction == direction
    assert np.diff(laps.boundaries) == pytest.approx([PERIOD] * 3, abs=0.06)
    assert laps.boundaries[0] == T0


def test_exact_number_of_rotations_has_no_partial() -> None:
    df = circle_drive(rotations=2.0 + 1e-4, dt=0.01)
    laps = segment_laps(df["t"], df["x"], df["y"], C)
    assert (laps.complete, laps.partial) == (2, 0)


def test_index_assigns_times_to_rotations() -> None:
    df = circle_drive(rotations=2.5, dt=0.1)
    laps = segment_laps(df["t"], df["x"], df["y"], C)
    idx = laps.index(df["t"])
    assert set(np.unique(idx)) == {0, 1, 2}
    assert idx[0] == 1
    assert idx[-1] == 0        # the partial rotation is outside every rotation
    assert laps.index([T0 - 1.0])[0] == 0


def test_backward_jitter_does_not_start_a_rotation_twice() -> None:
    df = circle_drive(rotations=1.6, dt=0.1, sd=0.0)
    x, y = df["x"].to_numpy(), df["y"].to_numpy()
    # jitter the angle back and forth by noise around the 2 pi crossing
    rng = np.random.default_rng(0)
    a = np.arctan2(y - CENTRE[1], x - CENTRE[0]) + rng.normal(0, 0.05, x.size)
    x2, y2 = CENTRE[0] + 0.7 * np.cos(a), CENTRE[1] + 0.7 * np.sin(a)
    swept, _ = swept_angle(x2, y2, CENTRE)
    assert np.all(np.diff(swept) >= 0)
    laps = segment_laps(df["t"], x2, y2, C)
    assert laps.complete == 1


def test_less_than_one_rotation() -> None:
    df = circle_drive(rotations=0.7)
    laps = segment_laps(df["t"], df["x"], df["y"], C)
    assert laps.complete == 0
    assert laps.partial == 1
    assert laps.index(df["t"]).max() == 0


def test_standstill_before_the_drive_is_no_rotation() -> None:
    df = circle_drive(rotations=2.2, dt=0.1)
    still = pd.DataFrame({"t": T0 - 10.0 + np.arange(0.0, 10.0, 0.1),
                          "x": df["x"].iloc[0], "y": df["y"].iloc[0], "heading": 0.0})
    both = pd.concat([still, df], ignore_index=True)
    laps = segment_laps(both["t"], both["x"], both["y"], C)
    assert laps.complete == 2
    assert laps.boundaries[0] == pytest.approx(T0)
    assert laps.index([T0 - 5.0])[0] == 0
