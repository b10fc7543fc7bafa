"""What the two particle filters share: the particle set, the prediction, the measurement
geometry per particle, the weighted estimate, and the backend (its one seam,
:mod:`lgvtool.localize.particle_backend`) that does their array operations.

Each particle is a pose of the target rotation centre O (the paper's choice: no eq. 5
conversion of noisy data). Positions are kept as complex numbers ``z = x + iy`` and headings
both as angles ``th`` and as rotors ``rot = exp(i th)``, so that moving a particle or putting a
body-frame point into the world is one complex multiply-add, vectorised over particles and
over the reflectors of a scan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol, TypeVar, Unpack

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.localize.estimator import Estimate, Estimator, EstimatorContext, Motion
from lgvtool.localize.kernel_choice import particle_backend
from lgvtool.localize.observations import PoseObservation, ScanObservation
from lgvtool.localize.params import param
from lgvtool.localize.particle_backend import ParticleBackend, Pose
from lgvtool.localize.pf_likelihood import reference_candidates, world_points
from lgvtool.localize.resampling import uniform_poses

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True)
class ParticleInitParams:
    """How a particle filter starts."""

    init: str = param("uniform", "start: uniform over the work area (global localisation), or "
                      "laser (around the first NAV pose or landmark fix); a caller's initial "
                      "pose always wins", choices=("uniform", "laser"))
    init_sigma_xy_m: float = param(0.1, "position spread of a start around a pose, m",
                                   minimum=0.0)
    init_sigma_heading_rad: float = param(0.05, "heading spread of a start around a pose, rad",
                                          minimum=0.0)


class ParticleParams(Protocol):
    """What :class:`ParticleSet` reads of its parameters (:class:`ParticleInitParams`, the
    motion noise of :class:`lgvtool.localize.noise.MotionParams`)."""

    @property
    def init_sigma_xy_m(self) -> float: ...
    @property
    def init_sigma_heading_rad(self) -> float: ...
    def noise_sigmas(self, dist: float, rot: float) -> tuple[float, float, float]: ...


PP = TypeVar("PP", bound=ParticleParams)


class ParticleSet(Estimator[PP]):
    """Particles (positions ``z`` m, headings ``th`` rad) and their normalised weights ``w``;
    the array operations by :attr:`backend`."""

    kernel_family: ClassVar[str] = "particles"

    def __init__(self, params: PP | None = None, *, backend: ParticleBackend | None = None,
                 **context: Unpack[EstimatorContext]) -> None:
        super().__init__(params, **context)
        #: the array operations (the numpy reference or the compiled kernels), chosen once
        self.backend = backend if backend is not None else particle_backend()
        self.z: ComplexArray = np.zeros(0, dtype=np.complex128)
        self._th: FloatArray | None = np.zeros(0)
        self.rot: ComplexArray = np.zeros(0, dtype=np.complex128)
        self.w: FloatArray = np.zeros(0)
        self.last_ess = 0.0
        #: a pose near the bulk of the particles (the last estimate moved by the odometry)
        self._ref: tuple[float, float, float] | None = None

    @property
    def th(self) -> FloatArray:
        """Particle headings, rad (not wrapped; taken from the rotors ``rot`` when a filter
        keeps only those)."""
        if self._th is None:
            self._th = np.angle(self.rot)
        return self._th

    @th.setter
    def th(self, value: FloatArray) -> None:
        self._th = value

    @property
    def x(self) -> FloatArray:
        """Particle x, m."""
        return self.z.real

    @property
    def y(self) -> FloatArray:
        """Particle y, m."""
        return self.z.imag

    def set_particles(self, x: FloatArray, y: FloatArray, th: FloatArray,
                      w: FloatArray | None = None) -> None:
        """Replace the particle set (poses in m, rad; weights normalised here; None: equal)."""
        self.z = np.asarray(x, dtype=np.float64) + 1j * np.asarray(y, dtype=np.float64)
        self._set_headings(np.asarray(th, dtype=np.float64))
        n = len(self.z)
        self.w = np.full(n, 1.0 / n) if w is None else np.asarray(w) / np.sum(w)

    def _set_headings(self, th: FloatArray) -> None:
        self.th = wrap_angle(th)
        self.rot = np.exp(1j * self.th)

    # ------------------------------------------------------------------ start
    def _start_uniform(self, n: int) -> None:
        self.set_particles(*uniform_poses(self.rng, n, self.area))

    def _start_around(self, pose: tuple[float, float, float], n: int) -> None:
        p = self.params
        g = self.rng.standard_normal((3, n))
        self.set_particles(pose[0] + p.init_sigma_xy_m * g[0], pose[1] + p.init_sigma_xy_m * g[1],
                           pose[2] + p.init_sigma_heading_rad * g[2])

    @property
    def initialized(self) -> bool:
        return len(self.z) > 0

    # ------------------------------------------------------------------ prediction
    def predict(self, motion: Motion) -> None:
        """Eq. 9 for every particle: the odometry motion (with motion noise) composed onto
        each particle's pose."""
        if len(self.z) == 0:
            return
        self._move(motion, self.params.noise_sigmas(motion.dist, motion.rot))

    def _move(self, motion: Motion, sigmas: tuple[float, float, float]) -> None:
        """:meth:`predict` with the motion noise's standard deviations ``sigmas`` (along m,
        across m, heading rad)."""
        self.z, self.th, self.rot = self.backend.predict(self.rng, self.z, self.th, self.rot,
                                                         motion, sigmas)
        self._move_ref(motion)

    def _move_ref(self, motion: Motion) -> None:
        """Move the reference pose by the odometry motion (noise-free)."""
        if self._ref is not None:
            x, y, t = self._ref
            c0, s0 = math.cos(t), math.sin(t)
            self._ref = (x + c0 * motion.dx - s0 * motion.dy, y + s0 * motion.dx + c0 * motion.dy,
                         t + motion.dth)

    # ------------------------------------------------------------------ measurement geometry
    def world_points(self, obs: ScanObservation) -> ComplexArray:
        """The measured reflectors in the world at every particle's pose, (M, K) complex, m."""
        return world_points(self.z, self.rot, obs.q)

    def _reference_nearest(self, obs: ScanObservation) -> NDArray[np.intp]:
        """For each measured point seen from the reference pose, a map reflector likely to be
        the nearest one for the particles: the reflector of the measurement's id when the scan
        gives one, else the nearest to the point at the reference pose. (Only a candidate:
        callers check it.)"""
        return reference_candidates(obs, self.map, self._reference_pose())

    def _nearest_residuals(self, p: ComplexArray, obs: ScanObservation) -> ComplexArray:
        """``L_j - p`` with ``L_j`` the map reflector nearest to each point ``p`` (M, K)."""
        mz = self.map.z
        j1 = self._reference_nearest(obs)
        e = mz[j1] - p
        # a point within half the spacing of j1 to its nearest neighbour has j1 as its nearest
        far = np.abs(e) >= self.map.half_sep[j1]
        if far.any():
            jb, _ = self.map.nearest(p.real[far], p.imag[far])
            e[far] = mz[jb] - p[far]
        return e

    def _reference_pose(self) -> tuple[float, float, float]:
        """A pose near the bulk of the particles: the last estimate, else the heaviest one."""
        if self._ref is not None:
            return self._ref
        i = int(np.argmax(self.w)) if len(self.w) == len(self.z) else 0
        return float(self.z[i].real), float(self.z[i].imag), float(self.th[i])

    def head_residuals(self, obs: PoseObservation) -> tuple[FloatArray, FloatArray, FloatArray]:
        """NAV pose minus each particle's head pose: dx, dy (m) and wrapped dheading (rad)."""
        mount = complex(self.vehicle.nav_x, self.vehicle.nav_y)
        d = complex(obs.x, obs.y) - (self.z + self.rot * mount)
        dh = np.angle(complex(math.cos(obs.heading), math.sin(obs.heading)) * self.rot.conj())
        return d.real, d.imag, dh

    # ------------------------------------------------------------------ estimate
    def weighted_pose(self, w: FloatArray) -> Pose:
        """Weighted mean (eq. 11; the heading as a circular mean, since a plain mean of angles
        breaks at +-pi) and the weighted covariance of ``(x, y, heading)``."""
        return self.backend.weighted_pose(self.z, self.rot, w)

    def cloud(self) -> tuple[FloatArray, FloatArray, FloatArray] | None:
        if len(self.z) == 0:
            return None
        return self.z.real, self.z.imag, self.th

    def _as_estimate(self, pose: tuple[float, float, float, FloatArray]) -> Estimate:
        return Estimate(pose[0], pose[1], pose[2], pose[3], len(self.z), self.last_ess)
