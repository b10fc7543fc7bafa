"""Fused loops of the particle filters, compiled with numba (the ``fast`` extra).

Each kernel makes one pass over the particles doing what the numpy path of the filters does in
several array operations (one temporary array each): the motion, the transform of every
measured reflector into the world, its association with the nearest map reflector, the
weight, the weighted sums of the estimate and the redistribution or resampling. The random
numbers are never drawn here: the filters draw them in bulk from their
``numpy.random.Generator`` exactly as the numpy path does and hand them in, so a seed gives
the same random stream on both paths. Where the numpy path's arithmetic is elementwise, the
kernels repeat it operation for operation (the same bits); where numpy sums through BLAS or
pairwise summation, the kernels sum in order, which differs in the last bits (docs/filter.md:
within 1e-9 m).

Importing this module imports numba; the filters import it only when they run
(:func:`lgvtool.localize.particles.fused_kernels`). The compiled code is cached on disk
(``cache=True``, in ``__pycache__`` beside this file), so only the first run on a machine pays
the compilation.

Units: positions m (complex ``x + iy``), headings as rotors ``exp(i th)`` or rad.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba
import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IntArray = NDArray[np.intp]

_F = TypeVar("_F", bound=Callable[..., Any])

_LOG2 = math.log(2.0)
_TWO_PI = 2.0 * math.pi


def _jit(f: _F) -> _F:
    """Compile ``f`` in nopython mode, cached on disk, without fast-math (the numpy path's
    rounding is kept: no reassociation, no fused multiply-add)."""
    return cast(_F, numba.njit(cache=True, nogil=True, error_model="numpy")(f))


# ---------------------------------------------------------------------------- shared pieces
@_jit
def _nearest_distance(px: float, py: float, map_z: ComplexArray) -> float:
    """Distance from the point ``(px, py)`` to the nearest map reflector, m."""
    best = math.inf
    for r in range(map_z.shape[0]):
        ex = map_z[r].real - px
        ey = map_z[r].imag - py
        e = math.sqrt(ex * ex + ey * ey)
        if e < best:
            best = e
    return best


@_jit
def _nearest_index(p: complex, map_z: ComplexArray) -> int:
    """Index of the map reflector nearest to ``p`` (the first of equals, as ``np.argmin``),
    compared by squared distance."""
    best = math.inf
    j = 0
    for r in range(map_z.shape[0]):
        ex = map_z[r].real - p.real
        ey = map_z[r].imag - p.imag
        d2 = ex * ex + ey * ey
        if d2 < best:
            best = d2
            j = r
    return j


#: below this angle (rad) :func:`_rotor` sums Taylor series instead of calling cos and sin
_SMALL_ANGLE = 0.05


@_jit
def _rotor(x: float) -> complex:
    """``exp(i x)`` (x rad). For ``|x| < 0.05`` (a redistribution's heading offsets) from the
    Taylor series of cos and sin to the 10th order (truncation below 1e-20, so within an ulp
    of the library's functions, and 5x faster), else from ``math.cos`` and ``math.sin``."""
    if abs(x) < _SMALL_ANGLE:
        x2 = x * x
        c = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0 - x2 * (
            1.0 / 40320.0 - x2 * (1.0 / 3628800.0)))))
        sn = x * (1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0 - x2 * (
            1.0 / 362880.0)))))
        return complex(c, sn)
    return complex(math.cos(x), math.sin(x))


@_jit
def _wrap_pi(th: float) -> float:
    """``np.remainder(th + pi, 2 pi) - pi``, operation for operation (rad)."""
    a = th + math.pi
    mod = math.fmod(a, _TWO_PI)
    if mod != 0.0:
        if mod < 0.0:
            mod += _TWO_PI
    else:
        mod = 0.0
    return mod - math.pi


@_jit
def _logaddexp(x: float, y: float) -> float:
    """``np.logaddexp`` for finite or infinite ``x``, ``y``."""
    if x == y:
        return x + _LOG2
    tmp = x - y
    if tmp > 0.0:
        return x + math.log1p(math.exp(-tmp))
    if tmp <= 0.0:
        return y + math.log1p(math.exp(tmp))
    return tmp


