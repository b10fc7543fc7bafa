"""The circle of a circle drive: its kinematic radius and the fits of its centre.

With a fixed steering angle the target rotation centre O drives a circle of radius
``R = h / tan(delta)`` (domain.md section 1, :func:`kinematic_radius`, the steering angle of a
drive by :func:`median_steering`). The evaluation (``lgvtool.evaluate``) and ``replay``'s view
of the reference circle need its centre, and optionally a radius fitted to the data instead of
the kinematic one:

- :func:`fit_kasa`: algebraic (Kasa) fit of centre and radius, linear least squares; fast, and
  the starting point of the geometric fits;
- :func:`fit_geometric`: geometric fit of centre and radius, minimising the sum of squared
  distances of the points from the circle (Gauss-Newton from the Kasa fit);
- :func:`fit_centre`: geometric fit of the centre alone for a given (kinematic) radius.

Every fit takes optional per-point weights and an optional outlier trim (``trim``): after a
first fit, points whose radial residual lies more than ``trim`` robust standard deviations
(1.4826 x median absolute deviation) from the median residual are left out of the next fit, at
most :data:`TRIM_PASSES` times. Trimming only affects where the circle is; every point still
counts in the metrics.

All lengths in m.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.errors import InputError

TRIM_PASSES = 3
"""How many times a trimmed fit drops outliers and fits again."""

TRIM_FLOOR = 0.02
"""Residuals smaller than this never count as outliers, m (keeps noise-free data intact)."""

TRIM = 5.0
"""Outlier trim of the reference circle's centre fits, robust standard deviations."""

NOT_A_CIRCLE = 0.25
"""A trajectory whose radial RMSE about its circle exceeds this fraction of the radius (and
0.1 m) is not driving a circle (:func:`follows_circle`)."""

MOVING_SPEED = 0.01
"""Drive speed above which an MCU frame counts as driving, m/s (:func:`median_steering`)."""

_MAX_ITERATIONS = 100
_TOLERANCE = 1e-12


