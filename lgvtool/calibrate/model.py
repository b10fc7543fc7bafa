"""The factors of the calibration and their analytic Jacobians.

State: the free calibration quantities (SI), then per drive the pose ``(x, y, theta)`` of O at
every node (m, m, rad) and, for MCU drives with a free gyro bias, one bias per stretch of
``bias_stretch_s`` (rad/s). Every residual is divided by its standard deviation, so the cost is
the sum of squared normalised residuals.

Factors of each interval between two nodes (body-frame motion ``(dx, dy)`` of O in the frame of
the earlier node and heading change ``dtheta``):

- distance and lateral: ``(dx, dy)`` against the chord of an arc of length ``ds`` turning
  ``dtheta``: ``ds (sin a / a, (1 - cos a) / a)`` with ``a = dtheta``, where
  ``ds = pi / ppr (r_l n_l + r_r n_r)`` (MCU, counts ``n``) or ``s_v * integral of v``;
- gyro (MCU): ``dtheta = (integral of the rate - b T) / gyro_scale``;
- encoder heading (MCU): ``dtheta = 2 pi / ppr (r_r n_r - r_l n_l) / track``;
- turn (generic odometry): ``dtheta = s_w * integral of omega``.

Factors of each reflector measurement, stamped ``t`` (scan start plus time in the scan): the
pose at ``t - nav_time_offset`` interpolated between its two nodes, the head at
``(nav_x, nav_y)`` turned by ``nav_yaw``; range and bearing to the map reflector. A NAV pose
(when there are no scans) is a factor on the head's pose at its receive time minus
``nav_time_offset``, its position moved by the revolution's skew
``(omega T / pi) R(heading) (s_x, s_y)`` (:mod:`lgvtool.localize.pose_model`; ``omega`` the
odometry's turn rate, ``T`` the head period, ``heading`` the reported one) with the lever
``(pose_lever_x, pose_lever_y)`` (m, head frame) in the state: a turning head pulls its fit off
by a bias proportional to the turn rate, which a mounting offset alone would absorb. Gyro bias
stretches are tied by a random walk.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.calibrate.drive import Drive

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

LEVER = ("pose_lever_x", "pose_lever_y")
"""The NAV poses' skew lever (m, head frame), free when NAV poses are observed: nuisance
unknowns of the mounting's estimate, not vehicle quantities. One lever per drive
(:func:`lever_names`): it depends on the reflectors the head fits, so on the route."""


def lever_names(drive: int) -> tuple[str, str]:
    """State names of drive ``drive``'s skew lever."""
    return f"{LEVER[0]}:{drive}", f"{LEVER[1]}:{drive}"

GROUPS = ("distance", "lateral", "gyro", "encoder", "turn", "range", "bearing", "pose_xy",
          "pose_heading")
"""Residual groups; each has its own noise scale, re-estimated from its residuals."""