# ---------------------------------------------------------------------------- pf-paper
#: particles moved and weighed together by :func:`paper_exponents` (their coordinates are
#: laid out as separate arrays, so that the loop over them runs in SIMD registers)
_CHUNK = 256


@_jit
def paper_exponents(prev: ComplexArray, cur: ComplexArray, step_z: complex, step_rot: complex,
                    q: ComplexArray, cand: ComplexArray, half: FloatArray,
                    map_z: ComplexArray, factor: float, exponent: FloatArray) -> None:
    """Move the packed particles ``prev`` (M, 3: z, rot, 1) by the body-frame step ``step_z``
    (m) and the turn ``step_rot`` (a rotor) into ``cur`` (may be ``prev``; ``step_z = 0``,
    ``step_rot = 1``: no motion), put the measured points ``q`` (K, body frame, m) into the
    world at every particle, take each point's distance to its nearest map reflector (the
    candidate ``cand[k]`` when nearer than ``half[k]``, half its distance to its own nearest
    neighbour, else a search of ``map_z``) and write the exponent of eq. 10,
    ``factor * D_m^2`` with ``D_m`` the summed distances (summed in the order of the points).
    """
    m = prev.shape[0]
    k = q.shape[0]
    zr = np.empty(_CHUNK)
    zi = np.empty(_CHUNK)
    rr = np.empty(_CHUNK)
    ri = np.empty(_CHUNK)
    tot = np.empty(_CHUNK)
    far = np.empty(_CHUNK)
    for a in range(0, m, _CHUNK):
        n = min(_CHUNK, m - a)
        for i in range(n):
            z = prev[a + i, 0] + prev[a + i, 1] * step_z
            rot = prev[a + i, 1] * step_rot
            cur[a + i, 0] = z
            cur[a + i, 1] = rot
            cur[a + i, 2] = 1.0
            zr[i] = z.real
            zi[i] = z.imag
            rr[i] = rot.real
            ri[i] = rot.imag
            tot[i] = 0.0
            far[i] = -math.inf
        for j in range(k):
            qr = q[j].real
            qi = q[j].imag
            cr = cand[j].real
            ci = cand[j].imag
            h = half[j]
            for i in range(n):
                dx = zr[i] + (rr[i] * qr - ri[i] * qi) - cr
                dy = zi[i] + (rr[i] * qi + ri[i] * qr) - ci
                d = math.sqrt(dx * dx + dy * dy)
                tot[i] += d
                far[i] = max(far[i], d - h)
        for i in range(n):
            if far[i] >= 0.0:
                # a point not nearer its candidate than half the candidate's spacing: the
                # sum again, such points searched in the whole map
                t = 0.0
                for j in range(k):
                    px = zr[i] + (rr[i] * q[j].real - ri[i] * q[j].imag)
                    py = zi[i] + (rr[i] * q[j].imag + ri[i] * q[j].real)
                    dx = px - cand[j].real
                    dy = py - cand[j].imag
                    d = math.sqrt(dx * dx + dy * dy)
                    if d >= half[j]:
                        d = _nearest_distance(px, py, map_z)
                    t += d
                tot[i] = t
            exponent[a + i] = tot[i] * tot[i] * factor


@_jit
def paper_move(prev: ComplexArray, cur: ComplexArray, step_z: complex, step_rot: complex
               ) -> None:
    """Eq. 9 on packed particles: ``cur`` (may be ``prev``) is ``prev`` moved by the
    body-frame step ``step_z`` (m) and turned by the rotor ``step_rot``."""
    for i in range(prev.shape[0]):
        z = prev[i, 0] + prev[i, 1] * step_z
        rot = prev[i, 1] * step_rot
        cur[i, 0] = z
        cur[i, 1] = rot
        cur[i, 2] = 1.0