@dataclass(frozen=True)
class Circle:
    """A circle in the map frame: centre (cx, cy) and radius r, m."""

    cx: float
    cy: float
    r: float

    def radial_error(self, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
        """Signed radial error of points, m: distance from the centre minus the radius
        (positive outside the circle)."""
        return radial_error(x, y, self)

    def points(self, n: int = 361) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``n`` points around the circle (closed: the last equals the first), m."""
        a = np.linspace(0.0, 2.0 * np.pi, n)
        return self.cx + self.r * np.cos(a), self.cy + self.r * np.sin(a)


def radial_error(x: ArrayLike, y: ArrayLike, circle: Circle) -> NDArray[np.float64]:
    """Signed radial error of points (x, y) about ``circle``, m (positive outside)."""
    xa = np.asarray(x, dtype=float)
    ya = np.asarray(y, dtype=float)
    return np.hypot(xa - circle.cx, ya - circle.cy) - circle.r


def _prepare(
    x: ArrayLike, y: ArrayLike, weights: ArrayLike | None, minimum: int
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    xa = np.asarray(x, dtype=float).ravel()
    ya = np.asarray(y, dtype=float).ravel()
    if xa.shape != ya.shape:
        raise ValueError("x and y must have the same length")
    w = np.ones_like(xa) if weights is None else np.asarray(weights, dtype=float).ravel()
    if w.shape != xa.shape:
        raise ValueError("weights must have the same length as x and y")
    ok = np.isfinite(xa) & np.isfinite(ya) & np.isfinite(w) & (w > 0)
    xa, ya, w = xa[ok], ya[ok], w[ok]
    if xa.size < minimum:
        raise InputError(f"a circle fit needs at least {minimum} usable points, got {xa.size}")
    return xa, ya, w


def _kasa(x: NDArray[np.float64], y: NDArray[np.float64], w: NDArray[np.float64]) -> Circle:
    # x^2 + y^2 = 2 cx x + 2 cy y + c, with c = r^2 - cx^2 - cy^2; centred for conditioning.
    mx, my = np.average(x, weights=w), np.average(y, weights=w)
    u, v = x - mx, y - my
    sw = np.sqrt(w)
    a = np.column_stack([2.0 * u, 2.0 * v, np.ones_like(u)]) * sw[:, None]
    b = (u * u + v * v) * sw
    sol, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if rank < 3:
        raise InputError("the points do not determine a circle (collinear or coincident)")
    uc, vc, c = (float(s) for s in sol)
    r2 = c + uc * uc + vc * vc
    if not np.isfinite(r2) or r2 <= 0.0:
        raise InputError("the points do not determine a circle (collinear or coincident)")
    return Circle(uc + mx, vc + my, float(np.sqrt(r2)))


def _gauss_newton(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    start: Circle,
    radius: float | None,
) -> Circle:
    """Minimise sum w (|p - c| - r)^2 over (cx, cy[, r]); ``radius`` fixes r when given."""
    cx, cy = start.cx, start.cy
    r = start.r if radius is None else radius
    sw = np.sqrt(w)

    def cost(cx_: float, cy_: float, r_: float) -> float:
        res = np.hypot(x - cx_, y - cy_) - r_
        return float(np.sum(w * res * res))

    current = cost(cx, cy, r)
    for _ in range(_MAX_ITERATIONS):
        dx, dy = x - cx, y - cy
        d = np.hypot(dx, dy)
        d = np.where(d < 1e-12, 1e-12, d)
        res = d - r
        cols = [-dx / d, -dy / d]
        if radius is None:
            cols.append(-np.ones_like(d))
        jac = np.column_stack(cols) * sw[:, None]
        step, *_ = np.linalg.lstsq(jac, -res * sw, rcond=None)
        scale = 1.0
        improved = False
        while scale > 1e-6:
            ncx, ncy = cx + scale * step[0], cy + scale * step[1]
            nr = r + scale * step[2] if radius is None else r
            new = cost(ncx, ncy, nr)
            if new <= current:
                improved = True
                break
            scale *= 0.5
        if not improved:
            break
        done = current - new <= _TOLERANCE * max(current, 1e-30) or float(
            np.max(np.abs(step))
        ) * scale < 1e-12
        cx, cy, r, current = ncx, ncy, nr, new
        if done:
            break
    return Circle(float(cx), float(cy), float(abs(r)))


def _trimmed(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    w: NDArray[np.float64],
    fit: _Fit,
    trim: float | None,
    start: Circle | None = None,
) -> Circle:
    """Fit, then refit without outliers; each fit starts from the previous circle (or from
    ``start``, whose residuals then also choose the points of the first fit)."""
    if trim is None:
        return fit(x, y, w, start)
    circle = start if start is not None else fit(x, y, w, None)
    fitted = start is None
    keep = np.ones_like(x, dtype=bool)
    for _ in range(TRIM_PASSES):
        res = radial_error(x, y, circle)
        med = float(np.median(res[keep]))
        sigma = 1.4826 * float(np.median(np.abs(res[keep] - med)))
        limit = max(trim * sigma, TRIM_FLOOR)
        new_keep = np.abs(res - med) <= limit
        if new_keep.sum() < 3 or (fitted and np.array_equal(new_keep, keep)):
            break
        keep = new_keep
        circle = fit(x[keep], y[keep], w[keep], circle)
        fitted = True
    return circle if fitted else fit(x, y, w, start)


class _Fit:
    """A fit of one kind, as a callable over (x, y, weights, initial circle or None)."""

    def __init__(self, kind: str, radius: float | None = None) -> None:
        self.kind = kind
        self.radius = radius

    def __call__(
        self,
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        w: NDArray[np.float64],
        initial: Circle | None,
    ) -> Circle:
        if self.kind == "kasa":
            return _kasa(x, y, w)
        start = initial if initial is not None else _kasa(x, y, w)
        if self.kind == "geometric":
            return _gauss_newton(x, y, w, start, None)
        assert self.radius is not None
        return _gauss_newton(x, y, w, Circle(start.cx, start.cy, self.radius), self.radius)


def fit_kasa(
    x: ArrayLike, y: ArrayLike, *, weights: ArrayLike | None = None, trim: float | None = None
) -> Circle:
    """Algebraic (Kasa) circle fit: linear least squares on ``x^2 + y^2 = 2 cx x + 2 cy y + c``.

    Inputs in m; raises :class:`~lgvtool.errors.InputError` if fewer than 3 usable points or
    the points are collinear.
    """
    xa, ya, w = _prepare(x, y, weights, 3)
    return _trimmed(xa, ya, w, _Fit("kasa"), trim)


def fit_geometric(
    x: ArrayLike,
    y: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    trim: float | None = None,
    start: Circle | None = None,
) -> Circle:
    """Geometric circle fit (centre and radius): least squares of the distances of the points
    from the circle, Gauss-Newton from ``start`` (default: the Kasa fit). Inputs and result
    in m."""
    xa, ya, w = _prepare(x, y, weights, 3)
    return _trimmed(xa, ya, w, _Fit("geometric"), trim, start)


def fit_centre(
    x: ArrayLike,
    y: ArrayLike,
    radius: float,
    *,
    weights: ArrayLike | None = None,
    trim: float | None = None,
    start: Circle | None = None,
) -> Circle:
    """Centre of the circle of given ``radius`` (m) that best fits the points in the least
    squares sense of their radial errors (Gauss-Newton from the centre of ``start``, default
    the Kasa fit)."""
    if not (np.isfinite(radius) and radius > 0):
        raise InputError(f"the reference radius must be positive and finite, got {radius}")
    xa, ya, w = _prepare(x, y, weights, 3)
    return _trimmed(xa, ya, w, _Fit("centre", float(radius)), trim, start)


def fit_circle(
    x: ArrayLike,
    y: ArrayLike,
    radius: float | None,
    *,
    weights: ArrayLike | None = None,
    trim: float | None = None,
    start: Circle | None = None,
) -> Circle:
    """:func:`fit_centre` for a given ``radius`` (m), else :func:`fit_geometric`."""
    if radius is None:
        return fit_geometric(x, y, weights=weights, trim=trim, start=start)
    return fit_centre(x, y, radius, weights=weights, trim=trim, start=start)


def follows_circle(radial_rmse: float, r: float) -> bool:
    """Whether a trajectory with this radial RMSE (m) about a circle of radius ``r`` (m)
    follows it (:data:`NOT_A_CIRCLE`)."""
    return not radial_rmse > max(NOT_A_CIRCLE * r, 0.1)


def median_steering(angle: NDArray[np.float64], speed: NDArray[np.float64] | None
                    ) -> float | None:
    """Median steering angle over the drive, rad, from the MCU frames' steering angles (rad,
    NaN where absent) and drive speeds (m/s; None: unknown); frames at standstill are left out
    unless the vehicle never moves. None if there is no usable angle."""
    ok = np.isfinite(angle)
    if speed is not None:
        moving = ok & (np.abs(speed) > MOVING_SPEED)
        if moving.any():
            ok = moving
    return float(np.median(angle[ok])) if ok.any() else None


def kinematic_radius(h: float, steering_angle: float) -> float:
    """R = h / |tan(delta)|, m (inf for a straight drive)."""
    t = abs(math.tan(steering_angle))
    return math.inf if t < 1e-9 else h / t
