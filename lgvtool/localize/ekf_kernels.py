"""Compiled loops of the Gaussian estimators (EKF, dead reckoning), with numba (the ``fast``
extra).

The same arithmetic as the numpy path of :mod:`lgvtool.localize.ekf` (the prediction
``P <- F P F^T + G Q G^T`` of the 3-state pose, the reflector update in information form),
written as scalar loops so that one observation costs one call instead of about a hundred
numpy calls. Elementwise steps repeat the numpy path's operations in its order; the 3 x 3
products, the sums over reflectors and the matrix inverse are summed in order here (numpy
uses BLAS and LAPACK), which differs in the last bits only (well within 1e-9 m and 1e-9 of
the covariances' scale).

Importing this module imports numba; only the estimators' compiled backend imports it
(:mod:`lgvtool.localize.ekf_compiled`, when an estimator is made with the kernels chosen:
:func:`lgvtool.localize.kernel_choice.gaussian_backend`), never at start-up. The compiled code is
cached on disk (``cache=True``, in ``__pycache__`` beside this file), so only the first run on
a machine pays the compilation.

Units: positions m, angles rad, times s.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba
import numpy as np
from numpy.typing import NDArray

from lgvtool.localize.ekf import lost_scan as ekf_lost_scan

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IntArray = NDArray[np.int64]

_F = TypeVar("_F", bound=Callable[..., Any])

_TWO_PI = 2.0 * math.pi

# indexes into the parameter vector of :func:`step`
P_NOISE_DIST, P_NOISE_LAT, P_NOISE_ROT, P_NOISE_ROT_PER_M = 0, 1, 2, 3
P_SIGMA_RANGE, P_SIGMA_RANGE_PER_M, P_SIGMA_BEARING, P_GATE2, P_USE_IDS = 4, 5, 6, 7, 8
#: the square of the association's ambiguity ratio (lgvtool.localize.association)
P_RATIO2 = 9
#: how long scans may find nothing before the estimator looks for a fix (``scan_recover_s``)
P_RECOVER_S = 10
N_PARAMS = 11


def _jit(f: _F) -> _F:
    """Compile ``f`` in nopython mode, cached on disk, without fast-math (no reassociation)."""
    return cast(_F, numba.njit(cache=True, nogil=True, error_model="numpy")(f))


@_jit
def _wrap(a: float) -> float:
    """Wrap an angle to (-pi, pi], rad (as :func:`lgvtool.angles.wrap_scalar`)."""
    w = float(np.fmod(a + math.pi, _TWO_PI))
    if w < 0.0:
        w += _TWO_PI
    w -= math.pi
    return w + _TWO_PI if w <= -math.pi else w


@_jit
def _predict(mu: FloatArray, P: FloatArray, dx: float, dy: float, dth: float, dist: float,
             rot: float, prm: FloatArray) -> None:
    """The 3-state prediction in place: the body-frame motion ``(dx, dy, dth)`` (m, m, rad)
    composed onto ``mu``, ``P <- F P F^T + G Q G^T`` with the noise of ``dist`` (m) and
    ``rot`` (rad)."""
    x, y, th = mu[0], mu[1], mu[2]
    c, s = math.cos(th), math.sin(th)
    mu[0] = x + c * dx - s * dy
    mu[1] = y + s * dx + c * dy
    mu[2] = _wrap(th + dth)
    sa = prm[P_NOISE_DIST] * dist
    sl = prm[P_NOISE_LAT] * dist
    st = prm[P_NOISE_ROT] * rot + prm[P_NOISE_ROT_PER_M] * dist
    f02 = -s * dx - c * dy
    f12 = c * dx - s * dy
    # F P: rows 0 and 1 pick up f02 / f12 times row 2
    a = np.empty((3, 3))
    for j in range(3):
        a[0, j] = P[0, j] + f02 * P[2, j]
        a[1, j] = P[1, j] + f12 * P[2, j]
        a[2, j] = P[2, j]
    # (F P) F^T
    b = np.empty((3, 3))
    for i in range(3):
        b[i, 0] = a[i, 0] + a[i, 2] * f02
        b[i, 1] = a[i, 1] + a[i, 2] * f12
        b[i, 2] = a[i, 2]
    # G Q G^T with G the rotation by th (z untouched)
    qa, ql, qt = sa * sa, sl * sl, st * st
    b[0, 0] += c * c * qa + s * s * ql
    b[0, 1] += c * s * qa - s * c * ql
    b[1, 0] += s * c * qa - c * s * ql
    b[1, 1] += s * s * qa + c * c * ql
    b[2, 2] += qt
    for i in range(3):
        for j in range(3):
            P[i, j] = b[i, j]


@_jit
def _invert(A: FloatArray) -> FloatArray:
    """Inverse of a small square matrix (Gauss-Jordan with partial pivoting)."""
    n = A.shape[0]
    M = A.copy()
    inv = np.eye(n)
    for col in range(n):
        piv = col
        best = abs(M[col, col])
        for r in range(col + 1, n):
            if abs(M[r, col]) > best:
                best = abs(M[r, col])
                piv = r
        if piv != col:
            for j in range(n):
                M[col, j], M[piv, j] = M[piv, j], M[col, j]
                inv[col, j], inv[piv, j] = inv[piv, j], inv[col, j]
        d = M[col, col]
        for j in range(n):
            M[col, j] /= d
            inv[col, j] /= d
        for r in range(n):
            if r != col:
                f = M[r, col]
                if f != 0.0:
                    for j in range(n):
                        M[r, j] -= f * M[col, j]
                        inv[r, j] -= f * inv[col, j]
    return inv


@_jit
def _innovation(j: int, ox: float, oy: float, ray: float, rng_k: float, c: float, s: float,
                hx: FloatArray, hy: FloatArray, P: FloatArray, sr2: float, sb2: float,
                hr: FloatArray, hb: FloatArray) -> tuple[float, float, float]:
    """Map reflector ``j`` (body frame ``hx[j], hy[j]``, m) seen from the sensor origin
    ``(ox, oy)`` (m, body frame) of a reflector measured at range ``rng_k`` (m) along the ray
    angle ``ray`` (rad): the range and ray-angle Jacobians into ``hr``, ``hb`` and the squared
    Mahalanobis distance of the innovation (not-a-number as infinite), the range and the
    bearing innovation (m, rad)."""
    vx = hx[j] - ox
    vy = hy[j] - oy
    r2 = max(vx * vx + vy * vy, 1e-12)
    rng = math.sqrt(r2)
    nr = rng_k - rng
    a = ray - math.atan2(vy, vx)
    nb = _wrap(a)
    dvx0, dvx1, dvx2 = -c, -s, hy[j]
    dvy0, dvy1, dvy2 = s, -c, -hx[j]
    hr[0] = (vx * dvx0 + vy * dvy0) / rng
    hr[1] = (vx * dvx1 + vy * dvy1) / rng
    hr[2] = (vx * dvx2 + vy * dvy2) / rng
    hb[0] = (vx * dvy0 - vy * dvx0) / r2
    hb[1] = (vx * dvy1 - vy * dvx1) / r2
    hb[2] = (vx * dvy2 - vy * dvx2) / r2
    srr = 0.0
    srb = 0.0
    sbb = 0.0
    for i in range(3):
        for m in range(3):
            srr += hr[i] * P[i, m] * hr[m]
            srb += hr[i] * P[i, m] * hb[m]
            sbb += hb[i] * P[i, m] * hb[m]
    srr += sr2
    sbb += sb2
    det = srr * sbb - srb * srb
    d2 = (sbb * nr * nr - 2.0 * srb * nr * nb + srr * nb * nb) / det
    if math.isnan(d2):
        d2 = math.inf
    return d2, nr, nb


@_jit
def _update_scan(mu: FloatArray, P: FloatArray, q: ComplexArray, u: ComplexArray,
                 ranges: FloatArray, ids: IntArray, map_x: FloatArray, map_y: FloatArray,
                 map_ids: IntArray, prm: FloatArray, counts: IntArray) -> bool:
    """The reflector update of :meth:`lgvtool.localize.ekf.Ekf._update_scan` in place, with
    its association (:func:`lgvtool.localize.association.associate`: the id's reflector inside
    the gate, else the nearest inside it unless a second is inside at less than the ambiguity
    ratio times its distance); adds the accepted and rejected reflectors, those whose id failed
    its gate and those dropped as ambiguous to ``counts[0:4]``; True when at least one
    reflector was accepted."""
    K = ranges.shape[0]
    J = map_x.shape[0]
    n = P.shape[0]
    if K == 0 or J == 0:
        return False
    x, y, th = mu[0], mu[1], mu[2]
    c, s = math.cos(th), math.sin(th)
    hx = np.empty(J)
    hy = np.empty(J)
    for j in range(J):
        ex, ey = map_x[j] - x, map_y[j] - y
        hx[j] = c * ex + s * ey
        hy[j] = -s * ex + c * ey
    sb2 = prm[P_SIGMA_BEARING] ** 2
    gate2 = prm[P_GATE2]
    ratio2 = prm[P_RATIO2]
    use_ids = prm[P_USE_IDS] != 0.0
    # the accepted measurements: H rows (range, bearing) over the pose, innovations, weights
    Hr = np.empty((K, 3))
    Hb = np.empty((K, 3))
    nu_r = np.empty(K)
    nu_b = np.empty(K)
    w_r = np.empty(K)
    hr = np.empty(3)
    hb = np.empty(3)
    n_ok = 0
    rejected = 0
    for k in range(K):
        ox = q[k].real - ranges[k] * u[k].real
        oy = q[k].imag - ranges[k] * u[k].imag
        ray = math.atan2(u[k].imag, u[k].real)
        sr2 = prm[P_SIGMA_RANGE] ** 2 + (prm[P_SIGMA_RANGE_PER_M] * ranges[k]) ** 2
        known = -1
        if use_ids:
            for j in range(J):
                if map_ids[j] == ids[k]:
                    known = j  # the last reflector of a repeated id
        chosen = -1
        nr = 0.0
        nb = 0.0
        if known >= 0:
            d2, nr, nb = _innovation(known, ox, oy, ray, ranges[k], c, s, hx, hy, P, sr2, sb2,
                                     hr, hb)
            if d2 <= gate2:
                chosen = known
            else:
                counts[2] += 1
        if chosen < 0:
            best_d2 = math.inf
            second = math.inf
            best_j = -1
            for j in range(J):
                d2, _, _ = _innovation(j, ox, oy, ray, ranges[k], c, s, hx, hy, P, sr2, sb2,
                                       hr, hb)
                if d2 < best_d2:
                    second = best_d2
                    best_d2 = d2
                    best_j = j
                elif d2 < second:
                    second = d2
            if best_d2 <= gate2:
                if second <= gate2 and second < ratio2 * best_d2:
                    counts[3] += 1
                else:
                    chosen = best_j
                    _, nr, nb = _innovation(best_j, ox, oy, ray, ranges[k], c, s, hx, hy, P,
                                            sr2, sb2, hr, hb)
        if chosen >= 0:
            for i in range(3):
                Hr[n_ok, i] = hr[i]
                Hb[n_ok, i] = hb[i]
            nu_r[n_ok] = nr
            nu_b[n_ok] = nb
            w_r[n_ok] = 1.0 / sr2
            n_ok += 1
        else:
            rejected += 1
    counts[1] += rejected
    if n_ok == 0:
        return False
    wb = 1.0 / sb2
    Y = np.zeros((n, n))
    yv = np.zeros(n)
    for k in range(n_ok):
        for i in range(3):
            yv[i] += Hr[k, i] * w_r[k] * nu_r[k] + Hb[k, i] * wb * nu_b[k]
            for m in range(3):
                Y[i, m] += Hr[k, i] * w_r[k] * Hr[k, m] + Hb[k, i] * wb * Hb[k, m]
    A = _invert(P)
    for i in range(n):
        for m in range(n):
            A[i, m] += Y[i, m]
    P_new = _invert(A)
    for i in range(n):
        acc = 0.0
        for m in range(n):
            acc += P_new[i, m] * yv[m]
        mu[i] += acc
    mu[2] = _wrap(mu[2])
    for i in range(n):
        for m in range(n):
            P[i, m] = 0.5 * (P_new[i, m] + P_new[m, i])
    counts[0] += n_ok
    return True


@_jit
def _record(mu: FloatArray, P: FloatArray, t: float, k: int, ct: FloatArray, cx: FloatArray,
            cy: FloatArray, ch: FloatArray, covs: FloatArray) -> None:
    """Row ``k`` of the estimate table: time, pose and the symmetrised 3 x 3 covariance."""
    ct[k] = t
    cx[k] = mu[0]
    cy[k] = mu[1]
    ch[k] = mu[2]
    for i in range(3):
        for j in range(3):
            covs[k, 3 * i + j] = 0.5 * (P[i, j] + P[j, i])


lost_scan = _jit(ekf_lost_scan)
""":func:`lgvtool.localize.ekf.lost_scan` itself, compiled for the loop (one rule, one text)."""


@_jit
def step(mu: FloatArray, P: FloatArray, i_move: int, dx: FloatArray, dy: FloatArray,
         dth: FloatArray, dist: FloatArray, rot: FloatArray, scan: bool, q: ComplexArray,
         u: ComplexArray, ranges: FloatArray, ids: IntArray, map_x: FloatArray,
         map_y: FloatArray, map_ids: IntArray, prm: FloatArray, counts: IntArray, t: float,
         k: int, ct: FloatArray, cx: FloatArray, cy: FloatArray, ch: FloatArray,
         covs: FloatArray) -> bool:
    """One observation of a started estimator: the motion ``i_move`` of the step arrays
    (none when negative), the reflector update when ``scan``, then row ``k`` of the table.
    True when a reflector was accepted."""
    if i_move >= 0:
        _predict(mu, P, dx[i_move], dy[i_move], dth[i_move], dist[i_move], rot[i_move], prm)
    accepted = False
    if scan:
        accepted = _update_scan(mu, P, q, u, ranges, ids, map_x, map_y, map_ids, prm, counts)
    _record(mu, P, t, k, ct, cx, cy, ch, covs)
    return accepted


@_jit
def track(mu: FloatArray, P: FloatArray, j0: int, i0: int, dx: FloatArray, dy: FloatArray,
          dth: FloatArray, dist: FloatArray, rot: FloatArray, kinds: NDArray[np.int8],
          offs: IntArray, q: ComplexArray, u: ComplexArray, ranges: FloatArray,
          ids: IntArray, map_x: FloatArray, map_y: FloatArray, map_ids: IntArray,
          prm: FloatArray, counts: IntArray, times: FloatArray, lost: FloatArray, k: int,
          ct: FloatArray, cx: FloatArray, cy: FloatArray, ch: FloatArray, covs: FloatArray
          ) -> tuple[int, int, bool]:
    """:func:`step` for the entries of a chunk (:func:`lgvtool.localize.chunks.scan_chunk`)
    from ``j0`` on (observation ``i0 + j0`` of the run; ``dx[i - 1]`` moves to observation
    ``i``, no motion when ``dx`` is empty), as long as they are scans (kind 1: points
    ``offs[j]:offs[j + 1]`` of ``q``, ``u``, ``ranges`` m and reflector ``ids``) or times
    without one (kind 0). ``lost`` is the estimator's ``scan_lost`` (:func:`lost_scan`).
    Returns the entry it stopped at (another kind, the chunk's end, or the one after a scan
    that makes a recovery due), the next free row, and whether a recovery is due (the
    caller tries it with the scan before that entry and rewrites its row)."""
    moving = dx.shape[0] > 0
    j = j0
    while j < kinds.shape[0] and kinds[j] != 2:
        i = i0 + j
        a = offs[j]
        b = offs[j + 1]
        accepted = step(mu, P, i - 1 if moving and i > 0 else -1, dx, dy, dth, dist, rot,
                        kinds[j] == 1, q[a:b], u[a:b], ranges[a:b], ids[a:b], map_x, map_y,
                        map_ids, prm, counts, times[i], k, ct, cx, cy, ch, covs)
        k += 1
        j += 1
        if kinds[j - 1] == 1 and lost_scan(lost, times[i], b - a, accepted,
                                           prm[P_RECOVER_S]):
            return j, k, True
    return j, k, False


@_jit
def coast(mu: FloatArray, P: FloatArray, first: int, dx: FloatArray, dy: FloatArray,
          dth: FloatArray, dist: FloatArray, rot: FloatArray, prm: FloatArray,
          times: FloatArray, k: int, ct: FloatArray, cx: FloatArray, cy: FloatArray,
          ch: FloatArray, covs: FloatArray) -> int:
    """Predictions alone from observation ``first`` to the last (``dx[i - 1]`` moves to
    ``times[i]``; no motion when ``dx`` is empty), one row per observation from row ``k`` on;
    returns the next free row."""
    for i in range(first, times.shape[0]):
        if i > 0 and dx.shape[0] > 0:
            _predict(mu, P, dx[i - 1], dy[i - 1], dth[i - 1], dist[i - 1], rot[i - 1], prm)
        _record(mu, P, times[i], k, ct, cx, cy, ch, covs)
        k += 1
    return k