@_jit
def paper_weights(s: ComplexArray, exponent: FloatArray, w: FloatArray
                  ) -> tuple[float, float, float, float, float]:
    """Eq. 10 relative to the best particle: ``exponent -= max(exponent)``,
    ``w = exp(exponent)`` (unnormalised); returns the weighted sums of x, y (m), cos th,
    sin th and the sum of the weights (eq. 11 before the division)."""
    top = -math.inf
    for i in range(s.shape[0]):
        if exponent[i] > top:
            top = exponent[i]
    sx = sy = sc = ss = total = 0.0
    for i in range(s.shape[0]):
        e = exponent[i] - top
        exponent[i] = e
        wi = math.exp(e)
        w[i] = wi
        z = s[i, 0]
        r = s[i, 1]
        sx += wi * z.real
        sy += wi * z.imag
        sc += wi * r.real
        ss += wi * r.imag
        total += wi
    return sx, sy, sc, ss, total


@_jit
def paper_redistribute(s: ComplexArray, top: IntArray, u: FloatArray, n_top: int,
                       n_local: int, width: FloatArray, low: FloatArray, far_z: complex,
                       out: ComplexArray) -> None:
    """The paper's redistribution of packed particles ``s`` into ``out`` from its uniform
    numbers ``u`` (4, M): particle ``i < n_local`` descends from the parent
    ``s[top[int(u[0, i] n_top)]]`` (``top``: the heaviest particles), moved by
    ``u[1:3, i] width + low`` (m) and turned by ``u[3, i] width + low`` (rad); the others are
    uniform, ``far_z`` plus the same offsets over the work area and every heading. The same
    arithmetic, in the same order, as the numpy path's
    :class:`lgvtool.localize.resampling.RedistributionDraws` and ``apply_packed``, except the
    turn's rotor for small angles (:func:`_rotor`: within an ulp)."""
    for i in range(out.shape[0]):
        ox = u[1, i] * width[0, i] + low[0, i]
        oy = u[2, i] * width[1, i] + low[1, i]
        oh = u[3, i] * width[2, i] + low[2, i]
        turn = _rotor(oh)
        if i < n_local:
            src = top[int(u[0, i] * n_top)]
            z = s[src, 0]
            # z (1 + 0i) + shift: the numpy path's product by the scale, then the shift
            out[i, 0] = complex(z.real * 1.0 - z.imag * 0.0, z.real * 0.0 + z.imag * 1.0) \
                + complex(ox, oy)
            out[i, 1] = s[src, 1] * turn + 0j
        else:
            out[i, 0] = complex(ox + far_z.real, oy + far_z.imag)
            out[i, 1] = turn
        out[i, 2] = 1.0


@_jit
def paper_spread(s: ComplexArray, w: FloatArray, total: float, sum_z: complex,
                 sum_rot: complex, cov: FloatArray) -> float:
    """Covariance of ``(x, y, heading)`` (into ``cov``, 3 x 3; m^2, m rad, rad^2) and effective
    sample size of a weighted packed set: ``w`` unnormalised with sum ``total``, ``sum_z`` and
    ``sum_rot`` the weighted sums of z and rot (the heading deviations are taken from their
    circular mean)."""
    mean = sum_z / total
    rc = sum_rot.conjugate()
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    sw2 = 0.0
    for i in range(s.shape[0]):
        wn = w[i] / total
        d = s[i, 0] - mean
        r = s[i, 1] * rc
        h = math.atan2(r.imag, r.real)
        dx = d.real
        dy = d.imag
        a00 += dx * wn * dx
        a01 += dx * wn * dy
        a02 += dx * wn * h
        a11 += dy * wn * dy
        a12 += dy * wn * h
        a22 += h * wn * h
        sw2 += wn * wn
    cov[0, 0] = a00
    cov[0, 1] = cov[1, 0] = a01
    cov[0, 2] = cov[2, 0] = a02
    cov[1, 1] = a11
    cov[1, 2] = cov[2, 1] = a12
    cov[2, 2] = a22
    return 1.0 / sw2
