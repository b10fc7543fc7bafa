"""``pf``'s reflector likelihood as pure functions of the particles (the numpy reference of
the particle backends, :mod:`lgvtool.localize.particle_backend`).

Each reflector of a scan is an independent measurement: the residual ``L_j - p_mk`` from the
point measured at particle ``m`` to its layout reflector ``j``, split along the measured ray
(the range noise) and across it (the range times the bearing noise), weighed by a 2-D
Gaussian, mixed with a uniform outlier density, and summed over the reflectors as logarithms.
Association (:mod:`lgvtool.localize.association`, per particle): a reflector's id when its
layout reflector lies inside the gate, else the nearest layout reflector inside it, none (the
outlier density) when the gate holds nothing or two alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.association import safe_radius
from lgvtool.localize.observations import ReflectorMap, ScanObservation

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
_LOG_2PI = math.log(2.0 * math.pi)


@dataclass(frozen=True)
class ScanModel:
    """The constants of ``pf``'s reflector likelihood: the noise along a ray (``sigma_range_m``
    plus ``sigma_range_per_m`` times the range, in quadrature, m) and across it (the range
    times ``sigma_bearing_rad``), whether ids associate (``use_ids``), the outlier mixture
    (``outlier``; ``log_inlier`` = log(1 - eps), ``log_outlier`` = log(eps) + the log outlier
    density per m^2), the association gate in standard deviations (``gate_root``), the
    ambiguity ratio and the log weight of a reflector associated against its id
    (``log_mismatch``)."""

    sigma_range_m: float
    sigma_range_per_m: float
    sigma_bearing_rad: float
    use_ids: bool
    outlier: bool
    log_inlier: float
    log_outlier: float
    gate_root: float
    ambiguity_ratio: float
    log_mismatch: float

    def ray_sigmas(self, ranges: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Noise standard deviations (m) of reflectors at ``ranges`` (m) along their ray and
        across it."""
        if self.sigma_range_per_m > 0.0:
            sr = np.sqrt(self.sigma_range_m ** 2 + (self.sigma_range_per_m * ranges) ** 2)
        else:
            sr = np.full(len(ranges), self.sigma_range_m)
        return sr, np.sqrt((ranges * self.sigma_bearing_rad) ** 2 + 1e-12)

    def gate_radii(self, ranges: FloatArray) -> FloatArray:
        """The association gate of reflectors at ``ranges`` (m), m: :attr:`gate_root` times the
        larger of their noise along and across the ray."""
        sr, st = self.ray_sigmas(ranges)
        out: FloatArray = self.gate_root * np.maximum(sr, st)
        return out


def world_points(z: ComplexArray, rot: ComplexArray, q: ComplexArray) -> ComplexArray:
    """The body-frame points ``q`` (complex, m) in the world at every particle's pose
    (positions ``z``, heading rotors ``rot``): (M, K) complex, m."""
    return z[:, None] + np.multiply.outer(rot, q)


def reference_candidates(obs: ScanObservation, rmap: ReflectorMap,
                         ref: tuple[float, float, float]) -> NDArray[np.intp]:
    """For each measured point, a map reflector likely to be the nearest one for the particles:
    the reflector of its id when the scan gives one in the map, else the nearest to the point
    seen from the reference pose ``ref`` (x, y m, heading rad). (Only a candidate: callers
    check it.)"""
    j = obs.map_index(rmap)
    if (j >= 0).all():
        return j
    pr = complex(ref[0], ref[1]) + complex(math.cos(ref[2]), math.sin(ref[2])) * obs.q
    near = np.argmin(np.abs(rmap.z[None, :] - pr[:, None]), axis=1)
    return np.where(j >= 0, j, near)


def associate(z: ComplexArray, rot: ComplexArray, obs: ScanObservation, rmap: ReflectorMap,
              cand: NDArray[np.intp], model: ScanModel
              ) -> tuple[ComplexArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Every particle's association of the reflectors of ``obs``: the residual ``L_j - p_mk``
    (M, K complex, m) from each measured point to its layout reflector (the nearest when it has
    none), whether the point has none (nothing inside the gate, or two alike: ambiguous) and
    whether a point with an id went to another reflector than the id's.

    A point with an id (``model.use_ids``) takes the id's reflector when nearer than its gate
    radius; a point without one takes its candidate ``cand`` (:func:`reference_candidates`)
    when nearer than the radius within which the candidate is provably the nearest, inside the
    gate and unambiguous (:func:`lgvtool.localize.association.safe_radius`); the rest search
    the whole layout.
    """
    pts = world_points(z, rot, obs.q)
    jid = obs.map_index(rmap) if model.use_ids else np.full(len(obs), -1, dtype=np.int64)
    g = model.gate_radii(obs.ranges)
    idpt = jid >= 0
    half = np.where(idpt, g, safe_radius(rmap.half_sep[cand], g, model.ambiguity_ratio))
    e = rmap.z[cand] - pts
    d2 = e.real * e.real + e.imag * e.imag
    slow = d2 - half * half >= 0.0
    drop = np.zeros(e.shape, dtype=bool)
    mismatch = np.zeros(e.shape, dtype=bool)
    if slow.any():
        ps = pts[slow]
        b1, d1, d2nd = rmap.nearest_two(ps.real, ps.imag)
        g2 = np.broadcast_to(g * g, e.shape)[slow]
        ratio2 = model.ambiguity_ratio * model.ambiguity_ratio
        dropped = ~(d1 < g2) | ((d2nd < g2) & (d2nd < ratio2 * d1))
        e[slow] = rmap.z[b1] - ps
        drop[slow] = dropped
        jrow = np.broadcast_to(jid, e.shape)[slow]
        mismatch[slow] = (jrow >= 0) & (b1 != jrow) & ~dropped
    return e, drop, mismatch


def mixed(loglik: FloatArray, outlier: bool, log_inlier: float, log_outlier: float
          ) -> FloatArray:
    """The outlier mixture ``log((1 - eps) exp(loglik) + eps U)`` of per-measurement
    log-likelihoods (``log_inlier`` = log(1 - eps), ``log_outlier`` = log(eps U)); ``loglik``
    itself without the mixture (``outlier`` false)."""
    if not outlier:
        return loglik
    return np.logaddexp(log_inlier + loglik, log_outlier)


def scan_loglik(z: ComplexArray, rot: ComplexArray, obs: ScanObservation, rmap: ReflectorMap,
                ref: tuple[float, float, float], model: ScanModel) -> FloatArray:
    """The log-likelihood of each particle (positions ``z``, rotors ``rot``) for the scan
    ``obs``, associated by :func:`associate` (candidates seen from ``ref``): the sum over its
    reflectors."""
    sr, st = model.ray_sigmas(obs.ranges)
    const = _LOG_2PI + np.log(sr) + np.log(st)
    e, drop, mismatch = associate(z, rot, obs, rmap, reference_candidates(obs, rmap, ref),
                                  model)
    # the residual along (er) and across (et) each reflector's ray
    ray = e * np.multiply.outer(rot.conj(), obs.u.conj())
    er, et = ray.real, ray.imag
    ll = -0.5 * ((er / sr) ** 2 + (et / st) ** 2) - const
    if drop.any():
        # no reflector: the outlier density (the mixture of -inf is exactly that)
        ll[drop] = -math.inf if model.outlier else model.log_outlier
    ll = mixed(ll, model.outlier, model.log_inlier, model.log_outlier)
    if mismatch.any():
        ll[mismatch] += model.log_mismatch
    summed: FloatArray = ll.sum(axis=1)
    return summed
