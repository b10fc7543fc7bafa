"""The simulated laser navigation scored as the paper's Table 1, straight from a simulation.

:func:`laser_evaluation` takes the NAV200 poses the host received in a simulated run (the
newest valid solution at each poll), converts them to the point O with the paper's eq. 5
(corrected) and scores them against the circle drive exactly as ``lgvtool evaluate`` scores its
``laser`` estimator: a centre fitted on the kinematic radius, rotations from the truth, signed
radial errors, per-rotation RMSE and variance. No log is written, so checking the calibration
of the simulator against Table 1 (``docs/simulator.md``) takes a fraction of a second per run.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from lgvtool.evaluate.evaluation import EstimatorEvaluation
    from lgvtool.sim.simulation import Simulation


def laser_evaluation(sim: Simulation) -> EstimatorEvaluation:
    """The ``laser`` row of Table 1 for a simulated circle run (figures in m and m^2).

    Raises :class:`~lgvtool.errors.InputError` when the run is not a circle drive with
    complete rotations.
    """
    from lgvtool.errors import InputError
    from lgvtool.evaluate.evaluation import BASELINE, evaluate_trajectories
    from lgvtool.trajectory import Trajectory

    ref = sim.plan.reference
    if "steering_angle" not in ref:
        raise InputError(f"scenario '{sim.setup.scenario.name}' is not a circle drive")
    sol, traffic = sim.solutions, sim.nav_traffic
    answered = traffic.solution >= 0
    index = traffic.solution[answered]
    valid = sol.valid[index]
    index = index[valid]
    t = traffic.poll_times[answered][valid]
    v = sim.config.vehicle
    hx, hy, th = sol.x[index], sol.y[index], sol.heading[index]
    laser = Trajectory.cleaned(t, hx - v.nav_x * np.cos(th) + v.nav_y * np.sin(th),
                               hy - v.nav_x * np.sin(th) - v.nav_y * np.cos(th), th,
                               sim.start_ns)
    step = 1.0 / sim.settings.sim.truth_rate_hz
    truth = sim.truth.sampled(np.arange(0.0, sim.truth.duration, step))
    res = evaluate_trajectories({BASELINE: laser}, truth=truth,
                                steering_angle=float(ref["steering_angle"]), h=v.h,
                                name=f"{sim.setup.scenario.name} seed {sim.seed}")
    out = res.estimators.get(BASELINE)
    if out is None or out.average is None or not out.rotations:
        raise InputError("the simulated run has no complete rotation to score")
    return out
