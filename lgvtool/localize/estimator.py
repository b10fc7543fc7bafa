"""The one small interface every estimator implements.

An estimator is pure: it never reads a file or a clock. The caller feeds it, in time order,
the body-frame motion since the previous call (:meth:`Estimator.predict`) and observations
(:meth:`Estimator.update`), and reads :meth:`Estimator.estimate`. Poses are of the target
rotation centre O in the map frame (m, rad); covariances are of ``(x, y, heading)``.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Generic, TypedDict, TypeVar

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Area, Reflector, Vehicle
from lgvtool.declared import JSONScalar
from lgvtool.localize.observations import PoseObservation, ReflectorMap, ScanObservation
from lgvtool.localize.params import make_params, params_dict
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.localize.motion import Deltas

Observation = PoseObservation | ScanObservation
#: an estimator's parameter group (a frozen dataclass of declared settings); covariant, since an
#: estimator's parameters are set once, when it is made, and only read after: an
#: ``Estimator[PfParams]`` is an ``Estimator[object]`` (an estimator of any parameters)
P = TypeVar("P", covariant=True)
FloatArray = NDArray[np.float64]
#: a kept particle cloud: time (s), particle x (m), y (m) and heading (rad)
Cloud = tuple[float, FloatArray, FloatArray, FloatArray]


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


@dataclass(frozen=True)
class EstimateRows:
    """What :meth:`Estimator.run` returns: ``poses``, one row per observation time at which
    the estimator had a pose (a :class:`lgvtool.trajectory.Trajectory`: ``t`` in s on the
    caller's clock, pose of O in m, m, rad with the heading not wrapped, and per row the
    row-major 3x3 covariance, particle count and ESS), and the kept particle ``clouds``."""

    poses: Trajectory
    clouds: list[Cloud]


class EstimatorContext(TypedDict, total=False):
    """The keyword arguments of :class:`Estimator` besides its parameters (what a subclass
    passes on with ``**context: Unpack[EstimatorContext]``)."""

    vehicle: Vehicle | None
    reflectors: tuple[Reflector, ...] | list[Reflector]
    area: Area | None
    rng: np.random.Generator | None
    initial_pose: tuple[float, float, float] | None


_SAMPLES: dict[tuple[int, int], NDArray[np.intp]] = {}


def cloud_sample(k: int, size: int) -> NDArray[np.intp]:
    """Indices of at most ``size`` of ``k`` particles, evenly strided through the set (do not
    modify: shared between calls)."""
    sel = _SAMPLES.get((k, size))
    if sel is None:
        sel = _SAMPLES[(k, size)] = np.linspace(0, k - 1, min(k, size)).astype(np.intp)
        sel.setflags(write=False)
    return sel


class Estimator(ABC, Generic[P]):
    """Base of the estimators: parameters (``P``, the class's :attr:`Params`), vehicle
    geometry, reflector map, work area, RNG."""

    #: registry name, e.g. ``"pf"``
    name: ClassVar[str] = ""
    #: the parameter dataclass of this estimator (``P``)
    Params: ClassVar[type[Any]]
    #: one-line description
    summary: ClassVar[str] = ""
    #: True if the estimator consumes motion, scans, NAV poses
    uses_motion: ClassVar[bool] = True
    uses_scans: ClassVar[bool] = True
    uses_poses: ClassVar[bool] = True
    #: the family of compiled kernels the estimator may run, made ready before estimators run
    #: side by side (:func:`lgvtool.localize.kernel_choice.ready`; "" for none)
    kernel_family: ClassVar[str] = ""

    params: P

    def __init__(self, params: P | None = None, *, vehicle: Vehicle | None = None,
                 reflectors: tuple[Reflector, ...] | list[Reflector] = (),
                 area: Area | None = None, rng: np.random.Generator | None = None,
                 initial_pose: tuple[float, float, float] | None = None) -> None:
        self.params = params if params is not None else self.configure()
        self.vehicle = vehicle or Vehicle()
        self.map = ReflectorMap(reflectors)
        self.area = area or Area()
        self.rng = rng if rng is not None else np.random.default_rng(0)
        self.initial_pose = initial_pose
        #: what the estimator did that its rows alone do not tell, in time order: (time s,
        #: kind, text), e.g. ``restarted`` (``ekf`` found a lost vehicle again) or
        #: ``reanchored`` (the robust gate on NAV poses); ``replay`` writes each as an event
        self.events: list[tuple[float, str, str]] = []

    @classmethod
    def configure(cls, **values: object) -> P:
        """The parameters with ``values`` (``{param: value}``) over the defaults, each checked
        (:func:`lgvtool.localize.params.make_params`): ``Ekf.configure(sigma_range_m=0.03)``.

        :raises lgvtool.errors.ConfigError: an unknown parameter or a bad value, named
            ``<estimator>.<param>``.
        """
        made: P = make_params(cls.Params, cls.name, values)
        return made

    @property
    def settings(self) -> dict[str, JSONScalar]:
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

    def run(self, times: FloatArray, observations: Sequence[Observation | None],
            steps: Deltas | None, *, progress: Callable[[int], None] | None = None,
            cloud_period_s: float = 2.0, cloud_size: int = 50) -> EstimateRows:
        """Process observations in time order and record the estimate after each.

        ``times[i]`` (s) is the time of ``observations[i]``; None there means "only move the
        estimator to this time". ``steps`` holds the body-frame motion from each time to the
        next (``len(times) - 1`` entries; None: no motion). One particle cloud of at most
        ``cloud_size`` particles is kept per ``cloud_period_s`` s. ``progress`` is called with
        the number of observations processed since its last call.
        """
        return step_loop(self, times, observations, steps, progress=progress,
                         cloud_period_s=cloud_period_s, cloud_size=cloud_size)

    def step(self, i: int, o: Observation | None, moves: Moves | None,
             rec: RowRecorder) -> None:
        """One step of :meth:`run`: the motion to observation ``i`` (from ``moves``, none for
        the first), the update with ``o`` (None: none) and the estimate recorded in ``rec``."""
        if i > 0 and moves is not None:
            self.predict(Motion(*moves[i - 1]))
        if o is not None:
            self.update(o)
        e = self.estimate()
        if e is not None:
            rec.add(i, e)
            rec.maybe_cloud(i, self)


def step_loop(est: Estimator[object], times: FloatArray,
              observations: Sequence[Observation | None], steps: Deltas | None, *,
              progress: Callable[[int], None] | None = None, cloud_period_s: float = 2.0,
              cloud_size: int = 50) -> EstimateRows:
    """:meth:`Estimator.run` as ``predict``, ``update`` and ``estimate`` in turn
    (:meth:`Estimator.step`) at every observation: the reference every faster loop equals."""
    n = len(observations)
    moves = Moves(steps) if steps is not None and est.uses_motion and n > 1 else None
    rec = RowRecorder(times, cloud_period_s, cloud_size)
    report = Reporter(progress)
    for i, o in enumerate(observations):
        est.step(i, o, moves, rec)
        report.at(i)
    report.at(n, last=True)
    return rec.rows()


class Reporter:
    """Hands ``progress`` the observations done since its last call, at least every
    :attr:`EVERY` of them (None: nothing is reported)."""

    EVERY = 500

    def __init__(self, progress: Callable[[int], None] | None) -> None:
        self._progress = progress
        self._done = 0

    def at(self, i: int, *, last: bool = False) -> None:
        """``i`` observations are done (``last``: all of them; reported whatever the count)."""
        if self._progress is not None and (last or i - self._done >= self.EVERY):
            self._progress(i - self._done)
            self._done = i


class RowRecorder:
    """The rows of :meth:`Estimator.run` as they are made: one per observation time with an
    estimate (at most ``len(times)``), filled in place (no Python object per row), and one
    particle cloud of at most ``cloud_size`` particles per ``cloud_period_s`` s. The compiled
    loops write the row arrays themselves from row :attr:`k` on."""

    def __init__(self, times: FloatArray, cloud_period_s: float, cloud_size: int) -> None:
        n = len(times)
        f64 = np.float64
        #: the observation times, s
        self.times = np.ascontiguousarray(times, dtype=f64)
        self._tl: list[float] = self.times.tolist()
        self.t, self.x, self.y, self.heading = (np.empty(n, dtype=f64) for _ in range(4))
        self.covariance = np.empty((n, 9), dtype=f64)
        self.particles = np.empty(n, dtype=np.int64)
        self.ess = np.empty(n, dtype=f64)
        #: rows filled so far
        self.k = 0
        self.clouds: list[Cloud] = []
        self.cloud_period_s = cloud_period_s
        self.cloud_size = cloud_size
        #: the time (s) from which the next cloud is kept (infinite: none is)
        self.next_cloud = -math.inf if cloud_size > 0 else math.inf

    def add(self, i: int, e: Estimate) -> None:
        """The row of estimate ``e`` at observation ``i``."""
        k = self.k
        self.t[k], self.x[k], self.y[k], self.heading[k] = self._tl[i], e.x, e.y, e.heading
        self.covariance[k] = np.asarray(e.covariance, dtype=np.float64).reshape(9)
        self.particles[k] = e.particles
        self.ess[k] = e.ess
        self.k = k + 1

    def maybe_cloud(self, i: int, est: Estimator[object]) -> None:
        """Keep ``est``'s particle cloud at observation ``i`` if one is due."""
        t = self._tl[i]
        if t >= self.next_cloud:
            c = est.cloud()
            if c is not None:
                sel = cloud_sample(len(c[0]), self.cloud_size)
                self.clouds.append((t, c[0][sel], c[1][sel], c[2][sel]))
                self.next_cloud = t + self.cloud_period_s

    def rows(self) -> EstimateRows:
        """The rows filled (from the first estimate on: trimmed copies, the rest freed)."""
        k = self.k
        if k == len(self.t):
            poses = Trajectory(self.t, self.x, self.y, self.heading, covariance=self.covariance,
                               particles=self.particles, ess=self.ess)
        else:
            poses = Trajectory(self.t[:k].copy(), self.x[:k].copy(), self.y[:k].copy(),
                               self.heading[:k].copy(), covariance=self.covariance[:k].copy(),
                               particles=self.particles[:k].copy(), ess=self.ess[:k].copy())
        return EstimateRows(poses, self.clouds)


class Moves:
    """The motions between consecutive observation times as tuples ``(dx, dy, dth, dist,
    rot)``, made from the arrays of a :class:`Deltas` a block at a time (instead of one list of
    tuples for the whole log)."""

    BLOCK = 4096

    def __init__(self, steps: Deltas) -> None:
        self._arrays = (steps.dx, steps.dy, steps.dth, steps.dist, steps.rot)
        self._start = -1
        self._block: list[tuple[float, float, float, float, float]] = []

    def __getitem__(self, i: int) -> tuple[float, float, float, float, float]:
        b = i - i % self.BLOCK
        if b != self._start:
            self._block = list(zip(*(a[b:b + self.BLOCK].tolist() for a in self._arrays),
                                   strict=True))
            self._start = b
        return self._block[i - b]
