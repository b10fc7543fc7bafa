"""The measurement-informed (EKF) proposal of ``pf``: each particle's local Gaussian updated by a
camera or laser frame's landmark measurements, vectorised over particles.

Between frames a particle is moved by the noise-free odometry (its own odometry scales) and
carries the motion noise accumulated since the last frame as a covariance ``P`` (3 x 3, in
``x`` m, ``y`` m, heading rad): for one motion step, whose noise is Gaussian in the body frame
of the earlier pose, that Gaussian is the exact motion model; over several steps it is
linearised in the heading. At a frame each particle's Gaussian ``N(m, P)`` is updated by the
frame's landmarks with one Kalman step linearised at ``m`` (the extended particle filter of
van der Merwe et al. 2000, FastSLAM 2.0's proposal), the particle is drawn from that
posterior ``q = N(m + d, P')`` and weighted by prior x likelihood / proposal.

The measurement is the pf's own: the landmark's residual ``r`` in the frame of the measured
ray (along it: the range, across it: the range times the bearing), with independent Gaussian
noise ``sr`` along and ``st`` across (standard deviations, m). For landmark ``L`` measured at
body-frame point ``q`` along the unit ray ``u``, seen from pose ``(z, th)`` (complex position,
heading), ``r = conj(u) (exp(-i th) (L - z) - q)``.

With ``A = sum J^T R^-1 J`` and ``b = sum J^T R^-1 r`` over the landmarks used, the posterior is
``P' = P (I + A P)^-1``, ``d = -P' b`` (valid for a singular ``P``: no inverse of ``P`` is
taken), and the linearised model's evidence is ``N(r; 0, S)``, ``S = R + J P J^T``, with
``r^T S^-1 r = r^T R^-1 r - b^T P' b`` and ``det S = det R det(I + A P)``. Since
``p_lin(z | x) N(x; m, P) = N(r; 0, S) q(x)`` exactly for the linearised model, the importance
weight of a draw ``x`` is ``N(r; 0, S) p(z | x) / p_lin(z | x)``: the evidence, corrected by the
true likelihood (the outlier mixture, the nonlinear geometry) over the linearised one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
BoolArray = NDArray[np.bool_]


def predict_covariance(cov: FloatArray, rot: ComplexArray, step: ComplexArray,
                       sigmas: tuple[float, float, float]) -> FloatArray:
    """``F P F^T + G Q G^T`` for every particle: the covariance ``cov`` (N, 3, 3) carried
    through a motion whose world displacement is ``step`` (N complex, m) from headings
    ``rot`` (N rotors, before the motion), plus the body-frame motion noise ``sigmas``
    (along m, across m, heading rad) rotated into the world. ``F = I + u e_3^T`` with
    ``u = (-step_y, step_x, 0)``, so ``F P F^T`` is two rank-one corrections."""
    u = np.stack((-step.imag, step.real), axis=-1)                     # (N, 2)
    out = cov.copy()
    out[:, :2, :] += u[:, :, None] * cov[:, 2:3, :]
    out[:, :, :2] += out[:, :, 2:3] * u[:, None, :]
    sa, sl, st = sigmas
    c, s = rot.real, rot.imag
    va, vl = sa * sa, sl * sl
    out[:, 0, 0] += c * c * va + s * s * vl
    out[:, 1, 1] += s * s * va + c * c * vl
    cross = c * s * (va - vl)
    out[:, 0, 1] += cross
    out[:, 1, 0] += cross
    out[:, 2, 2] += st * st
    return out


def ray_residuals(z: ComplexArray, rot: ComplexArray, landmarks: ComplexArray,
                  q: ComplexArray, u: ComplexArray) -> tuple[FloatArray, FloatArray]:
    """The residual ``r`` (N, K, 2: along, across the ray, m) of each landmark ``landmarks``
    (N, K complex, m, the map landmark each particle associates) at the poses ``z``, ``rot``
    (N), and its Jacobian (N, K, 2, 3) in ``x``, ``y``, heading."""
    cu = u.conj()[None, :]
    a = -cu * rot.conj()[:, None]          # d r / d x (complex); d r / d y = i a
    h = a * (z[:, None] - landmarks)       # conj(u) exp(-i th) (L - z)
    r = h - cu * q[None, :]
    jac = np.empty((*r.shape, 2, 3))
    jac[..., 0, 0], jac[..., 1, 0] = a.real, a.imag
    jac[..., 0, 1], jac[..., 1, 1] = -a.imag, a.real
    jac[..., 0, 2], jac[..., 1, 2] = h.imag, -h.real   # d r / d th = -i h
    return np.stack((r.real, r.imag), axis=-1), jac


@dataclass(frozen=True)
class Proposal:
    """Each particle's Gaussian after a frame: mean offset ``d`` (N, 3) from the prior mean,
    covariance ``cov`` (N, 3, 3), and what its weight needs: the residuals ``r`` (N, K, 2) and
    Jacobians ``jac`` (N, K, 2, 3) of the linearisation, the weights ``wt`` (N, K, 2) of the
    residuals (the inverse noise variances of the landmarks inside the gate, 0 outside) and
    ``log_evidence`` (N), the log of ``N(r; 0, S)`` over the used landmarks without its
    constant ``-sum (log 2 pi + log sr + log st)`` (the same constant as the linearised
    likelihood's, which cancels in the weight)."""

    d: FloatArray
    cov: FloatArray
    r: FloatArray
    jac: FloatArray
    wt: FloatArray
    log_evidence: FloatArray

    @property
    def used(self) -> BoolArray:
        """Which landmarks (N, K) each particle's proposal used (inside the gate)."""
        out: BoolArray = self.wt[..., 0] > 0.0
        return out


def _mul3(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a @ b`` for stacks (N, 3, 3), element by element (faster than a batched matmul of
    many small matrices)."""
    return (a[:, :, 0, None] * b[:, None, 0, :] + a[:, :, 1, None] * b[:, None, 1, :]
            + a[:, :, 2, None] * b[:, None, 2, :])


def _inv3(m: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Inverses and determinants of a stack (N, 3, 3), by cofactors."""
    r0, r1, r2 = m[:, 0], m[:, 1], m[:, 2]
    c0, c1, c2 = np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)
    det = np.einsum("ni,ni->n", r0, c0)
    return np.stack((c0, c1, c2), axis=-1) / det[:, None, None], det


def kalman_proposal(cov: FloatArray, r: FloatArray, jac: FloatArray, sr: FloatArray,
                    st: FloatArray, gate_chi2: float) -> Proposal:
    """One Kalman step per particle from ``N(0, cov)`` (offsets from the prior mean) with the
    residuals ``r`` and Jacobians ``jac`` of :func:`ray_residuals` and the noise ``sr``,
    ``st`` (K, m) along and across each ray. A landmark whose squared Mahalanobis distance
    ``r^T (R + J P J^T)^-1 r`` exceeds ``gate_chi2`` (a misread landmark, a particle far from
    it) is left out of that particle's proposal (its weight still counts it)."""
    n = len(cov)
    col = [jac[..., j] for j in range(3)]                              # (N, K, 2) each
    pc = cov[:, None, None, :, :]
    jp = [col[0] * pc[..., 0, j] + col[1] * pc[..., 1, j] + col[2] * pc[..., 2, j]
          for j in range(3)]                                           # (J P)[..., j]
    # the gate: S_k = R_k + J_k P J_k^T, 2 x 2 per particle and landmark
    s00 = sum(jp[j][..., 0] * col[j][..., 0] for j in range(3)) + sr * sr
    s11 = sum(jp[j][..., 1] * col[j][..., 1] for j in range(3)) + st * st
    s01 = sum(jp[j][..., 0] * col[j][..., 1] for j in range(3))
    r0, r1 = r[..., 0], r[..., 1]
    m2 = (s11 * r0 * r0 - 2.0 * s01 * r0 * r1 + s00 * r1 * r1) / (s00 * s11 - s01 * s01)
    inv_var = np.stack((1.0 / (sr * sr), 1.0 / (st * st)), axis=-1)   # (K, 2)
    wt = np.where((m2 <= gate_chi2)[..., None], inv_var[None], 0.0)    # (N, K, 2)
    cw = [c * wt for c in col]
    a = np.empty((n, 3, 3))
    for i in range(3):
        for j in range(i, 3):
            a[:, i, j] = a[:, j, i] = np.sum(cw[i] * col[j], axis=(1, 2))   # J^T R^-1 J
    b = np.stack([np.sum(c * r, axis=(1, 2)) for c in cw], axis=-1)       # J^T R^-1 r
    m = _mul3(a, cov)
    m[:, 0, 0] += 1.0
    m[:, 1, 1] += 1.0
    m[:, 2, 2] += 1.0                                                  # I + A P
    inv, det = _inv3(m)
    post = _mul3(cov, inv)
    post = 0.5 * (post + post.transpose(0, 2, 1))
    d = -np.einsum("nij,nj->ni", post, b)
    quad = np.sum(r * wt * r, axis=(1, 2)) + np.einsum("ni,ni->n", b, d)
    return Proposal(d, post, r, jac, wt, -0.5 * (quad + np.log(det)))


def gaussian_offsets(cov: FloatArray, g: FloatArray) -> FloatArray:
    """Draws (N, 3) of ``N(0, cov)`` (cov: N, 3, 3, positive semi-definite) from standard
    normals ``g`` (N, 3): ``L sqrt(D) g`` with the LDL^T factors, a pivot of (nearly) zero
    giving no spread in that direction, so a singular ``cov`` is fine."""
    tiny = 1e-15 * (np.abs(cov[:, 0, 0]) + np.abs(cov[:, 1, 1]) + np.abs(cov[:, 2, 2])) + 1e-300

    def ratio(num: FloatArray, den: FloatArray) -> FloatArray:
        out: FloatArray = np.divide(num, den, out=np.zeros_like(num), where=den > tiny)
        return out

    d0 = cov[:, 0, 0]
    l10, l20 = ratio(cov[:, 1, 0], d0), ratio(cov[:, 2, 0], d0)
    d1 = cov[:, 1, 1] - l10 * l10 * d0
    l21 = ratio(cov[:, 2, 1] - l20 * l10 * d0, d1)
    d2 = cov[:, 2, 2] - l20 * l20 * d0 - l21 * l21 * d1
    e0 = np.sqrt(np.maximum(d0, 0.0)) * g[:, 0]
    e1 = np.sqrt(np.maximum(d1, 0.0)) * g[:, 1]
    e2 = np.sqrt(np.maximum(d2, 0.0)) * g[:, 2]
    return np.stack((e0, l10 * e0 + e1, l20 * e0 + l21 * e1 + e2), axis=-1)


def draw(prop: Proposal, g: FloatArray) -> FloatArray:
    """Offsets (N, 3) from the prior means drawn from the proposal with standard normals ``g``
    (N, 3)."""
    return prop.d + gaussian_offsets(prop.cov, g)


def log_weight_correction(prop: Proposal, dx: FloatArray) -> FloatArray:
    """``log N(r; 0, S) - log p_lin(z | x)`` (N) for the draws at offsets ``dx`` (N, 3): add
    ``log p(z | x)`` (the true likelihood) for the importance weight's logarithm."""
    jac = prop.jac
    e = prop.r + (jac[..., 0] * dx[:, None, None, 0] + jac[..., 1] * dx[:, None, None, 1]
                  + jac[..., 2] * dx[:, None, None, 2])
    out: FloatArray = prop.log_evidence + 0.5 * np.sum(e * prop.wt * e, axis=(1, 2))
    return out
