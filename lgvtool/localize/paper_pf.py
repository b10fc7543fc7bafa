"""``pf-paper``: the particle filter of the paper, section 3.2, step by step.

1. Initialisation: ``particles`` (150) poses of O uniform over the work area, uniform heading.
2. Prediction (eq. 9): the encoder + gyro motion composed onto every particle.
3. Correction: each measured reflector is put into the world at the particle's sensor pose
   (the sensor sits at ``(nav_x, nav_y)`` in the vehicle frame) and associated with the
   nearest known reflector; the distances are summed, ``D_m = sum_k |L_j(k) - p_mk|``, and the
   weight is the Gaussian of eq. 10 with mean 0, ``w_m = (2 pi sigma^2)^(-1/2)
   exp(-D_m^2 / (2 sigma^2))``.
4. Estimate (eq. 11): the weighted mean of the particles (the heading as a circular mean, since
   a plain mean of angles breaks at +-pi).
5. Redistribution: ``local_fraction`` (95 %) of the new particles uniformly within
   ``+-spread_m`` (25 cm) and ``+-heading_spread_rad`` around parents drawn from the
   ``top_fraction`` (25 %) of particles by weight; the rest uniform over the work area.

Without reflector scans (a log with the NAV pose only) the same weight is computed from the
distance between each particle's head position and the reported one plus ``pose_heading_m``
times the heading difference, so the filter still runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from lgvtool.localize.estimator import Estimate, Motion, Observation
from lgvtool.localize.fix import pose_fix
from lgvtool.localize.noise import MotionParams
from lgvtool.localize.observations import PoseObservation, SourceParams
from lgvtool.localize.params import param
from lgvtool.localize.particles import ParticleInitParams, ParticleSet
from lgvtool.localize.resampling import RedistributionPlan, effective_sample_size

#: heading spread of the redistribution, rad. The paper gives none. A heading offset moves a
#: reflector at range r by r times the offset; this spread moves a reflector 25 m away (across
#: the paper's 25 m x 20 m hall) by at most the paper's position spread of 25 cm, so position
#: and heading spread disturb the measured reflectors alike.
DEFAULT_HEADING_SPREAD = 0.25 / 25.0


@dataclass(frozen=True)
class PaperPfParams(MotionParams, SourceParams, ParticleInitParams):
    """Parameters of the paper's filter; defaults are the paper's values where it gives one."""

    particles: int = param(150, "number of particles (paper: 150)", minimum=1)
    sigma_m: float = param(1.0, "standard deviation of the eq. 10 Gaussian on the summed "
                           "association distance, m (paper: standard normal, sigma = 1)",
                           minimum=1e-9)
    top_fraction: float = param(0.25, "fraction of particles, by weight, that parent the "
                                "redistribution (paper: top 25 %)", minimum=0.0, maximum=1.0)
    local_fraction: float = param(0.95, "fraction of particles redistributed around the "
                                  "parents; the rest go uniform over the work area (paper: "
                                  "95 %)", minimum=0.0, maximum=1.0)
    spread_m: float = param(0.25, "half width of the uniform redistribution in x and y, m "
                            "(paper: +-25 cm)", minimum=0.0)
    heading_spread_rad: float = param(DEFAULT_HEADING_SPREAD, "half width of the uniform "
                                      "redistribution in heading, rad (not in the paper: "
                                      "moves a reflector 25 m away by 25 cm)",
                                      minimum=0.0)
    pose_heading_m: float = param(1.0, "pose-only weight: metres of distance per radian of "
                                  "heading difference, m/rad", minimum=0.0)
    noise_dist: float = param(0.0, "along-track motion noise per metre, m/m (the paper adds "
                              "none: redistribution spreads the particles)", minimum=0.0)
    noise_lat: float = param(0.0, "across-track motion noise per metre, m/m", minimum=0.0)
    noise_rot: float = param(0.0, "heading noise per radian turned, rad/rad", minimum=0.0)
    noise_rot_per_m: float = param(0.0, "heading noise per metre travelled, rad/m",
                                   minimum=0.0)
    use_ids: bool = param(False, "use reflector ids for association (the paper associates "
                          "with the nearest known reflector)")
    deskew: bool = param(False, "de-skew reflectors by their time in the revolution (not in "
                         "the paper)")
    scans: str = param("nav-poll", "which revolutions weigh the particles: nav-poll (the "
                       "paper: when the NAV is polled, every 450 ms, the last revolution "
                       "completed before the poll) or all", choices=("nav-poll", "all"))


class PaperParticleFilter(ParticleSet):
    """The paper's particle filter (section 3.2), every constant a parameter."""

    name = "pf-paper"
    Params = PaperPfParams
    summary = "the paper's particle filter: 150 particles, eq. 9-11, 95/25 redistribution"

    def __init__(self, *args: object, **kwargs: object) -> None:
        super().__init__(*args, **kwargs)
        self._mean: tuple[float, float, float, np.ndarray] | None = None
        self._plan: RedistributionPlan | None = None
        n = self.params.particles
        self._uniform_w = np.full(n, 1.0 / n)
        if self.initial_pose is not None:
            self._start_around(self.initial_pose, self.params.particles)
        elif self.params.init == "uniform":
            self._start_uniform(self.params.particles)

    def predict(self, motion: Motion) -> None:
        super().predict(motion)
        if self._mean is not None:
            x, y, th, cov = self._mean
            c, s = math.cos(th), math.sin(th)
            self._mean = (x + c * motion.dx - s * motion.dy, y + s * motion.dx + c * motion.dy,
                          math.remainder(th + motion.dth, 2.0 * math.pi), cov)

    def distances(self, obs: Observation) -> np.ndarray:
        """The summed association distance ``D_m`` of every particle, m."""
        if isinstance(obs, PoseObservation):
            dx, dy, dh = self.head_residuals(obs)
            return np.sqrt(dx * dx + dy * dy) + self.params.pose_heading_m * np.abs(dh)
        if self.params.use_ids:
            return np.abs(self.scan_residuals(obs, True)).sum(axis=1)
        tail = 0 if self._plan is None else self._plan.m - self._plan.n_local
        d = self.nearest_distances(obs, brute_tail=tail)
        return d @ np.ones(d.shape[1])

    def update(self, obs: Observation) -> bool:
        p = self.params
        if not self.initialized:
            pose = pose_fix(obs, self.vehicle.nav_x, self.vehicle.nav_y, self.map,
                            use_ids=p.use_ids)
            if pose is None:
                return False
            self._start_around(pose, p.particles)
            return True
        if not isinstance(obs, PoseObservation) and (len(obs) == 0 or len(self.map) == 0):
            return False
        d = self.distances(obs)
        sigma = p.sigma_m
        w = np.exp(d * d * (-0.5 / (sigma * sigma)))
        w *= 1.0 / math.sqrt(2.0 * math.pi * sigma * sigma)
        total = float(w.sum())
        if total > 0.0 and math.isfinite(total):
            w /= total
        else:
            # every weight underflowed: the limit of eq. 11 is the particle(s) with least D
            w = (d == d.min()).astype(np.float64)
            w /= w.sum()
        self.w = w
        self.last_ess = effective_sample_size(w)
        self._mean = self.weighted_pose(w)
        self._ref = self._mean[:3]
        if self._plan is None or self._plan.m != len(self.z):
            self._plan = RedistributionPlan(
                len(self.z), self.area, top_fraction=p.top_fraction,
                local_fraction=p.local_fraction, spread_m=p.spread_m,
                heading_spread_rad=p.heading_spread_rad)
        self.z, self.th = self._plan.apply(self.z, self.th, w, self.rng)
        self.rot = np.exp(1j * self.th)
        self.w = self._uniform_w
        return True

    def estimate(self) -> Estimate | None:
        if self._mean is None:
            return None
        return self._as_estimate(self._mean)
