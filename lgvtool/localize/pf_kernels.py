"""Fused loops of the particle filters, compiled with numba (the ``fast`` extra).

Each kernel makes one pass over the particles doing what the numpy path of the filters does in
several array operations (one temporary array each): the motion, the transform of every
measured reflector into the world, its association with the nearest map reflector, the
weight, the weighted sums of the estimate and the redistribution or resampling. The random
numbers are those of the numpy path, in its order: the filters draw them in bulk from their
``numpy.random.Generator`` and hand them in, or (``pf_predict_drawn``, pf's ``pf_track``)
hand in the generator itself, whose methods numba implements with NumPy's algorithms (and
:func:`_permutation`, NumPy's shuffle), so a seed gives the same random stream on both
paths. Where the numpy path's arithmetic is elementwise, the kernels repeat it operation for
operation (the same bits); where numpy sums through BLAS or pairwise summation, the kernels
sum in order, and a few library functions are replaced by series, which differs in the last
bits (docs/filter.md: within 1e-9 m).

Importing this module imports numba; only the filters' compiled backend imports it
(:mod:`lgvtool.localize.pf_compiled`, when a filter is made with the kernels chosen:
:func:`lgvtool.localize.kernel_choice.particle_backend`). The compiled code is cached on disk
(``cache=True``, in ``__pycache__`` beside this file), so only the first run on a machine pays
the compilation. The kernels of both filters and the pieces they share stay in this one module
on purpose: numba checks a cached kernel against its own source file only, so a kernel calling
a compiled function of another module would keep running the old code from the cache after
that other module changed (numba's documented cache limitation).

Units: positions m (complex ``x + iy``), headings as rotors ``exp(i th)`` or rad.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar, cast

import numba
import numba.extending
import numpy as np
from llvmlite import ir as llvm_ir
from numba.np.random import generator_core
from numpy.typing import NDArray

if TYPE_CHECKING:
    from numba.core.base import BaseContext
    from numba.core.typing.context import Context
    from numba.core.typing.templates import Signature

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IntArray = NDArray[np.intp]

_F = TypeVar("_F", bound=Callable[..., Any])

#: the next 32 random bits of a generator's bit generator (numba's binding of NumPy's
#: ``next_uint32``, which ``random_interval`` draws from)
_next_uint32 = cast(Callable[[Any], int], generator_core.next_uint32)

_TWO_PI = 2.0 * math.pi


def _jit(f: _F) -> _F:
    """Compile ``f`` in nopython mode, cached on disk, without fast-math (the numpy path's
    rounding is kept: no reassociation, no fused multiply-add)."""
    return cast(_F, numba.njit(cache=True, nogil=True, error_model="numpy")(f))


def _jit_inline(f: _F) -> _F:
    """:func:`_jit`, inlined into its callers (so that their loops can run in SIMD
    registers)."""
    return cast(_F, numba.njit(cache=True, nogil=True, error_model="numpy",
                               inline="always")(f))


# ---------------------------------------------------------------------------- shared pieces
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


@_jit_inline
def _cos_series(x: float) -> float:
    """The Taylor series of ``cos x`` to the 10th order (x rad, meant for ``|x| < 0.05``)."""
    x2 = x * x
    return 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0 - x2 * (
        1.0 / 40320.0 - x2 * (1.0 / 3628800.0)))))


@_jit_inline
def _sin_series(x: float) -> float:
    """The Taylor series of ``sin x`` to the 9th order (x rad, meant for ``|x| < 0.05``)."""
    x2 = x * x
    return x * (1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0 - x2 * (
        1.0 / 362880.0)))))


@_jit_inline
def _atan_series(u: float) -> float:
    """The Taylor series of ``atan u`` to the 13th order (meant for ``|u| < 0.05``), rad."""
    u2 = u * u
    return u * (1.0 - u2 * (1.0 / 3.0 - u2 * (1.0 / 5.0 - u2 * (1.0 / 7.0 - u2 * (
        1.0 / 9.0 - u2 * (1.0 / 11.0 - u2 * (1.0 / 13.0)))))))


@_jit
def _rotor(x: float) -> complex:
    """``exp(i x)`` (x rad). For ``|x| < 0.05`` (a redistribution's heading offsets) from the
    Taylor series of cos and sin to the 10th order (truncation below 1e-20, so within an ulp
    of the library's functions, and 5x faster), else from ``math.cos`` and ``math.sin``."""
    if abs(x) < _SMALL_ANGLE:
        return complex(_cos_series(x), _sin_series(x))
    return complex(math.cos(x), math.sin(x))


@_jit
def _heading(y: float, x: float) -> float:
    """``atan2(y, x)`` (rad). For ``|y| < 0.05 x`` (a particle's heading near the circular
    mean) from the Taylor series of ``atan(y / x)`` to the 13th order (truncation below
    1e-19, within an ulp or two of the library's function, and several times faster)."""
    if x > 0.0 and abs(y) < _SMALL_ANGLE * x:
        return _atan_series(y / x)
    return math.atan2(y, x)


@_jit
def _wrap_pi(th: float) -> float:
    """:func:`lgvtool.angles.wrap_angle` of one angle, to (-pi, pi] (rad): both take the
    floored remainder of ``th + pi`` from the exact ``fmod``, so the bits are the same (and the
    remainder of a number in [0, 2 pi) is itself); -pi maps to +pi."""
    a = th + math.pi
    w = a - math.pi if 0.0 <= a < _TWO_PI else a % _TWO_PI - math.pi
    return w + _TWO_PI if w <= -math.pi else w


# ---------------------------------------------------------------------------- pf-paper
#: particles moved and weighed together by :func:`paper_exponents` (their coordinates are
#: laid out as separate arrays, so that the loop over them runs in SIMD registers)
_CHUNK = 256


@_jit
def _chunk_arrays() -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray,
                             FloatArray, FloatArray]:
    """Scratch of a chunk of particles: x, y (m), the rotor's two parts, a sum, a product and
    a flag per particle."""
    return (np.empty(_CHUNK), np.empty(_CHUNK), np.empty(_CHUNK), np.empty(_CHUNK),
            np.empty(_CHUNK), np.empty(_CHUNK), np.empty(_CHUNK))


#: rows of the scratch of the pf-paper kernels (:func:`paper_scratch`)
_SCRATCH_ROWS = 13


def paper_scratch() -> FloatArray:
    """Scratch of :func:`paper_exponents`, :func:`paper_weigh` and :func:`paper_resample`: a
    chunk of particles laid out as separate arrays (allocated once per filter rather than
    on every call). The rows are padded so that no two start a multiple of 4 KiB apart
    (loads from one row would wait for stores to another, falsely aliased)."""
    return np.empty((_SCRATCH_ROWS, _CHUNK + 8))


@_jit
def paper_exponents(prev: ComplexArray, cur: ComplexArray, step_z: complex, step_rot: complex,
                    scan: ComplexArray, map_z: ComplexArray, factor: float,
                    exponent: FloatArray, work: FloatArray) -> float:
    """Move the packed particles ``prev`` (M, 2: z, rot) by the body-frame step ``step_z``
    (m) and the turn ``step_rot`` (a rotor) into ``cur`` (may be ``prev``; ``step_z = 0``,
    ``step_rot = 1``: no motion), put the measured points into the world at every particle,
    take each point's distance to its nearest map reflector and write the exponent of eq. 10,
    ``factor * D_m^2`` with ``D_m`` the summed distances (summed in the order of the points).
    ``scan`` (K, 3): per point its position in the body frame ``q`` (m), its candidate map
    reflector (m) and, as the real part, half the candidate's distance to its own nearest
    neighbour (m): the candidate is the nearest reflector when nearer than that, else
    ``map_z`` is searched. Returns the largest exponent. ``work``: :func:`paper_scratch`.
    """
    m = prev.shape[0]
    top = -math.inf
    k = scan.shape[0]
    zr, zi, rr, ri, tot, far = work[0], work[1], work[2], work[3], work[4], work[5]
    far_at = np.empty(m, dtype=np.intp)
    n_far = 0
    for a in range(0, m, _CHUNK):
        n = min(_CHUNK, m - a)
        for i in range(n):
            z = prev[a + i, 0] + prev[a + i, 1] * step_z
            rot = prev[a + i, 1] * step_rot
            cur[a + i, 0] = z
            cur[a + i, 1] = rot
            zr[i] = z.real
            zi[i] = z.imag
            rr[i] = rot.real
            ri[i] = rot.imag
            tot[i] = 0.0
            far[i] = -math.inf
        for j in range(k):
            qr = scan[j, 0].real
            qi = scan[j, 0].imag
            cr = scan[j, 1].real
            ci = scan[j, 1].imag
            h = scan[j, 2].real
            for i in range(n):
                dx = zr[i] + (rr[i] * qr - ri[i] * qi) - cr
                dy = zi[i] + (rr[i] * qi + ri[i] * qr) - ci
                d = math.sqrt(dx * dx + dy * dy)
                tot[i] += d
                far[i] = max(far[i], d - h)
        for i in range(n):
            if far[i] >= 0.0:
                # a point not nearer its candidate than half the candidate's spacing: the
                # particle's sum again below, with the others of its kind
                far_at[n_far] = a + i
                n_far += 1
            else:
                e = tot[i] * tot[i] * factor
                exponent[a + i] = e
                if e > top:
                    top = e
    for b in range(0, n_far, _CHUNK):
        top = max(top, _far_exponents(cur, far_at[b:min(n_far, b + _CHUNK)], scan, map_z,
                                      factor, exponent, work))
    return top


@_jit
def _far_exponents(s: ComplexArray, far_at: IntArray, scan: ComplexArray, map_z: ComplexArray,
                   factor: float, exponent: FloatArray, work: FloatArray) -> float:
    """The exponents of the packed particles ``s[far_at]`` (at most a chunk), which have a
    point not nearer its candidate than half the candidate's spacing: such points searched
    in the whole map by squared distance, the distances summed in point order (the numbers of
    a search per particle and point). The particles go together in SIMD registers: searched
    one by one, a far particle (the redistribution's uniform draws are 5 % of the set) cost
    several times a near one. Returns their largest exponent. ``work``: :func:`paper_scratch`
    (every row is free here)."""
    nf = far_at.shape[0]
    zr, zi, rr, ri, t, px, py, d, best = (work[0], work[1], work[2], work[3], work[4],
                                          work[5], work[6], work[7], work[8])
    for f in range(nf):
        z = s[far_at[f], 0]
        r = s[far_at[f], 1]
        zr[f] = z.real
        zi[f] = z.imag
        rr[f] = r.real
        ri[f] = r.imag
        t[f] = 0.0
    for j in range(scan.shape[0]):
        qr = scan[j, 0].real
        qi = scan[j, 0].imag
        cr = scan[j, 1].real
        ci = scan[j, 1].imag
        for f in range(nf):
            x = zr[f] + (rr[f] * qr - ri[f] * qi)
            y = zi[f] + (rr[f] * qi + ri[f] * qr)
            px[f] = x
            py[f] = y
            dx = x - cr
            dy = y - ci
            d[f] = math.sqrt(dx * dx + dy * dy)
            best[f] = math.inf
        for r in range(map_z.shape[0]):
            mr = map_z[r].real
            mi = map_z[r].imag
            for f in range(nf):
                ex = mr - px[f]
                ey = mi - py[f]
                best[f] = min(best[f], ex * ex + ey * ey)
        h = scan[j, 2].real
        for f in range(nf):
            t[f] += d[f] if d[f] < h else math.sqrt(best[f])
    top = -math.inf
    for f in range(nf):
        e = t[f] * t[f] * factor
        exponent[far_at[f]] = e
        top = max(top, e)
    return top


@_jit
def paper_move(prev: ComplexArray, cur: ComplexArray, step_z: complex, step_rot: complex
               ) -> None:
    """Eq. 9 on packed particles (M, 2: z, rot): ``cur`` (may be ``prev``) is ``prev`` moved
    by the body-frame step ``step_z`` (m) and turned by the rotor ``step_rot``."""
    for i in range(prev.shape[0]):
        z = prev[i, 0] + prev[i, 1] * step_z
        rot = prev[i, 1] * step_rot
        cur[i, 0] = z
        cur[i, 1] = rot


@_jit
def paper_weights(s: ComplexArray, exponent: FloatArray, w: FloatArray, sums: FloatArray
                  ) -> float:
    """Eq. 10 relative to the best particle: ``exponent -= max(exponent)``,
    ``w = exp(exponent)`` (unnormalised); writes the weighted sums of x, y (m), cos th,
    sin th and the sum of the weights (eq. 11 before the division) into ``sums`` (5,) and
    returns the last. ``s``: packed particles (M, 2: z, rot)."""
    top = -math.inf
    for i in range(s.shape[0]):
        if exponent[i] > top:
            top = exponent[i]
    return _weights_below(s, exponent, top, w, sums)


@_jit
def _weights_below(s: ComplexArray, exponent: FloatArray, top: float, w: FloatArray,
                   sums: FloatArray) -> float:
    """:func:`paper_weights` given ``top``, the largest exponent. The exponential from
    :func:`_exp_neg` (no library call: the loop runs in SIMD registers, 4x faster; within an
    ulp of ``math.exp``) where the exponent is within :data:`_EXP_SMALLEST` of the top, and
    from ``math.exp`` in a second loop for the others (the subnormal weights NumPy gives)."""
    n = s.shape[0]
    far = False
    for i in range(n):
        e = exponent[i] - top
        exponent[i] = e
        w[i] = _exp_neg(min(-e, _EXP_SMALLEST))
        far |= not (e >= -_EXP_SMALLEST)
    if far:
        for i in range(n):
            if not (exponent[i] >= -_EXP_SMALLEST):
                w[i] = math.exp(exponent[i])
    paper_sums(s, w, sums)
    total: float = sums[4]
    return total


@_jit
def paper_weigh(prev: ComplexArray, cur: ComplexArray, step_z: complex, step_rot: complex,
                scan: ComplexArray, map_z: ComplexArray, factor: float, exponent: FloatArray,
                w: FloatArray, sums: FloatArray, work: FloatArray) -> float:
    """:func:`paper_exponents` then :func:`paper_weights` on the moved particles ``cur``, in
    one call: motion, association, eq. 10 and eq. 11's sums (into ``sums``; returns the sum
    of the weights)."""
    top = paper_exponents(prev, cur, step_z, step_rot, scan, map_z, factor, exponent, work)
    return _weights_below(cur, exponent, top, w, sums)


@_jit
def paper_sums(s: ComplexArray, w: FloatArray, sums: FloatArray) -> None:
    """The weighted sums of x, y (m), cos th, sin th and the sum of the weights ``w`` of the
    packed particles ``s`` (M, 2: z, rot), in order, into ``sums`` (5,)."""
    sx = sy = sc = ss = total = 0.0
    for i in range(s.shape[0]):
        wi = w[i]
        z = s[i, 0]
        r = s[i, 1]
        sx += wi * z.real
        sy += wi * z.imag
        sc += wi * r.real
        ss += wi * r.imag
        total += wi
    sums[0] = sx
    sums[1] = sy
    sums[2] = sc
    sums[3] = ss
    sums[4] = total


@_jit
def _symmetric(cov: FloatArray, xx: float, xy: float, xh: float, yy: float, yh: float,
               hh: float) -> None:
    """Write the symmetric 3 x 3 covariance of (x, y, heading) from its six entries."""
    cov[0, 0] = xx
    cov[0, 1] = cov[1, 0] = xy
    cov[0, 2] = cov[2, 0] = xh
    cov[1, 1] = yy
    cov[1, 2] = cov[2, 1] = yh
    cov[2, 2] = hh


@_jit
def paper_resample(s: ComplexArray, w: FloatArray, top: IntArray, u: FloatArray,
                   plan: FloatArray, sums: FloatArray, out: ComplexArray, cov: FloatArray,
                   work: FloatArray) -> float:
    """The covariance and effective sample size of the weighted packed set ``s`` (M, 2: z,
    rot; ``w`` unnormalised, ``sums`` its eq. 11 sums from :func:`paper_weights`), and the
    paper's redistribution of ``s`` into ``out``, in one call.

    Covariance of ``(x, y, heading)`` into ``cov`` (3 x 3; m^2, m rad, rad^2),
    the heading deviations taken from the circular mean; returns the ESS.

    Redistribution from its uniform numbers ``u`` (4, M): particle ``i < n_local`` descends
    from the parent ``s[top[int(u[0, i] n_top)]]`` (``top``: the heaviest particles), moved by
    ``u[1:3, i] width + low`` (m) and turned by ``u[3, i] width + low`` (rad); the others are
    uniform, the work area's centre plus the same offsets over the work area and every
    heading. ``plan``: :attr:`lgvtool.localize.resampling.RedistributionPlan.kernel_plan`. The
    same arithmetic, in the same order, as the numpy path's
    :class:`lgvtool.localize.resampling.RedistributionDraws` and ``apply_packed``, except the
    turn's rotor for small angles (:func:`_rotor`: within an ulp). ``work``:
    :func:`paper_scratch`."""
    ess = _spread(s, w, sums, cov, work)
    _redistribute(s, top, u, plan, out, work)
    return ess


@_jit
def _spread(s: ComplexArray, w: FloatArray, sums: FloatArray, cov: FloatArray,
            work: FloatArray) -> float:
    """The covariance (into ``cov``) and ESS of :func:`paper_resample`. Particles in chunks
    laid out as separate arrays (the arithmetic in SIMD registers); the sums in order."""
    m = s.shape[0]
    total = sums[4]
    mean = complex(sums[0], sums[1]) / total
    mr, mi = mean.real, mean.imag
    rc = complex(sums[2], sums[3]).conjugate()
    cr, ci = rc.real, rc.imag
    a00 = a01 = a02 = a11 = a12 = a22 = 0.0
    sw2 = 0.0
    zr, zi, rr, ri, hh = work[0], work[1], work[2], work[3], work[4]
    p00, p01, p02, p11, p12, p22, pww = work[5], work[6], work[7], work[8], work[9], \
        work[10], work[11]
    # 1 for the particles whose heading deviation the series does not give (a flag row: with
    # the test in the loop below, the series loop no longer runs in SIMD registers)
    other = work[12]
    for a in range(0, m, _CHUNK):
        n = min(_CHUNK, m - a)
        for i in range(n):
            z = s[a + i, 0]
            r = s[a + i, 1]
            zr[i] = z.real
            zi[i] = z.imag
            rr[i] = r.real
            ri[i] = r.imag
        for i in range(n):
            # the heading deviation from the rotor relative to the circular mean (the complex
            # product), by the series (:func:`_heading`); its other case below
            yr = rr[i] * cr - ri[i] * ci
            yi = rr[i] * ci + ri[i] * cr
            hh[i] = _atan_series(yi / yr)
            other[i] = 0.0 if yr > 0.0 and abs(yi) < _SMALL_ANGLE * yr else 1.0
        for i in range(n):
            if other[i] != 0.0:
                yr = rr[i] * cr - ri[i] * ci
                yi = rr[i] * ci + ri[i] * cr
                hh[i] = math.atan2(yi, yr)
        for i in range(n):
            wn = w[a + i] / total
            dx = zr[i] - mr
            dy = zi[i] - mi
            h = hh[i]
            p00[i] = dx * wn * dx
            p01[i] = dx * wn * dy
            p02[i] = dx * wn * h
            p11[i] = dy * wn * dy
            p12[i] = dy * wn * h
            p22[i] = h * wn * h
            pww[i] = wn * wn
        for i in range(n):
            a00 += p00[i]
            a01 += p01[i]
            a02 += p02[i]
            a11 += p11[i]
            a12 += p12[i]
            a22 += p22[i]
            sw2 += pww[i]
    _symmetric(cov, a00, a01, a02, a11, a12, a22)
    return 1.0 / sw2


@_jit
def _redistribute(s: ComplexArray, top: IntArray, u: FloatArray, plan: FloatArray,
                  out: ComplexArray, work: FloatArray) -> None:
    """The redistribution of :func:`paper_resample`: the local particles' offsets and turns
    in chunks (SIMD), then their parents."""
    m = out.shape[0]
    wx, wy, wh, lx, ly, lh = plan[0], plan[1], plan[2], plan[3], plan[4], plan[5]
    fx, fy, fh, gx, gy, gh = plan[6], plan[7], plan[8], plan[9], plan[10], plan[11]
    cx, cy = plan[12], plan[13]
    n_top = int(plan[14])
    n_local = int(plan[15])
    ox, oy, oh, tc, ts = work[0], work[1], work[2], work[3], work[4]
    for a in range(0, n_local, _CHUNK):
        n = min(_CHUNK, n_local - a)
        for i in range(n):
            ox[i] = u[1, a + i] * wx + lx
            oy[i] = u[2, a + i] * wy + ly
            x = u[3, a + i] * wh + lh
            oh[i] = x
            # the turn's rotor by the series (:func:`_rotor`), its other case below
            tc[i] = _cos_series(x)
            ts[i] = _sin_series(x)
        for i in range(n):
            src = top[int(u[0, a + i] * n_top)]
            z = s[src, 0]
            # z (1 + 0i) + shift: the numpy path's product by the scale, then the shift
            out[a + i, 0] = complex(z.real * 1.0 - z.imag * 0.0, z.real * 0.0 + z.imag * 1.0) \
                + complex(ox[i], oy[i])
            x = oh[i]
            turn = complex(tc[i], ts[i]) if abs(x) < _SMALL_ANGLE else \
                complex(math.cos(x), math.sin(x))
            out[a + i, 1] = s[src, 1] * turn + 0j
    for i in range(n_local, m):
        px = u[1, i] * fx + gx
        py = u[2, i] * fy + gy
        out[i, 0] = complex(px + cx, py + cy)
        out[i, 1] = _rotor(u[3, i] * fh + gh)


# ---------------------------------------------------------------------------- pf
@_jit
def pf_predict(z: ComplexArray, th: FloatArray, rot: ComplexArray, g: FloatArray, dx: float,
               dy: float, dth: float, sa: float, sl: float, st: float, z_out: ComplexArray,
               th_out: FloatArray, rot_out: ComplexArray) -> None:
    """Eq. 9 with motion noise: particle ``i`` moved by ``(dx + sa g[0, i], dy + sl g[1, i])``
    (m, its body frame) and turned by ``dth + st g[2, i]`` (rad), ``g`` the standard normal
    numbers the numpy path draws; the heading wrapped to [-pi, pi) as the numpy path does.
    The rotor is turned by the turn's own rotor (:func:`_rotor`) instead of being made anew
    from the heading (the same to an ulp per step).

    The first loop takes every particle down the common branches of :func:`_wrap_pi` and
    :func:`_rotor` (no call: it is vectorised) and marks those that need the others (a heading
    leaving [-pi, pi) or a turn of 0.05 rad or more), which the second loop does again with
    the two functions: the same numbers as calling them for every particle."""
    n = z.shape[0]
    other = np.empty(n, dtype=np.bool_)
    for i in range(n):
        ddx = dx + sa * g[0, i]
        ddy = dy + sl * g[1, i]
        ddth = dth + st * g[2, i]
        r = rot[i]
        z_out[i] = z[i] + r * complex(ddx, ddy)
        a = (th[i] + ddth) + math.pi
        w = a - math.pi
        th_out[i] = w + _TWO_PI if w <= -math.pi else w
        x2 = ddth * ddth
        c = 1.0 - x2 * (0.5 - x2 * (1.0 / 24.0 - x2 * (1.0 / 720.0 - x2 * (
            1.0 / 40320.0 - x2 * (1.0 / 3628800.0)))))
        sn = ddth * (1.0 - x2 * (1.0 / 6.0 - x2 * (1.0 / 120.0 - x2 * (1.0 / 5040.0 - x2 * (
            1.0 / 362880.0)))))
        rot_out[i] = r * complex(c, sn)
        other[i] = not (0.0 <= a < _TWO_PI) or not (abs(ddth) < _SMALL_ANGLE)
    for i in range(n):
        if other[i]:
            ddth = dth + st * g[2, i]
            th_out[i] = _wrap_pi(th[i] + ddth)
            rot_out[i] = rot[i] * _rotor(ddth)


@_jit
def pf_predict_drawn(rng: np.random.Generator, z: ComplexArray, th: FloatArray,
                     rot: ComplexArray, dx: float, dy: float, dth: float, sa: float,
                     sl: float, st: float, z_out: ComplexArray, th_out: FloatArray,
                     rot_out: ComplexArray) -> None:
    """:func:`pf_predict` with its normal numbers drawn here from ``rng``: the numpy path's
    ``rng.standard_normal((3, n))`` (numba's generator methods give the same numbers and
    leave the generator in the same state, in a third of the time; handing the generator in
    costs a few microseconds, so the filter does this for large sets only)."""
    g = rng.standard_normal((3, z.shape[0]))
    pf_predict(z, th, rot, g, dx, dy, dth, sa, sl, st, z_out, th_out, rot_out)


#: ``1 + exp(-t)`` is 1 in double precision beyond this ``t``
_EXP_NEGLIGIBLE = 38.0
#: points weighed per block of :func:`pf_scan_loglik` (the product of the mixture factors, at
#: most 2 each, is taken as a logarithm once per block)
_POINTS = 512


@_jit
def _ray_loglik(ex: float, ey: float, rr: float, ri: float, ucr: float, uci: float,
                inv_sr: float, inv_st: float, const: float) -> float:
    """The Gaussian log-likelihood of a residual ``(ex, ey)`` (world frame, m) split along
    and across its ray: the residual times ``conj(rot) conj(u)`` (``rot = rr + i ri``,
    ``conj(u) = ucr + i uci``), the numpy path's products in its order, scaled by the
    reciprocal standard deviations (1/m; the numpy path divides: within an ulp)."""
    wr = rr * ucr + ri * uci
    wi = rr * uci - ri * ucr
    a = (ex * wr - ey * wi) * inv_sr
    b = (ex * wi + ey * wr) * inv_st
    return -0.5 * (a * a + b * b) - const


#: an intrinsic's code generator: the target context, the LLVM IR builder, the signature and the
#: arguments' LLVM values, giving the result's LLVM value
_Codegen = Callable[["BaseContext", llvm_ir.IRBuilder, "Signature", Sequence[llvm_ir.Value]],
                    llvm_ir.Value]


def _pow2_typing(typingctx: Context, k: numba.types.Type) -> tuple[Signature, _Codegen]:
    """``2.0 ** k`` for an integer ``-1022 <= k <= 1023``, made from its bits (a shift, no
    call: the loops that use it stay vectorised)."""
    sig = numba.types.float64(numba.types.int64)

    def codegen(context: BaseContext, builder: llvm_ir.IRBuilder, signature: Signature,
                args: Sequence[llvm_ir.Value]) -> llvm_ir.Value:
        i64 = llvm_ir.IntType(64)
        bits = builder.shl(builder.add(args[0], llvm_ir.Constant(i64, 1023)),
                           llvm_ir.Constant(i64, 52))
        return builder.bitcast(bits, llvm_ir.DoubleType())

    return sig, codegen


_pow2 = cast(Callable[[int], float], numba.extending.intrinsic(_pow2_typing))

#: :func:`_exp_neg` holds up to this argument (``exp(-708)`` is near the smallest normal
#: double)
_EXP_SMALLEST = 708.0

#: ``log 2`` split in two for the range reduction of :func:`_exp_neg` (the high part has
#: trailing zero bits, so ``k * _LN2_HI`` is exact for the ``k`` used)
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e+00


@_jit
def _exp_neg(t: float) -> float:
    """``exp(-t)`` for ``0 <= t <= 708`` (:data:`_EXP_SMALLEST`) without a library call, so
    that the loops over the particles are vectorised: ``t = k log 2 - r`` with ``|r| <= log(2) /
    2``, ``exp(r)`` from its Taylor series to the 13th order (truncation below 1e-17), times
    ``2 ** -k``. Within 1.2e-16 relative of ``math.exp`` (an ulp)."""
    k = math.floor(t * _INV_LN2 + 0.5)
    r = (k * _LN2_HI - t) + k * _LN2_LO
    p = 1.0 / 6227020800.0
    p = 1.0 / 479001600.0 + r * p
    p = 1.0 / 39916800.0 + r * p
    p = 1.0 / 3628800.0 + r * p
    p = 1.0 / 362880.0 + r * p
    p = 1.0 / 40320.0 + r * p
    p = 1.0 / 5040.0 + r * p
    p = 1.0 / 720.0 + r * p
    p = 1.0 / 120.0 + r * p
    p = 1.0 / 24.0 + r * p
    p = 1.0 / 6.0 + r * p
    p = 0.5 + r * p
    p = 1.0 + r * p
    p = 1.0 + r * p
    return p * _pow2(-k)


@_jit
def _mixture(v: float, log_in: float, log_out: float) -> tuple[float, float]:
    """``logaddexp(log_in + v, log_out)`` as ``(max, factor)``: the sum is
    ``max + log(factor)``, ``factor = 1 + exp(-|difference|)`` in [1, 2]."""
    x = log_in + v
    if x >= log_out:
        top = x
        t = x - log_out
    else:
        top = log_out
        t = log_out - x
    return top, 1.0 + _exp_neg(min(t, _EXP_NEGLIGIBLE))


@_jit
def pf_scan_loglik(z: ComplexArray, rot: ComplexArray, q: ComplexArray, u_conj: ComplexArray,
                   cand: ComplexArray, half: FloatArray, map_z: ComplexArray,
                   sr: FloatArray, st: FloatArray, const: FloatArray, outlier: bool,
                   log_in: float, log_out: float, ll: FloatArray, g2: FloatArray,
                   jid: IntArray, ratio2: float, log_pen: float) -> None:
    """Log-likelihood of a scan for every particle (into ``ll``): each measured point ``q[k]``
    (body frame, m) put into the world and associated
    (:func:`lgvtool.localize.association.associate` per particle, in squared metres): the
    candidate ``cand[k]`` when nearer than ``half[k]`` (for a point with an id, ``jid[k] >= 0``,
    the id's reflector and the gate radius; otherwise a radius within which the candidate is
    provably the nearest, inside the gate and unambiguous), else by a search of ``map_z``: the
    nearest inside the gate (squared radius ``g2[k]``, m^2) unless the second is inside it too
    and nearer than ``ratio2`` times the squared distance of the nearest; its residual split
    along and across the ray (``u_conj``: the conjugate unit ray, body frame), a Gaussian with
    ``sr[k]``, ``st[k]`` (m) and the constant ``const[k]`` (``log 2 pi + log sr + log st``);
    with ``outlier``, the mixture ``logaddexp(log_in + ll, log_out)``; a point with nothing
    (unambiguous) inside the gate counts ``log_out``, and a point with an id associated with
    another reflector adds ``log_pen``; summed over the points.

    The mixture's sum is taken as ``sum max(a, b) + log prod (1 + exp(-|a - b|))``: one
    exponential per point and one logarithm per particle instead of an
    exponential and a ``log1p`` per point (the same value to about 1e-15 per point). The
    particles go in chunks laid out as separate arrays (SIMD); a particle with a point not
    provably nearest its candidate is weighed again alone, searching the map for it."""
    m = z.shape[0]
    k = q.shape[0]
    zr, zi, rr, ri, tot, prod, far = _chunk_arrays()
    half2 = half * half
    inv_sr = 1.0 / sr
    inv_st = 1.0 / st
    for a in range(0, m, _CHUNK):
        n = min(_CHUNK, m - a)
        for i in range(n):
            zr[i] = z[a + i].real
            zi[i] = z[a + i].imag
            rr[i] = rot[a + i].real
            ri[i] = rot[a + i].imag
            tot[i] = 0.0
            prod[i] = 1.0
            far[i] = -math.inf
        for j0 in range(0, k, _POINTS):
            for j in range(j0, min(k, j0 + _POINTS)):
                qr = q[j].real
                qi = q[j].imag
                cr = cand[j].real
                ci = cand[j].imag
                h2 = half2[j]
                ucr = u_conj[j].real
                uci = u_conj[j].imag
                sj = inv_sr[j]
                tj = inv_st[j]
                cj = const[j]
                for i in range(n):
                    ex = cr - (zr[i] + (rr[i] * qr - ri[i] * qi))
                    ey = ci - (zi[i] + (rr[i] * qi + ri[i] * qr))
                    far[i] = max(far[i], ex * ex + ey * ey - h2)
                    v = _ray_loglik(ex, ey, rr[i], ri[i], ucr, uci, sj, tj, cj)
                    if outlier:
                        top, f = _mixture(v, log_in, log_out)
                        tot[i] += top
                        prod[i] *= f
                    else:
                        tot[i] += v
            if outlier:
                for i in range(n):
                    tot[i] += math.log(prod[i])
                    prod[i] = 1.0
        for i in range(n):
            if far[i] >= 0.0:
                tot[i] = _particle_loglik(zr[i], zi[i], rr[i], ri[i], q, u_conj, cand, half2,
                                          map_z, inv_sr, inv_st, const, outlier, log_in,
                                          log_out, g2, jid, ratio2, log_pen)
            ll[a + i] = tot[i]


@_jit
def _nearest_two(px: float, py: float, map_z: ComplexArray) -> tuple[int, float, float]:
    """The map reflector nearest to ``(px, py)`` (m; the first of equals, as ``np.argmin``),
    its squared distance and the squared distance of the second nearest (m^2; infinite for a
    map of one)."""
    best = math.inf
    second = math.inf
    j = 0
    for r in range(map_z.shape[0]):
        ex = map_z[r].real - px
        ey = map_z[r].imag - py
        d2 = ex * ex + ey * ey
        if d2 < best:
            second = best
            best = d2
            j = r
        elif d2 < second:
            second = d2
    return j, best, second


@_jit
def _particle_loglik(zr: float, zi: float, rr: float, ri: float, q: ComplexArray,
                     u_conj: ComplexArray, cand: ComplexArray, half2: FloatArray,
                     map_z: ComplexArray, inv_sr: FloatArray, inv_st: FloatArray,
                     const: FloatArray, outlier: bool, log_in: float, log_out: float,
                     g2: FloatArray, jid: IntArray, ratio2: float, log_pen: float) -> float:
    """:func:`pf_scan_loglik` for one particle, searching the map for the points whose
    candidate does not hold (the same arithmetic in the same order)."""
    total = 0.0
    prod = 1.0
    for j0 in range(0, q.shape[0], _POINTS):
        for j in range(j0, min(q.shape[0], j0 + _POINTS)):
            px = zr + (rr * q[j].real - ri * q[j].imag)
            py = zi + (rr * q[j].imag + ri * q[j].real)
            ex = cand[j].real - px
            ey = cand[j].imag - py
            pen = 0.0
            dropped = False
            if ex * ex + ey * ey - half2[j] >= 0.0:
                r, d1, d2nd = _nearest_two(px, py, map_z)
                if not d1 < g2[j] or (d2nd < g2[j] and d2nd < ratio2 * d1):
                    dropped = True
                else:
                    ex = map_z[r].real - px
                    ey = map_z[r].imag - py
                    if jid[j] >= 0 and r != jid[j]:
                        pen = log_pen
            if dropped:
                v = -math.inf if outlier else log_out
            else:
                v = _ray_loglik(ex, ey, rr, ri, u_conj[j].real, u_conj[j].imag, inv_sr[j],
                                inv_st[j], const[j])
            if outlier:
                top, f = _mixture(v, log_in, log_out)
                total += top + pen
                prod *= f
            else:
                total += v + pen
        if outlier:
            total += math.log(prod)
            prod = 1.0
    return total


@_jit
def weighted_pose(z: ComplexArray, rot: ComplexArray, w: FloatArray, cov: FloatArray
                  ) -> tuple[float, float, float]:
    """Weighted mean pose (x, y m; heading rad, the circular mean) of particles with
    normalised weights ``w``, and their covariance of ``(x, y, heading)`` (into ``cov``; the
    heading deviations from the circular mean)."""
    mz = 0j
    mr = 0j
    for i in range(z.shape[0]):
        mz += w[i] * z[i]
        mr += w[i] * rot[i]
    return _pose_spread(z, rot, w, mz, mr, cov)


@_jit
def _pose_spread(z: ComplexArray, rot: ComplexArray, w: FloatArray, mz: complex, mr: complex,
                 cov: FloatArray) -> tuple[float, float, float]:
    """:func:`weighted_pose` from the weighted sums ``mz`` of the positions (m) and ``mr`` of
    the rotors."""
    mrc = mr.conjugate()
    # the heading deviations: the common branch of :func:`_heading` in a vectorised loop,
    # the others again with the function (the same numbers)
    n = z.shape[0]
    hs = np.empty(n)
    other = np.empty(n, dtype=np.bool_)
    for i in range(n):
        r = rot[i] * mrc
        u = r.imag / r.real
        u2 = u * u
        hs[i] = u * (1.0 - u2 * (1.0 / 3.0 - u2 * (1.0 / 5.0 - u2 * (1.0 / 7.0 - u2 * (
            1.0 / 9.0 - u2 * (1.0 / 11.0 - u2 * (1.0 / 13.0)))))))
        other[i] = not (r.real > 0.0 and abs(r.imag) < _SMALL_ANGLE * r.real)
    for i in range(n):
        if other[i]:
            r = rot[i] * mrc
            hs[i] = _heading(r.imag, r.real)
    sxx = sxy = syy = sxh = syh = shh = 0.0
    for i in range(n):
        d = z[i] - mz
        h = hs[i]
        wi = w[i]
        sxx += wi * d.real * d.real
        sxy += wi * d.real * d.imag
        syy += wi * d.imag * d.imag
        sxh += wi * d.real * h
        syh += wi * d.imag * h
        shh += wi * h * h
    _symmetric(cov, sxx, sxy, sxh, syy, syh, shh)
    return mz.real, mz.imag, math.atan2(mr.imag, mr.real)


@_jit
def pf_weigh(logw: FloatArray, ll: FloatArray, z: ComplexArray, rot: ComplexArray,
             w: FloatArray, logw_out: FloatArray, cov: FloatArray
             ) -> tuple[float, float, float, float, float]:
    """Log weights times the likelihoods ``ll``, normalised by log-sum-exp (``w`` normalised,
    ``logw_out``), and then, when some weight is left, :func:`weighted_pose` of the new
    weights (its first sums taken in the normalising pass). Returns the log of the weighted
    mean likelihood ``log sum w p``, the effective sample size ``1 / sum w^2`` and the mean
    pose (x, y m, heading rad; its covariance into ``cov``); ``-inf, 0, 0, 0, 0`` (nothing
    written but ``logw_out``) when every log weight is -inf."""
    n = logw.shape[0]
    top = -math.inf
    for i in range(n):
        v = logw[i] + ll[i]
        logw_out[i] = v
        if v > top:
            top = v
    if not math.isfinite(top):
        return -math.inf, 0.0, 0.0, 0.0, 0.0
    for i in range(n):
        # (vectorised: no call; the weights below exp(-708) relative to the best, which
        # no sum or estimate can see, are 0)
        t = top - logw_out[i]
        e = _exp_neg(min(t, _EXP_SMALLEST))
        w[i] = 0.0 if t > _EXP_SMALLEST else e
    total = 0.0
    for i in range(n):
        total += w[i]
    log_avg = top + math.log(total)
    sw2 = 0.0
    mz = 0j
    mr = 0j
    for i in range(n):
        wi = w[i] / total
        w[i] = wi
        sw2 += wi * wi
        logw_out[i] = logw_out[i] - log_avg
        mz += wi * z[i]
        mr += wi * rot[i]
    x, y, t = _pose_spread(z, rot, w, mz, mr, cov)
    return log_avg, 1.0 / sw2, x, y, t


@_jit
def low_variance_gather(w: FloatArray, u0: float, n: int, z: ComplexArray, th: FloatArray,
                        rot: ComplexArray, z_out: ComplexArray, th_out: FloatArray,
                        rot_out: ComplexArray, idx: IntArray, wrap: bool) -> None:
    """Low-variance resampling of ``n`` particles from the normalised weights ``w`` with the
    offset ``u0`` (the numpy path's ``rng.random()``), in one merge over the cumulative
    weights (the indices of ``searchsorted(c, (u0 + i) / n, 'right')``, into ``idx``), and the
    copy of the chosen particles (with ``wrap``, the heading wrapped again as the numpy path
    does, the rotor the parent's)."""
    _low_variance_indices(w, u0, idx[:n])
    for i in range(n):
        j = idx[i]
        z_out[i] = z[j]
        th_out[i] = _wrap_pi(th[j]) if wrap else th[j]
        rot_out[i] = rot[j]


@_jit
def _low_variance_indices(w: FloatArray, u0: float, idx: IntArray) -> None:
    """Low-variance resampling's ``len(idx)`` indices from the normalised weights ``w`` and
    the offset ``u0``, in one merge over the cumulative weights (the indices of
    ``searchsorted(c, (u0 + i) / n, 'right')``, the last cumulative weight taken as 1)."""
    n = idx.shape[0]
    m = w.shape[0]
    j = 0
    c = w[0] if m > 1 else 1.0
    for i in range(n):
        u = (u0 + i) / n
        while j < m - 1 and not (c > u):
            j += 1
            c = c + w[j] if j < m - 1 else 1.0
        idx[i] = j


#: ``log(2 pi)``, the 2-D Gaussian's normalising constant
_LOG_2PI = math.log(2.0 * math.pi)


@_jit
def pf_scan(z: ComplexArray, rot: ComplexArray, q: ComplexArray, u: ComplexArray,
            ranges: FloatArray, j: IntArray, ref_z: complex, ref_rot: complex,
            map_z: ComplexArray, half_sep: FloatArray, sigma_range: float, sigma_range2: float,
            sigma_range_per_m: float, sigma_bearing: float, use_ids: bool, outlier: bool,
            log_in: float, log_out: float, ll: FloatArray, gate_root: float, ratio: float,
            log_pen: float) -> None:
    """:func:`pf_scan_loglik` with its per-point inputs made here, as the numpy path makes
    them: each point's candidate (the map reflector of its id ``j[k]`` when known, else the
    one nearest to the point seen from the reference pose ``ref_z``, ``ref_rot``), the range
    and across-ray standard deviations from ``ranges`` (m; ``sigma_range`` m, its square
    ``sigma_range2``, ``sigma_range_per_m`` m/m, ``sigma_bearing`` rad), the Gaussians'
    constants ``log 2 pi + log sr + log st``, the gate radius ``gate_root`` times the larger
    standard deviation (m) and the candidate's radius: the gate radius for a point with an id
    (with ``use_ids``), else the radius within which the candidate is provably the nearest,
    inside the gate and unambiguous with the ambiguity ``ratio``
    (:func:`lgvtool.localize.association.safe_radius`)."""
    k = q.shape[0]
    cand = np.empty(k, dtype=np.complex128)
    half = np.empty(k)
    sr = np.empty(k)
    st = np.empty(k)
    const = np.empty(k)
    u_conj = np.empty(k, dtype=np.complex128)
    g2 = np.empty(k)
    jid = np.empty(k, dtype=np.intp)
    for p in range(k):
        jp = j[p]
        c = jp if jp >= 0 else _nearest_index(ref_z + ref_rot * q[p], map_z)
        cand[p] = map_z[c]
        r = ranges[p]
        if sigma_range_per_m > 0.0:
            e = sigma_range_per_m * r
            sr[p] = math.sqrt(sigma_range2 + e * e)
        else:
            sr[p] = sigma_range
        b = r * sigma_bearing
        st[p] = math.sqrt(b * b + 1e-12)
        const[p] = _LOG_2PI + math.log(sr[p]) + math.log(st[p])
        u_conj[p] = u[p].conjugate()
        g = gate_root * max(sr[p], st[p])
        g2[p] = g * g
        if use_ids and jp >= 0:
            jid[p] = jp
            half[p] = g
        else:
            jid[p] = -1
            h = half_sep[c]
            half[p] = max(min(min(h, g), max(2.0 * h - g, 2.0 * h / (1.0 + ratio))), 0.0)
    pf_scan_loglik(z, rot, q, u_conj, cand, half, map_z, sr, st, const, outlier, log_in,
                   log_out, ll, g2, jid, ratio * ratio, log_pen)


@_jit
def _bin_key(x: float, y: float, th: float, bin_xy: float, bin_th: float) -> int:
    """:func:`lgvtool.localize.kld.bin_keys` of one pose (m, m, rad)."""
    ix = math.floor(x / bin_xy)
    iy = math.floor(y / bin_xy)
    it = math.floor((th + math.pi) / bin_th)
    return (ix * 1_000_003 + iy) * 4099 + it


@_jit
def pf_kld_resample(w: FloatArray, u0: float, perm: IntArray, need: FloatArray, n_min: int,
                    bin_xy: float, bin_th: float, z: ComplexArray, th: FloatArray,
                    rot: ComplexArray, z_out: ComplexArray, th_out: FloatArray,
                    rot_out: ComplexArray, idx: IntArray) -> int:
    """Low-variance resampling of ``len(perm)`` particles from the normalised weights ``w``
    with the offset ``u0`` (as :func:`low_variance_gather`), taken in the order of the
    permutation ``perm`` (the numpy path's ``rng.permutation``), and KLD-sampling's count
    (:func:`lgvtool.localize.kld.kld_count`): the first ``n`` draws whose histogram bins
    (``bin_xy`` m, ``bin_th`` rad) number ``k`` with ``n >= max(need[k - 1], n_min)``
    (``need``: :func:`~lgvtool.localize.kld.kld_bound` of 1, 2, ... bins), at least
    ``n_min``. The chosen particles are copied into the first ``n`` entries of the outputs
    (their indices into ``idx``; the heading wrapped again as the numpy path does, the rotor
    the parent's); returns ``n``."""
    cap = perm.shape[0]
    lv = np.empty(cap, dtype=np.intp)
    _low_variance_indices(w, u0, lv)
    size = 1
    while size < 2 * cap:
        size *= 2
    mask = size - 1
    keys = np.empty(size, dtype=np.int64)
    used = np.zeros(size, dtype=np.bool_)
    bins = 0
    chosen = cap
    for i in range(cap):
        s = lv[perm[i]]
        key = _bin_key(z[s].real, z[s].imag, th[s], bin_xy, bin_th)
        h = ((key ^ (key >> 29)) * 0x5851F42D4C957F2D) & mask
        while used[h] and keys[h] != key:
            h = (h + 1) & mask
        if not used[h]:
            used[h] = True
            keys[h] = key
            bins += 1
        if i + 1 >= max(need[bins - 1], n_min):
            chosen = i + 1
            break
    n = min(max(chosen, n_min), cap)
    for i in range(n):
        s = lv[perm[i]]
        idx[i] = s
        z_out[i] = z[s]
        th_out[i] = _wrap_pi(th[s])
        rot_out[i] = rot[s]
    return int(n)


# ---------------------------------------------------------------------------- pf, a run of scans
#: why :func:`pf_track` returned: every observation of the chunk done
TRACK_DONE = 0
#: observation ``j`` needs the filter's own step (not a scan)
TRACK_STEP = 1
#: observation ``j`` moved and weighed; its resampling may re-draw particles (recovery), which
#: the filter does itself
TRACK_RESAMPLE = 2
#: the row of observation ``j - 1`` recorded and a particle cloud due
TRACK_CLOUD = 3

#: entries of :func:`pf_track`'s ``state``: the likelihood averages, whether they were
#: updated, the last ESS, the reference pose (a flag, x m, y m, heading rad), the cached
#: estimate (a flag, x m, y m, heading rad, its covariance row-major), the resamplings done and
#: the last update's log-likelihood per measurement
ST_SLOW, ST_FAST, ST_TRACKED, ST_ESS = 0, 1, 2, 3
ST_REF = 4
ST_CACHED = 8
ST_RESAMPLINGS = 21
ST_PER_OBS = 22
ST_SIZE = 23


@_jit
def _permutation(rng: np.random.Generator, n: int) -> IntArray:
    """``rng.permutation(n)`` for ``n < 2^32``: the same numbers, drawn the same way (NumPy's
    Fisher-Yates shuffle of ``arange(n)`` from the end, each index by ``random_interval``:
    the masked 32-bit draws of the bit generator, rejected above the bound), in a sixth of the
    time of numba's own method (which swaps through array views)."""
    p = np.arange(n)
    bg = rng.bit_generator
    for i in range(n - 1, 0, -1):
        bound = np.uint64(i)
        mask = bound
        for shift in (1, 2, 4, 8, 16, 32):
            mask |= mask >> np.uint64(shift)
        v = np.uint64(_next_uint32(bg)) & mask
        while v > bound:
            v = np.uint64(_next_uint32(bg)) & mask
        j = np.intp(v)
        t = p[i]
        p[i] = p[j]
        p[j] = t
    return p


@_jit
def _motion_step(rng: np.random.Generator, z: ComplexArray, th: FloatArray, rot: ComplexArray,
                 dx: float, dy: float, dth: float, sa: float, sl: float, st: float,
                 z_out: ComplexArray, th_out: FloatArray, rot_out: ComplexArray) -> None:
    """``pf``'s prediction of one motion (body frame: ``dx``, ``dy`` m, ``dth`` rad; noise
    ``sa``, ``sl`` m, ``st`` rad) from ``z``, ``th``, ``rot`` into the outputs: with noise
    :func:`pf_predict` with the numpy path's ``rng.standard_normal((3, n))``; without, the
    numpy path's noise-free step (the headings not wrapped)."""
    n = z.shape[0]
    if sa != 0.0 or sl != 0.0 or st != 0.0:
        g = rng.standard_normal((3, n))
        pf_predict(z, th, rot, g, dx, dy, dth, sa, sl, st, z_out, th_out, rot_out)
        return
    step = complex(dx, dy)
    turn = complex(math.cos(dth), math.sin(dth))
    for i in range(n):
        z_out[i] = z[i] + rot[i] * step
        th_out[i] = th[i] + dth
        rot_out[i] = rot[i] * turn


@_jit
def _reference(state: FloatArray, z: ComplexArray, th: FloatArray, w: FloatArray
               ) -> tuple[float, float, float]:
    """The reference pose of the association (x m, y m, heading rad): the state's, else the
    heaviest particle's (the first of equals, as ``np.argmax``)."""
    if state[ST_REF] != 0.0:
        return state[ST_REF + 1], state[ST_REF + 2], state[ST_REF + 3]
    best = 0
    for i in range(w.shape[0]):
        if w[i] > w[best]:
            best = i
    return z[best].real, z[best].imag, th[best]


@_jit
def _cache(state: FloatArray, x: float, y: float, t: float, cov: FloatArray) -> None:
    """Store the estimate (x, y m, heading rad, covariance 3 x 3) in ``state``."""
    state[ST_CACHED] = 1.0
    state[ST_CACHED + 1] = x
    state[ST_CACHED + 2] = y
    state[ST_CACHED + 3] = t
    for r in range(3):
        for c in range(3):
            state[ST_CACHED + 4 + 3 * r + c] = cov[r, c]


@_jit
def pf_track(rng: np.random.Generator, z: ComplexArray, th: FloatArray, rot: ComplexArray,
             w: FloatArray, logw: FloatArray, cap: int, state: FloatArray,
             kinds: NDArray[np.int8], offs: IntArray, q: ComplexArray, u: ComplexArray,
             ranges: FloatArray, jidx: IntArray, j0: int, i0: int, moving: bool,
             times: FloatArray, mdx: FloatArray, mdy: FloatArray, mdth: FloatArray,
             msa: FloatArray, msl: FloatArray, mst: FloatArray, map_z: ComplexArray,
             half_sep: FloatArray, prm: FloatArray, flags: IntArray, need: FloatArray,
             next_cloud: float, rows_t: FloatArray, rows_x: FloatArray, rows_y: FloatArray,
             rows_h: FloatArray, rows_cov: FloatArray, rows_n: IntArray, rows_ess: FloatArray,
             k: int) -> tuple[int, int, int, ComplexArray, FloatArray, ComplexArray,
                              FloatArray, FloatArray]:
    """``pf``'s predict, update and estimate over a chunk of observations in one call, from
    chunk entry ``j0`` (observation ``i0 + j0`` of the run): the same steps, with the same
    random numbers drawn from ``rng`` in the same order, as the filter's ``predict``,
    ``update`` (reflector scans; log weights, low-variance resampling with or without
    KLD-sampling, recovery's likelihood averages) and ``estimate``.

    Chunk entry ``j``: ``kinds[j]`` 0 (no observation: only move), 1 (a scan: points
    ``offs[j]:offs[j + 1]`` of ``q``, ``u`` (body frame), ``ranges`` (m) and ``jidx`` (map
    index, -1 unknown)) or 2 (anything else: returns :data:`TRACK_STEP`). The motion into
    observation ``i`` is entry ``i - 1`` of ``mdx``, ``mdy`` (m), ``mdth`` (rad) and of its
    noise ``msa``, ``msl`` (m), ``mst`` (rad) when ``moving``. ``prm``: sigma_range,
    its square, sigma_range_per_m, sigma_bearing, the outlier mixture's two log weights,
    alpha_slow, alpha_fast, reset_likelihood, ess_threshold, the KLD bins (m, rad), the
    association's gate root, ambiguity ratio and id-mismatch log weight (:func:`pf_scan`);
    ``flags``: use_ids, outlier, recovery, resample always, kld, min_particles, particles;
    ``need``: KLD's bound for 1 to ``cap`` bins; ``state``:
    :data:`ST_SIZE` entries, read and updated. Each estimate is written as row ``k`` on of the
    ``rows_*`` arrays (time s, pose m m rad, covariance row-major, count, ESS).

    Returns why it stopped (``TRACK_*``), the chunk entry to go on with, the next row and the
    particles and weights (``z``, ``th``, ``rot``, ``w``, ``logw``, new arrays)."""
    size = max(cap, z.shape[0])
    n = z.shape[0]
    za, zb = np.empty(size, dtype=np.complex128), np.empty(size, dtype=np.complex128)
    ra, rb = np.empty(size, dtype=np.complex128), np.empty(size, dtype=np.complex128)
    tha, thb = np.empty(size), np.empty(size)
    wa, wb = np.empty(size), np.empty(size)
    la, lb = np.empty(size), np.empty(size)
    idx = np.empty(size, dtype=np.intp)
    ll = np.empty(size)
    cov = np.empty((3, 3))
    za[:n] = z
    ra[:n] = rot
    tha[:n] = th
    wa[:n] = w
    la[:n] = logw
    use_ids = flags[0] != 0
    outlier = flags[1] != 0
    recovery = flags[2] != 0
    always = flags[3] != 0
    kld = flags[4] != 0
    n_min = flags[5]
    particles = flags[6]
    status = TRACK_DONE
    j = j0
    while j < kinds.shape[0]:
        kind = kinds[j]
        if kind == 2:
            status = TRACK_STEP
            break
        i = i0 + j
        if i > 0 and moving:
            s = i - 1
            _motion_step(rng, za[:n], tha[:n], ra[:n], mdx[s], mdy[s], mdth[s], msa[s],
                         msl[s], mst[s], zb[:n], thb[:n], rb[:n])
            za, zb = zb, za
            tha, thb = thb, tha
            ra, rb = rb, ra
            if state[ST_REF] != 0.0:
                x = state[ST_REF + 1]
                y = state[ST_REF + 2]
                t = state[ST_REF + 3]
                c0 = math.cos(t)
                s0 = math.sin(t)
                state[ST_REF + 1] = x + c0 * mdx[s] - s0 * mdy[s]
                state[ST_REF + 2] = y + s0 * mdx[s] + c0 * mdy[s]
                state[ST_REF + 3] = t + mdth[s]
            state[ST_CACHED] = 0.0
        a = offs[j]
        b = offs[j + 1]
        if kind == 1 and b > a:
            rx, ry, rt = _reference(state, za[:n], tha[:n], wa[:n])
            pf_scan(za[:n], ra[:n], q[a:b], u[a:b], ranges[a:b], jidx[a:b], complex(rx, ry),
                    complex(math.cos(rt), math.sin(rt)), map_z, half_sep, prm[0], prm[1],
                    prm[2], prm[3], use_ids, outlier, prm[4], prm[5], ll[:n], prm[12],
                    prm[13], prm[14])
            log_avg, ess, x, y, t = pf_weigh(la[:n], ll[:n], za[:n], ra[:n], wb[:n], lb[:n],
                                             cov)
            if math.isfinite(log_avg):
                wa, wb = wb, wa
                la, lb = lb, la
                per_obs = log_avg / (b - a)
                w_avg = math.exp(max(per_obs, -700.0))
                slow = state[ST_SLOW]
                fast = state[ST_FAST]
                state[ST_SLOW] = slow + prm[6] * (w_avg - slow)
                state[ST_FAST] = fast + prm[7] * (w_avg - fast)
                state[ST_TRACKED] = 1.0
                state[ST_ESS] = ess
                _cache(state, x, y, t, cov)
                state[ST_REF] = 1.0
                state[ST_REF + 1] = x
                state[ST_REF + 2] = y
                state[ST_REF + 3] = t
                lost = 0.0
                if recovery and prm[8] > 0.0:
                    lost = max(0.0, 1.0 - math.exp(min(per_obs, 700.0)) / prm[8])
                if lost > 0.0 or always or ess < prm[9] * n:
                    if recovery:
                        frac = lost
                        if state[ST_SLOW] > 0.0:
                            frac = max(frac, 1.0 - state[ST_FAST] / state[ST_SLOW])
                        if frac * (cap if kld else particles) >= 0.5:
                            # some particles may be re-drawn: the filter resamples itself
                            state[ST_PER_OBS] = per_obs
                            status = TRACK_RESAMPLE
                            break
                    if kld:
                        u0 = rng.random()
                        perm = _permutation(rng, cap)
                        n = pf_kld_resample(wa[:n], u0, perm, need, n_min, prm[10], prm[11],
                                            za[:n], tha[:n], ra[:n], zb, thb, rb, idx)
                    else:
                        low_variance_gather(wa[:n], rng.random(), particles, za[:n], tha[:n],
                                            ra[:n], zb, thb, rb, idx, True)
                        n = particles
                    za, zb = zb, za
                    tha, thb = thb, tha
                    ra, rb = rb, ra
                    wa[:n] = 1.0 / n
                    la[:n] = -math.log(n)
                    state[ST_RESAMPLINGS] += 1.0
        if state[ST_CACHED] == 0.0:
            x, y, t = weighted_pose(za[:n], ra[:n], wa[:n], cov)
            _cache(state, x, y, t, cov)
        rows_t[k] = times[i]
        rows_x[k] = state[ST_CACHED + 1]
        rows_y[k] = state[ST_CACHED + 2]
        rows_h[k] = state[ST_CACHED + 3]
        for c in range(9):
            rows_cov[k, c] = state[ST_CACHED + 4 + c]
        rows_n[k] = n
        rows_ess[k] = state[ST_ESS]
        k += 1
        j += 1
        if times[i] >= next_cloud:
            status = TRACK_CLOUD
            break
    return status, j, k, za[:n], tha[:n], ra[:n], wa[:n], la[:n]


# ---------------------------------------------------------------------------- pf, ekf proposal
@_jit
def pf_predict_covariance(cov: FloatArray, rot: ComplexArray, step: ComplexArray, sa: float,
                          sl: float, st: float, out: FloatArray) -> None:
    """:func:`lgvtool.localize.pf_proposal.predict_covariance` in one pass: ``F P F^T`` plus
    the body-frame motion noise (``sa``, ``sl`` m, ``st`` rad) rotated into the world."""
    va = sa * sa
    vl = sl * sl
    vt = st * st
    for n in range(cov.shape[0]):
        ux = -step[n].imag
        uy = step[n].real
        for j in range(3):
            out[n, 0, j] = cov[n, 0, j] + ux * cov[n, 2, j]
            out[n, 1, j] = cov[n, 1, j] + uy * cov[n, 2, j]
            out[n, 2, j] = cov[n, 2, j]
        for i in range(3):
            out[n, i, 0] += out[n, i, 2] * ux
            out[n, i, 1] += out[n, i, 2] * uy
        c = rot[n].real
        s = rot[n].imag
        cross = c * s * (va - vl)
        out[n, 0, 0] += c * c * va + s * s * vl
        out[n, 1, 1] += s * s * va + c * c * vl
        out[n, 0, 1] += cross
        out[n, 1, 0] += cross
        out[n, 2, 2] += vt


@_jit
def _ray_row(z: complex, rot: complex, lm: complex, q: complex, u_conj: complex
             ) -> tuple[float, float, float, float, float, float, float, float]:
    """The ray residual ``(r0, r1)`` of one landmark at one particle and its Jacobian's rows
    ``(j00, j01, j02)``, ``(j10, j11, j12)``
    (:func:`lgvtool.localize.pf_proposal.ray_residuals`)."""
    a = -u_conj * rot.conjugate()
    h = a * (z - lm)
    r = h - u_conj * q
    return r.real, r.imag, a.real, -a.imag, h.imag, a.imag, a.real, -h.real


@_jit
def pf_ekf_proposal(z: ComplexArray, rot: ComplexArray, cov: FloatArray, lm: ComplexArray,
                    q: ComplexArray, u_conj: ComplexArray, sr: FloatArray, st: FloatArray,
                    gate: float, g: FloatArray, dx: FloatArray, corr: FloatArray,
                    post: FloatArray) -> None:
    """The EKF proposal of every particle and its draw in one pass
    (:func:`lgvtool.localize.pf_proposal.kalman_proposal`, :func:`~.draw` and
    :func:`~.log_weight_correction`): the Kalman step from ``N(0, cov[n])`` with the ray
    residuals of the landmarks ``lm[n, k]`` inside the chi-square ``gate``, the draw's offset
    ``dx[n]`` (x m, y m, heading rad) with the standard normals ``g[n]`` (zeros: the
    posterior mean), the weight's correction ``corr[n]`` and the posterior covariance
    ``post[n]`` (3 x 3)."""
    k_n = q.shape[0]
    used = np.empty(k_n, dtype=np.bool_)
    for n in range(z.shape[0]):
        p00 = cov[n, 0, 0]
        p01 = cov[n, 0, 1]
        p02 = cov[n, 0, 2]
        p11 = cov[n, 1, 1]
        p12 = cov[n, 1, 2]
        p22 = cov[n, 2, 2]
        a00 = a01 = a02 = a11 = a12 = a22 = 0.0
        b0 = b1 = b2 = 0.0
        rr = 0.0
        for k in range(k_n):
            r0, r1, j00, j01, j02, j10, j11, j12 = _ray_row(z[n], rot[n], lm[n, k], q[k],
                                                            u_conj[k])
            # J P for both rows
            x0 = j00 * p00 + j01 * p01 + j02 * p02
            x1 = j00 * p01 + j01 * p11 + j02 * p12
            x2 = j00 * p02 + j01 * p12 + j02 * p22
            y0 = j10 * p00 + j11 * p01 + j12 * p02
            y1 = j10 * p01 + j11 * p11 + j12 * p12
            y2 = j10 * p02 + j11 * p12 + j12 * p22
            vr = sr[k] * sr[k]
            vt = st[k] * st[k]
            s00 = x0 * j00 + x1 * j01 + x2 * j02 + vr
            s11 = y0 * j10 + y1 * j11 + y2 * j12 + vt
            s01 = x0 * j10 + x1 * j11 + x2 * j12
            m2 = (s11 * r0 * r0 - 2.0 * s01 * r0 * r1 + s00 * r1 * r1) / (s00 * s11 - s01 * s01)
            used[k] = m2 <= gate
            if not used[k]:
                continue
            wr = 1.0 / vr
            wt = 1.0 / vt
            a00 += j00 * wr * j00 + j10 * wt * j10
            a01 += j00 * wr * j01 + j10 * wt * j11
            a02 += j00 * wr * j02 + j10 * wt * j12
            a11 += j01 * wr * j01 + j11 * wt * j11
            a12 += j01 * wr * j02 + j11 * wt * j12
            a22 += j02 * wr * j02 + j12 * wt * j12
            b0 += j00 * wr * r0 + j10 * wt * r1
            b1 += j01 * wr * r0 + j11 * wt * r1
            b2 += j02 * wr * r0 + j12 * wt * r1
            rr += r0 * wr * r0 + r1 * wt * r1
        # M = I + A P
        m00 = 1.0 + a00 * p00 + a01 * p01 + a02 * p02
        m01 = a00 * p01 + a01 * p11 + a02 * p12
        m02 = a00 * p02 + a01 * p12 + a02 * p22
        m10 = a01 * p00 + a11 * p01 + a12 * p02
        m11 = 1.0 + a01 * p01 + a11 * p11 + a12 * p12
        m12 = a01 * p02 + a11 * p12 + a12 * p22
        m20 = a02 * p00 + a12 * p01 + a22 * p02
        m21 = a02 * p01 + a12 * p11 + a22 * p12
        m22 = 1.0 + a02 * p02 + a12 * p12 + a22 * p22
        c00 = m11 * m22 - m12 * m21
        c01 = m02 * m21 - m01 * m22
        c02 = m01 * m12 - m02 * m11
        c10 = m12 * m20 - m10 * m22
        c11 = m00 * m22 - m02 * m20
        c12 = m02 * m10 - m00 * m12
        c20 = m10 * m21 - m11 * m20
        c21 = m01 * m20 - m00 * m21
        c22 = m00 * m11 - m01 * m10
        det = m00 * c00 + m01 * c10 + m02 * c20
        # P' = P M^-1 (the cofactors c are M^-1 times det), symmetrised
        q00 = (p00 * c00 + p01 * c10 + p02 * c20) / det
        q01 = (p00 * c01 + p01 * c11 + p02 * c21) / det
        q02 = (p00 * c02 + p01 * c12 + p02 * c22) / det
        q10 = (p01 * c00 + p11 * c10 + p12 * c20) / det
        q11 = (p01 * c01 + p11 * c11 + p12 * c21) / det
        q12 = (p01 * c02 + p11 * c12 + p12 * c22) / det
        q20 = (p02 * c00 + p12 * c10 + p22 * c20) / det
        q21 = (p02 * c01 + p12 * c11 + p22 * c21) / det
        q22 = (p02 * c02 + p12 * c12 + p22 * c22) / det
        q01 = 0.5 * (q01 + q10)
        q02 = 0.5 * (q02 + q20)
        q12 = 0.5 * (q12 + q21)
        post[n, 0, 0] = q00
        post[n, 1, 1] = q11
        post[n, 2, 2] = q22
        post[n, 0, 1] = post[n, 1, 0] = q01
        post[n, 0, 2] = post[n, 2, 0] = q02
        post[n, 1, 2] = post[n, 2, 1] = q12
        d0 = -(q00 * b0 + q01 * b1 + q02 * b2)
        d1 = -(q01 * b0 + q11 * b1 + q12 * b2)
        d2 = -(q02 * b0 + q12 * b1 + q22 * b2)
        log_ev = -0.5 * (rr + b0 * d0 + b1 * d1 + b2 * d2 + math.log(det))
        # the draw: L sqrt(D) g with the LDL^T factors of P'
        tiny = 1e-15 * (abs(q00) + abs(q11) + abs(q22)) + 1e-300
        l10 = q01 / q00 if q00 > tiny else 0.0
        l20 = q02 / q00 if q00 > tiny else 0.0
        e1 = q11 - l10 * l10 * q00
        l21 = (q12 - l20 * l10 * q00) / e1 if e1 > tiny else 0.0
        e2 = q22 - l20 * l20 * q00 - l21 * l21 * e1
        g0 = math.sqrt(max(q00, 0.0)) * g[n, 0]
        g1 = math.sqrt(max(e1, 0.0)) * g[n, 1]
        g2 = math.sqrt(max(e2, 0.0)) * g[n, 2]
        x = d0 + g0
        y = d1 + (l10 * g0 + g1)
        t = d2 + (l20 * g0 + l21 * g1 + g2)
        dx[n, 0] = x
        dx[n, 1] = y
        dx[n, 2] = t
        # the correction: log N(r; 0, S) - log p_lin(z | x)
        lin = 0.0
        for k in range(k_n):
            if not used[k]:
                continue
            r0, r1, j00, j01, j02, j10, j11, j12 = _ray_row(z[n], rot[n], lm[n, k], q[k],
                                                            u_conj[k])
            e0 = r0 + (j00 * x + j01 * y + j02 * t)
            f0 = r1 + (j10 * x + j11 * y + j12 * t)
            lin += e0 * e0 / (sr[k] * sr[k]) + f0 * f0 / (st[k] * st[k])
        corr[n] = log_ev + 0.5 * lin
