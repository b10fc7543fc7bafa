"""The one small interface every estimator implements.

An estimator is pure: it never reads a file or a clock. The caller feeds it, in time order,
the body-frame motion since the previous call (:meth:`Estimator.predict`) and observations
(:meth:`Estimator.update`), and reads :meth:`Estimator.estimate`. Poses are of the target
rotation centre O in the map frame (m, rad); covariances are of ``(x, y, heading)``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Area, Reflector, Vehicle
from lgvtool.localize.observations import PoseObservation, ReflectorMap, ScanObservation
from lgvtool.localize.params import make_params, params_dict

Observation = PoseObservation | ScanObservation


@dataclass(frozen=True, slots=True)
class Motion:
    """Motion of the vehicle in the body frame of its earlier pose.

    ``dx`` forward and ``dy`` left (m), ``dth`` heading change (rad); ``dist`` path length (m)
    and ``rot`` total absolute rotation (rad), which scale the motion noise.
    """

    dx: float
    dy: float
    dth: float
    dist: float = -1.0
    rot: float = -1.0

    def __post_init__(self) -> None:
        if self.dist < 0.0:
            object.__setattr__(self, "dist", math.hypot(self.dx, self.dy))
        if self.rot < 0.0:
            object.__setattr__(self, "rot", abs(self.dth))


@dataclass(frozen=True)
class Estimate:
    """Pose of O (m, m, rad) with its 3x3 covariance (m^2, m rad, rad^2).

    ``particles``: particle count (0 for other estimators); ``ess``: effective sample size of
    the last update before resampling (0 if not applicable).
    """

    x: float
    y: float
    heading: float
    covariance: NDArray[np.float64] = field(default_factory=lambda: np.zeros((3, 3)))
    particles: int = 0
    ess: float = 0.0


class Estimator(ABC):
    """Base of the estimators: parameters, vehicle geometry, reflector map, work area, RNG."""

    #: registry name, e.g. ``"pf"``
    name: ClassVar[str] = ""
    #: the parameter dataclass of this estimator
    Params: ClassVar[type]
    #: one-line description
    summary: ClassVar[str] = ""
    #: True if the estimator consumes motion, scans, NAV poses
    uses_motion: ClassVar[bool] = True
    uses_scans: ClassVar[bool] = True
    uses_poses: ClassVar[bool] = True

    def __init__(self, params: Any = None, *, vehicle: Vehicle | None = None,
                 reflectors: tuple[Reflector, ...] | list[Reflector] = (),
                 area: Area | None = None, rng: np.random.Generator | None = None,
                 initial_pose: tuple[float, float, float] | None = None,
                 **overrides: Any) -> None:
        if params is None or isinstance(params, dict):
            merged = dict(params or {})
            merged.update(overrides)
            params = make_params(self.Params, self.name, merged)
        elif overrides:
            params = make_params(self.Params, self.name, overrides, base=params)
        self.params = params
        self.vehicle = vehicle or Vehicle()
        self.map = ReflectorMap(reflectors)
        self.area = area or Area()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.initial_pose = initial_pose

    @property
    def settings(self) -> dict[str, Any]:
        """The effective parameters as a JSON-able dict."""
        return params_dict(self.params)

    @property
    @abstractmethod
    def initialized(self) -> bool:
        """True once the estimator has a pose to report."""

    @abstractmethod
    def predict(self, motion: Motion) -> None:
        """Move the belief by the body-frame ``motion``."""

    @abstractmethod
    def update(self, obs: Observation) -> bool:
        """Correct the belief with ``obs``; returns True if the observation was used."""

    @abstractmethod
    def estimate(self) -> Estimate | None:
        """The current pose estimate, or None before initialisation."""

    def cloud(self) -> tuple[NDArray[np.float64], NDArray[np.float64],
                             NDArray[np.float64]] | None:
        """The particles ``(x, y, heading)`` for particle filters, else None."""
        return None