def arc_terms(a: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """``A = sin a / a``, ``B = (1 - cos a) / a`` and their derivatives (series near 0)."""
    small = np.abs(a) < 1e-4
    safe = np.where(small, 1.0, a)
    s, c = np.sin(safe), np.cos(safe)
    a2 = a * a
    big_a = np.where(small, 1.0 - a2 / 6.0, s / safe)
    big_b = np.where(small, a / 2.0 - a * a2 / 24.0, (1.0 - c) / safe)
    da = np.where(small, -a / 3.0, (safe * c - s) / (safe * safe))
    db = np.where(small, 0.5 - a2 / 8.0, (safe * s - (1.0 - c)) / (safe * safe))
    return big_a, big_b, da, db


@dataclass
class Layout:
    """Where everything sits in the state vector."""

    names: list[str]
    """Free calibration quantities, in state order (columns 0..len-1)."""
    values: dict[str, float]
    """Every calibration quantity's current value (SI): free ones mirror the state."""
    pose_offset: list[int] = field(default_factory=list)
    bias_offset: list[int] = field(default_factory=list)
    bias_count: list[int] = field(default_factory=list)
    size: int = 0

    def column(self, name: str) -> int:
        """State column of a free quantity, -1 when held fixed."""
        return self.names.index(name) if name in self.names else -1


@dataclass
class Factors:
    """Per drive, what changes only between outer iterations: the node each measurement is
    interpolated from, which measurements take part, the noise scales and robust weights."""

    obs_k: list[IntArray]
    obs_use: list[NDArray[np.bool_]]
    pose_k: list[IntArray]
    pose_use: list[NDArray[np.bool_]]
    scale: dict[str, float]
    """Multiplier of each group's standard deviation."""
    acc: list[FloatArray] = field(default_factory=list)
    """Mean acceleration over each interval (:func:`interval_acceleration`)."""
    pose_skew: list[FloatArray] = field(default_factory=list)
    """Per NAV pose, the odometry's turn rate over its interval times the head period over pi
    (``omega T / pi``, dimensionless): the factor of the skew lever."""
    capacity: tuple[int, int] = (0, 0)
    """Rows and Jacobian entries of the last evaluation, for which the next one makes room
    up front."""


class Rows:
    """Accumulates residuals and the Jacobian's rows (compressed sparse rows, appended in
    place: see :class:`_Growing`)."""

    def __init__(self, jac: bool, capacity: tuple[int, int] = (0, 0)) -> None:
        self.jac = jac
        rows, entries = capacity
        self.res = _Growing(np.float64, rows)
        self.group = _Growing(np.int64, rows)
        self.time = _Growing(np.float64, rows)
        self.drive = _Growing(np.int64, rows)
        self.counts = _Growing(np.int64, rows if jac else 0)
        """Entries in each row."""
        self.columns = _Growing(np.int32, entries if jac else 0)
        """Column of each entry, row by row (32-bit while they fit)."""
        self.vals = _Growing(np.float64, entries if jac else 0)
        self.n = 0

    def add(self, e: FloatArray, group: int, t: FloatArray, drive: int,
            cols: list[tuple[IntArray | int, FloatArray | float]]) -> None:
        """Residuals ``e`` and their derivatives ``[(columns, values), ...]`` (a column -1 is a
        fixed quantity and is left out)."""
        m = len(e)
        if m == 0:
            return
        self.res.extend(e)
        self.group.extend(np.full(m, group, dtype=np.int64))
        self.time.extend(np.broadcast_to(t, (m,)))
        self.drive.extend(np.full(m, drive, dtype=np.int64))
        self.n += m
        if not self.jac:
            return
        c = np.empty((m, len(cols)), dtype=np.int64)
        v = np.empty((m, len(cols)), dtype=np.float64)
        for i, (col, val) in enumerate(cols):
            c[:, i] = col
            v[:, i] = val
        keep = c >= 0
        self.counts.extend(np.count_nonzero(keep, axis=1))
        kept = c[keep]  # row by row, in the order of ``cols``
        # 32-bit column indices while they fit: the Jacobian is most of the calibration's memory
        if len(kept) and kept.max() >= 2 ** 31:
            self.columns.widen(np.int64)
        self.columns.extend(kept)
        self.vals.extend(v[keep])

    def build(self, size: int, jac: bool) -> tuple[FloatArray, sp.csr_matrix | None, IntArray,
                                                    FloatArray, IntArray]:
        """Residual vector, Jacobian (or None), group, time and drive of every row."""
        res, grp, tim, drv = (g.take() for g in (self.res, self.group, self.time, self.drive))
        j = None
        if jac:
            counts = self.counts.take()
            if int(counts.sum()) >= 2 ** 31:  # the row pointers need 64 bits, and the columns
                self.columns.widen(np.int64)
            columns = self.columns.take()
            indptr = np.zeros(self.n + 1, dtype=columns.dtype)
            np.cumsum(counts, out=indptr[1:])
            del counts
            j = sp.csr_matrix((self.vals.take(), columns, indptr), shape=(self.n, size))
        return res, j, grp, tim, drv


class _Growing:
    """A 1-D array appended to in place, its capacity at least doubled when full. Only the
    part written is resident (a fresh capacity is not touched before it is written), so the
    whole is never held beside its pieces, as joining a list of blocks would."""

    def __init__(self, dtype: Any, capacity: int = 0) -> None:
        self.a: NDArray[Any] = np.empty(capacity, dtype=dtype)
        self.n = 0

    def extend(self, values: NDArray[Any]) -> None:
        """Append ``values``."""
        need = self.n + len(values)
        if need > len(self.a):
            grown = np.empty(max(need, 2 * len(self.a), 1024), dtype=self.a.dtype)
            grown[:self.n] = self.a[:self.n]
            self.a = grown
        self.a[self.n:need] = values
        self.n = need

    def widen(self, dtype: Any) -> None:
        """Hold the values as ``dtype`` from now on."""
        if self.a.dtype != dtype:
            self.a = self.a.astype(dtype)

    def take(self) -> NDArray[Any]:
        """The values appended (a view of the first ``n`` of the capacity); empties this."""
        a = self.a[:self.n]
        self.a, self.n = np.empty(0, dtype=self.a.dtype), 0
        return a


@dataclass
class Noise:
    """Starting standard deviations of the factors (before the group scales)."""

    range_m: float = 0.02
    range_per_m: float = 0.0
    bearing_rad: float = 0.005
    pose_xy_m: float = 0.05
    pose_heading_rad: float = 0.01
    gyro_rad_s: float = 0.001
    """Noise of a frame's mean gyro rate, rad/s."""
    slip_per_sqrt_m: float = 0.0015
    """Wheel slip, m per sqrt(m) of travel, each wheel."""
    odom_dist_per_m: float = 0.05
    """Generic odometry: distance noise per m travelled (plus 5 mm)."""
    odom_turn_per_rad: float = 0.05
    """Generic odometry: turn noise per rad turned (plus 0.005 rad and 0.02 rad per m)."""
    bias_walk: float = math.radians(0.005)
    """Gyro bias random walk, rad/s per sqrt(s)."""


def _get(layout: Layout, name: str) -> float:
    return layout.values[name]


def evaluate(x: FloatArray, layout: Layout, drives: list[Drive], factors: Factors,
             noise: Noise, start: dict[str, float], prior: dict[str, float],
             bias_stretch_s: float, vehicle_ppr: int, jac: bool = True
             ) -> tuple[FloatArray, sp.csr_matrix | None, IntArray, FloatArray, IntArray]:
    """Residuals (normalised) and their Jacobian at state ``x``."""
    for i, name in enumerate(layout.names):
        layout.values[name] = float(x[i])
    rows = Rows(jac, factors.capacity)
    sc = factors.scale
    g = {n: GROUPS.index(n) for n in GROUPS}
    col = layout.column
    mx, my, myaw = _get(layout, "nav_x"), _get(layout, "nav_y"), _get(layout, "nav_yaw")
    tau = _get(layout, "nav_time_offset")
    c_mx, c_my, c_yaw, c_tau = col("nav_x"), col("nav_y"), col("nav_yaw"), col("nav_time_offset")
    k_count = 2.0 * math.pi / vehicle_ppr
    for d, drive in enumerate(drives):
        po = layout.pose_offset[d]
        n = len(drive.t)
        pose = x[po:po + 3 * n].reshape(n, 3)
        lx_name, ly_name = lever_names(d)
        lever = (layout.values.get(lx_name, 0.0), layout.values.get(ly_name, 0.0))
        c_lever = (col(lx_name), col(ly_name))
        cx = po + 3 * np.arange(n, dtype=np.int64)
        px, py, pth = pose[:, 0], pose[:, 1], pose[:, 2]
        # ---------------------------------------------------------------- odometry
        k0 = np.arange(n - 1)
        c, s = np.cos(pth[:-1]), np.sin(pth[:-1])
        ex, ey = px[1:] - px[:-1], py[1:] - py[:-1]
        dxb, dyb = c * ex + s * ey, -s * ex + c * ey
        dth = pth[1:] - pth[:-1]
        a_, b_, da_, db_ = arc_terms(dth)
        t_mid = 0.5 * (drive.t[:-1] + drive.t[1:])
        xk, yk, tk = cx[k0], cx[k0] + 1, cx[k0] + 2
        xk1, yk1, tk1 = cx[k0 + 1], cx[k0 + 1] + 1, cx[k0 + 1] + 2
        if drive.motion == "mcu":
            rl, rr, tr = (_get(layout, "wheel_radius_left"), _get(layout, "wheel_radius_right"),
                          _get(layout, "track"))
            nl, nr = drive.counts_left, drive.counts_right
            ds = 0.5 * k_count * (rl * nl + rr * nr)
            dds_rl, dds_rr = 0.5 * k_count * nl, 0.5 * k_count * nr
            c_rl, c_rr, c_tr = col("wheel_radius_left"), col("wheel_radius_right"), col("track")
            # the noise follows the starting geometry, so that it does not move with the state
            rl0, rr0, tr0 = (start["wheel_radius_left"], start["wheel_radius_right"],
                             start["track"])
            q = k_count * 0.5 * (rl0 + rr0) / math.sqrt(6.0)
            ds0 = np.abs(0.5 * k_count * (rl0 * nl + rr0 * nr))
            slip = noise.slip_per_sqrt_m ** 2 * ds0
            sig1 = np.sqrt(0.5 * q * q + 0.5 * slip + 1e-8) * sc["distance"]
            sig2 = (5e-4 + 0.005 * ds0) * sc["lateral"]
            scale_cols: list[tuple[int, FloatArray]] = [(c_rl, dds_rl), (c_rr, dds_rr)]
        else:
            sv, sw = _get(layout, "odom_scale_v"), _get(layout, "odom_scale_w")
            ds = sv * drive.dist
            scale_cols = [(col("odom_scale_v"), drive.dist)]
            dist0 = np.abs(start["odom_scale_v"] * drive.dist)
            sig1 = (0.005 + noise.odom_dist_per_m * dist0) * sc["distance"]
            sig2 = (0.002 + 0.5 * noise.odom_dist_per_m * dist0) * sc["lateral"]
        e1 = (dxb - ds * a_) / sig1
        rows.add(e1, g["distance"], t_mid, d, [
            (xk, -c / sig1), (yk, -s / sig1), (tk, (dyb + ds * da_) / sig1),
            (xk1, c / sig1), (yk1, s / sig1), (tk1, -ds * da_ / sig1),
            *[(cc, -v * a_ / sig1) for cc, v in scale_cols]])
        e2 = (dyb - ds * b_) / sig2
        rows.add(e2, g["lateral"], t_mid, d, [
            (xk, s / sig2), (yk, -c / sig2), (tk, (-dxb + ds * db_) / sig2),
            (xk1, -s / sig2), (yk1, c / sig2), (tk1, -ds * db_ / sig2),
            *[(cc, -v * b_ / sig2) for cc, v in scale_cols]])
        if drive.motion == "mcu":
            ok = drive.gyro_ok
            sg = _get(layout, "gyro_scale")
            nb = layout.bias_count[d]
            seg = np.minimum(((t_mid - drive.t[0]) / bias_stretch_s).astype(np.int64),
                             max(nb - 1, 0))
            if nb:
                bias = x[layout.bias_offset[d]:layout.bias_offset[d] + nb][seg]
                c_b = layout.bias_offset[d] + seg
            else:
                bias = np.full(n - 1, _get(layout, "gyro_bias"))
                c_b = np.full(n - 1, -1, dtype=np.int64)
            gdt = drive.gyro_dt
            pred = (drive.gyro - bias * gdt) / sg
            sig3 = np.maximum(noise.gyro_rad_s * gdt, 1e-7) * sc["gyro"]
            e3 = (dth - pred) / sig3
            rows.add(e3[ok], g["gyro"], t_mid[ok], d, [
                (tk[ok], -1.0 / sig3[ok]), (tk1[ok], 1.0 / sig3[ok]),
                (col("gyro_scale"), (pred / sg / sig3)[ok]),
                (c_b[ok], (gdt / sg / sig3)[ok])])
            enc = k_count * (rr * nr - rl * nl) / tr
            wheel_l = noise.slip_per_sqrt_m ** 2 * np.abs(k_count * rl0 * nl)
            wheel_r = noise.slip_per_sqrt_m ** 2 * np.abs(k_count * rr0 * nr)
            sig4 = np.sqrt(2.0 * q * q + wheel_l + wheel_r + 1e-10) / tr0 * sc["encoder"]
            e4 = (dth - enc) / sig4
            rows.add(e4, g["encoder"], t_mid, d, [
                (tk, -1.0 / sig4), (tk1, 1.0 / sig4),
                (c_rr, -k_count * nr / tr / sig4), (c_rl, k_count * nl / tr / sig4),
                (c_tr, enc / tr / sig4)])
            if nb > 1:
                b = x[layout.bias_offset[d]:layout.bias_offset[d] + nb]
                sig_w = noise.bias_walk * math.sqrt(bias_stretch_s)
                cb = layout.bias_offset[d] + np.arange(nb - 1)
                rows.add((b[1:] - b[:-1]) / sig_w, -1, drive.t[0] + bias_stretch_s * (
                    np.arange(nb - 1) + 1.0), d, [(cb, -1.0 / sig_w), (cb + 1, 1.0 / sig_w)])
            if nb:
                b = x[layout.bias_offset[d]:layout.bias_offset[d] + nb]
                sp0 = prior["gyro_bias"]
                rows.add((b - start["gyro_bias"]) / sp0, -1, np.full(nb, drive.t[0]), d,
                         [(layout.bias_offset[d] + np.arange(nb), 1.0 / sp0)])
        else:
            sw, yaw_m = _get(layout, "odom_scale_w"), _get(layout, "odom_yaw_per_m")
            pred = sw * drive.turn + yaw_m * drive.dist
            sig3 = (0.005 + noise.odom_turn_per_rad * np.abs(start["odom_scale_w"] * drive.turn)
                    + 0.02 * dist0) * sc["turn"]
            e3 = (dth - pred) / sig3
            rows.add(e3, g["turn"], t_mid, d, [
                (tk, -1.0 / sig3), (tk1, 1.0 / sig3),
                (col("odom_scale_w"), -drive.turn / sig3),
                (col("odom_yaw_per_m"), -drive.dist / sig3)])
        # ---------------------------------------------------------------- observations
        acc = factors.acc[d]
        for kind, use in _observation_blocks(factors, d):
            if kind == "scan":
                kk = factors.obs_k[d][use]
                t_obs = drive.obs_t[use]
            else:
                kk = factors.pose_k[d][use]
                t_obs = drive.pose_t[use]
            t0, t1 = drive.t[kk], drive.t[kk + 1]
            span = t1 - t0
            f = (t_obs - tau - t0) / span
            p0, p1 = pose[kk], pose[kk + 1]
            # linear between the nodes, bent by the interval's mean acceleration (held
            # constant in the Jacobian): exact for a quadratic motion
            p = (p0 + f[:, None] * (p1 - p0)
                 - 0.5 * acc[kk] * (f * (1.0 - f) * span * span)[:, None])
            vel = ((p1 - p0) / span[:, None]
                   - 0.5 * acc[kk] * ((1.0 - 2.0 * f) * span)[:, None])  # d p / d t
            ct, st = np.cos(p[:, 2]), np.sin(p[:, 2])
            hx = p[:, 0] + ct * mx - st * my
            hy = p[:, 1] + st * mx + ct * my
            dhx_dth = -st * mx - ct * my
            dhy_dth = ct * mx - st * my
            ip = _Interp([cx[kk], cx[kk] + 1, cx[kk] + 2],
                         [cx[kk + 1], cx[kk + 1] + 1, cx[kk + 1] + 2], f, vel, c_tau, c_yaw,
                         (c_mx, c_my), ct, st, d, t_obs)

            def add(e: FloatArray, grp: int, gx: FloatArray, gy: FloatArray, gth: FloatArray,
                    gyaw: FloatArray | float, ip: _Interp = ip, head: bool = True,
                    extra: tuple[tuple[int, FloatArray], ...] = ()) -> None:
                _add_interpolated(rows, ip, e, grp, gx, gy, gth, gyaw, head, extra)

            if kind == "scan":
                lx, ly = drive.obs_lx[use], drive.obs_ly[use]
                rng, brg = drive.obs_range[use], drive.obs_bearing[use]
                dx, dy = lx - hx, ly - hy
                q2 = dx * dx + dy * dy
                r = np.sqrt(q2)
                sig_r = np.sqrt(noise.range_m ** 2 + (noise.range_per_m * rng) ** 2) * sc["range"]
                sig_b = noise.bearing_rad * sc["bearing"]
                er = (rng - r) / sig_r
                ghx, ghy = dx / (r * sig_r), dy / (r * sig_r)
                add(er, g["range"], ghx, ghy, ghx * dhx_dth + ghy * dhy_dth, 0.0)
                bh = np.arctan2(dy, dx) - p[:, 2] - myaw
                eb = wrap_angle(brg - bh) / sig_b
                ghx, ghy = -dy / (q2 * sig_b), dx / (q2 * sig_b)
                add(eb, g["bearing"], ghx, ghy, ghx * dhx_dth + ghy * dhy_dth + 1.0 / sig_b,
                    1.0 / sig_b)
            else:
                sig_p = noise.pose_xy_m * sc["pose_xy"]
                sig_h = noise.pose_heading_rad * sc["pose_heading"]
                qx, qy, qh = drive.pose_x[use], drive.pose_y[use], drive.pose_heading[use]
                zero = np.zeros(len(kk))
                # the skew of a turning head, fixed in its reported frame: columns s_x, s_y
                kw = factors.pose_skew[d][use]
                cq, sq = kw * np.cos(qh), kw * np.sin(qh)
                skew = ((cq, -sq), (sq, cq))
                for comp, h, meas in ((0, hx, qx), (1, hy, qy)):
                    ds_x, ds_y = skew[comp]
                    e = (h + ds_x * lever[0] + ds_y * lever[1] - meas) / sig_p
                    one = np.full(len(kk), 1.0 / sig_p)
                    dth_ = (dhx_dth if comp == 0 else dhy_dth) / sig_p
                    add(e, g["pose_xy"], one if comp == 0 else zero,
                        zero if comp == 0 else one, dth_, 0.0,
                        extra=((c_lever[0], ds_x / sig_p), (c_lever[1], ds_y / sig_p)))
                eh = wrap_angle(p[:, 2] + myaw - qh)
                add(eh / sig_h, g["pose_heading"], zero, zero, np.full(len(kk), 1.0 / sig_h),
                    1.0 / sig_h, head=False)
    # ---------------------------------------------------------------- priors
    for i, name in enumerate(layout.names):
        sp0 = prior[name]
        rows.add(np.array([(x[i] - start[name]) / sp0]), -1, np.zeros(1), -1,
                 [(i, 1.0 / sp0)])
    built = rows.build(layout.size, jac)
    if jac:
        j = built[1]
        assert j is not None
        factors.capacity = (j.shape[0], j.nnz)
    return built


OBSERVATION_BLOCK = 32_768
"""Measurements whose factors are computed together: the intermediate arrays of a block, not
of a whole drive, are held at once (a block's rows are still contiguous in the Jacobian)."""


def _observation_blocks(factors: Factors, d: int) -> Iterator[tuple[str, IntArray]]:
    """The reflector measurements (``scan``), then the NAV poses (``pose``) of drive ``d`` that
    take part, as indices in blocks of at most :data:`OBSERVATION_BLOCK`."""
    for kind, use in (("scan", factors.obs_use[d]), ("pose", factors.pose_use[d])):
        where = np.flatnonzero(use)
        for first in range(0, len(where), OBSERVATION_BLOCK):
            yield kind, where[first:first + OBSERVATION_BLOCK]


@dataclass(frozen=True)
class _Interp:
    """Measurements interpolated between two nodes: the nodes' columns, the fraction ``f``,
    the pose's rate of change, the time offset's, the yaw's and the mounting offset's columns,
    the cosine and sine of the interpolated heading."""

    cols0: list[IntArray]
    cols1: list[IntArray]
    f: FloatArray
    vel: FloatArray
    c_tau: int
    c_yaw: int
    c_mount: tuple[int, int]
    cos: FloatArray
    sin: FloatArray
    drive: int
    t: FloatArray


def _add_interpolated(rows: Rows, ip: _Interp, e: FloatArray, grp: int, gx: FloatArray,
                      gy: FloatArray, gth: FloatArray, gyaw: FloatArray | float,
                      head: bool, extra: tuple[tuple[int, FloatArray], ...] = ()) -> None:
    """Rows of measurements whose derivatives by the interpolated pose are ``(gx, gy, gth)``
    and by the mounting yaw ``gyaw``: chained onto the two nodes and the time offset; with
    ``head`` (the head's position is measured, not only its heading) also onto the mounting
    offset, by which the head moves ``(cos, sin)`` per m of ``nav_x`` and ``(-sin, cos)``
    per m of ``nav_y``; ``extra``: further ``(column, derivatives)`` of state quantities."""
    gp = (gx, gy, gth)
    cols: list[tuple[IntArray | int, FloatArray | float]] = []
    for i in range(3):
        cols.append((ip.cols0[i], (1.0 - ip.f) * gp[i]))
        cols.append((ip.cols1[i], ip.f * gp[i]))
    cols.append((ip.c_tau, -(gx * ip.vel[:, 0] + gy * ip.vel[:, 1] + gth * ip.vel[:, 2])))
    cols.append((ip.c_yaw, gyaw))
    if head:
        cols.append((ip.c_mount[0], gx * ip.cos + gy * ip.sin))
        cols.append((ip.c_mount[1], -gx * ip.sin + gy * ip.cos))
    cols.extend(extra)
    rows.add(e, grp, ip.t, ip.drive, cols)


def interval_acceleration(t: FloatArray, ds: FloatArray, dth: FloatArray,
                          heading: FloatArray) -> FloatArray:
    """Mean acceleration ``(x, y, theta)`` over each interval between nodes at ``t`` (m/s^2,
    rad/s^2), (n-1, 3): from the odometry's distance ``ds`` and turn ``dth`` of each interval
    and the nodes' ``heading`` (the mean of the second differences at its two ends; zero at the
    ends of the drive). Odometry, not the nodes: their positions carry the observations' noise."""
    n = len(t)
    acc = np.zeros((max(n - 1, 0), 3))
    if n < 3:
        return acc
    dt = np.maximum(np.diff(t), 1e-6)
    mid = 0.5 * (heading[:-1] + heading[1:])
    vel = np.stack([ds * np.cos(mid), ds * np.sin(mid), dth], axis=1) / dt[:, None]
    node = np.zeros((n, 3))
    node[1:-1] = np.diff(vel, axis=0) / (0.5 * (dt[:-1] + dt[1:]))[:, None]
    acc[:] = 0.5 * (node[:-1] + node[1:])
    return acc
