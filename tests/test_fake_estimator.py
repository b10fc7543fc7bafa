"""An estimator is its class and its parameter declarations: a fake one, registered by one line
(:func:`lgvtool.localize.registry.register`), is listed by ``lgvtool config --parameters``, its
parameters are checked by ``--set`` like any other's, and ``replay`` runs it."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Unpack

import pytest
from inprocess import run_command

from lgvtool.localize.estimator import (
    Estimate,
    Estimator,
    EstimatorContext,
    Motion,
    Observation,
)
from lgvtool.localize.geometry import nav_to_o
from lgvtool.localize.observations import PoseObservation
from lgvtool.localize.params import param
from lgvtool.localize.registry import ESTIMATORS, register, unregister

SAMPLE = Path(__file__).resolve().parents[1] / "sample_logs" / "paper-circle.mcap"


@dataclass(frozen=True)
class FakeParams:
    """The fake estimator's one parameter."""

    lag: float = param(0.5, "how far it lags behind the NAV pose, as a fraction of the step",
                       minimum=0.0, maximum=1.0)


class Lagging(Estimator[FakeParams]):
    """Moves a fraction ``1 - lag`` of the way to each NAV pose converted to O."""

    name = "lagging"
    Params = FakeParams
    summary = "a test-only estimator"
    uses_scans = False
    uses_motion = False  # one that uses motion declares MotionParams (its motion noise)

    def __init__(self, params: FakeParams | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, **context)
        self._est: Estimate | None = None

    @property
    def initialized(self) -> bool:
        return self._est is not None

    def predict(self, motion: Motion) -> None:
        """Ignores the motion."""

    def update(self, obs: Observation) -> bool:
        if not isinstance(obs, PoseObservation):
            return False
        xo, yo, _ = nav_to_o(obs.x, obs.y, obs.heading, self.vehicle.nav_x,
                             self.vehicle.nav_y)  # the head's pose, moved to O
        x, y = float(xo), float(yo)
        if self._est is None:
            self._est = Estimate(x, y, obs.heading)
            return True
        k = 1.0 - self.params.lag
        e = self._est
        self._est = Estimate(e.x + k * (x - e.x), e.y + k * (y - e.y),
                             e.heading + k * (obs.heading - e.heading))
        return True

    def estimate(self) -> Estimate | None:
        return self._est


@pytest.fixture
def lagging() -> Iterator[None]:
    register("lagging", __name__, "Lagging")
    try:
        yield
    finally:
        unregister("lagging")
    assert "lagging" not in ESTIMATORS


def test_a_registered_estimator_is_known_everywhere(lagging: None, tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run_command(capsys, "config", "--parameters", "--json")
    assert code == 0
    listed = json.loads(out)["estimators.lagging"]
    assert [d["key"] for d in listed] == ["lag"] and listed[0]["range"] == "[0, 1]"
    code, _, err = run_command(capsys, "replay", SAMPLE, "-e", "lagging", "--set",
                               "lagging.lag=2", "-o", tmp_path / "bad.mcap")
    assert code == 2 and "lagging.lag must be at most 1, got 2" in err
    assert not (tmp_path / "bad.mcap").exists()
    code, _, err = run_command(capsys, "replay", SAMPLE, "-e", "laser,lagging", "--set",
                               "lagging.lag=0", "-o", tmp_path / "r.mcap", "--no-view")
    assert code == 0, err
    code, out, err = run_command(capsys, "evaluate", tmp_path / "r.mcap", "--json", "-o",
                                 tmp_path / "ev")
    assert code == 0, err
    figures = json.loads(out)["estimators"]
    # with no lag it is the laser's pose: the same truth error, to rounding
    assert figures["lagging"]["truth"]["position_rmse_m"] == pytest.approx(
        figures["laser"]["truth"]["position_rmse_m"], rel=1e-9)


def test_its_parameters_are_typed_and_checked() -> None:
    """One typed way to make an estimator's parameters from overrides: its class's
    ``configure``, every value checked by its declaration."""
    from lgvtool.errors import ConfigError

    assert Lagging.configure(lag=0.25) == FakeParams(lag=0.25)
    assert Lagging().params == FakeParams()
    assert Lagging(Lagging.configure(lag=0.0)).params.lag == 0.0
    with pytest.raises(ConfigError, match=r"lagging\.lag"):
        Lagging.configure(lag=2.0)
    with pytest.raises(ConfigError, match=r"lagging\.lagg"):
        Lagging.configure(lagg=0.1)


def test_registering_a_known_name_is_refused(lagging: None) -> None:
    with pytest.raises(ValueError, match="already registered"):
        register("pf", __name__, "Lagging")
