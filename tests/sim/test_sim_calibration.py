"""The simulated NAV200 is as noisy as the paper's laser navigation (Table 1's laser columns)."""

from __future__ import annotations

import pytest

from lgvtool.sim.calibration import laser_evaluation
from lgvtool.sim.simulation import simulate


@pytest.mark.parametrize("seed", [5, 6])
def test_the_laser_per_rotation_figures_are_those_of_table_1(seed: int) -> None:
    laser = laser_evaluation(simulate("paper-circle", seed=seed))
    assert len(laser.rotations) == 8
    avg = laser.average
    assert avg is not None
    # the paper: 56.9 mm and 473 mm^2 on average; within +-10 % and +-25 %
    assert 0.051 <= avg.rmse <= 0.063
    assert 355e-6 <= avg.variance <= 590e-6
    for rotation in laser.rotations:
        assert 250e-6 <= rotation.stats.variance <= 800e-6
    # mostly bias: the mean error carries most of the mean square
    assert avg.mean ** 2 > 2 * avg.variance


def test_without_the_calibrated_mechanisms_the_laser_is_far_quieter() -> None:
    quiet = {"nav.max_reflectors": 0, "nav.detection_probability": 1.0}
    laser = laser_evaluation(simulate("paper-circle", seed=5, overrides=quiet))
    assert laser.average is not None and laser.average.variance < 250e-6
