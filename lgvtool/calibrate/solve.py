"""The batch least squares over whole drives: start, Gauss-Newton/Levenberg-Marquardt with
robust (Huber) weights, noise re-estimation, uncertainty and observability.

The normal equations of the sparse Jacobian (:mod:`lgvtool.calibrate.model`) are solved with a
sparse LU factorisation (SuperLU, :class:`lgvtool.sparse_normal.Factor`) that eliminates the unknowns in
time order, the calibration quantities last (:meth:`Problem.elimination_order`); the columns
are scaled to unit norm first. Around each linearisation the robust weights are those of a
Huber loss at ``huber_k`` standard deviations (iteratively reweighted least squares); after
each round the noise scale of every residual group is re-estimated from its residuals (1.4826 x
the median absolute normalised residual), so that the uncertainties follow the data and not the
starting noise values.

The 1-sigma of each quantity is the larger of the formal one (the inverse of the normal matrix)
and a cluster-robust one (the sandwich ``H^-1 (sum_b g_b g_b^T) H^-1`` over stretches of
``cluster_s`` seconds), which holds when the errors are correlated over time (a reflector
measured with the same error for a while, unmodelled slip).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from lgvtool.calibrate.drive import Drive
from lgvtool.calibrate.model import (
    GROUPS,
    Factors,
    Layout,
    Noise,
    evaluate,
    interval_acceleration,
    lever_names,
)
from lgvtool.calibrate.quantities import QUANTITIES
from lgvtool.config import Reflector
from lgvtool.localize.geometry import pose_from_correspondences
from lgvtool.sparse_normal import Factor, row_slices, scaled_normal

FloatArray = NDArray[np.float64]

RESCALED = ("range", "bearing", "pose_xy", "pose_heading")
"""Groups whose noise is re-estimated: the measurements. The motion factors keep their noise
model (between free nodes they have too little redundancy for their residuals to tell)."""


@dataclass
class SolveSettings:
    """How the least squares runs."""

    huber_k: float = 2.0
    """Huber loss threshold, in standard deviations."""
    rounds: int = 3
    """Outer rounds (re-association, noise re-estimation)."""
    iterations: int = 8
    """Gauss-Newton steps per round at most."""
    tolerance: float = 1e-5
    """A round ends when a step lowers the cost by less than this fraction."""
    bias_stretch_s: float = 20.0
    """Length of a stretch with one gyro bias, s."""
    cluster_s: float = 10.0
    """Length of the stretches of the cluster-robust uncertainty, s."""
    gate_m: float = 0.5
    """A measurement without a known id goes to the nearest map reflector within this, m."""
    pose_period_s: float | None = None
    """Head revolution period of the NAV whose poses are observed, s: with it each drive's
    skew lever of the poses is estimated beside the mounting
    (:data:`lgvtool.calibrate.model.LEVER`); None: the poses carry no skew (a ``plain`` pose
    model)."""
    lever_prior_m: float = 2.0
    """1-sigma of the weak prior of each component of the skew lever around its starting
    value, m."""
    noise: Noise = field(default_factory=Noise)


@dataclass
class Solution:
    """What the least squares found."""

    values: dict[str, float]
    """Every quantity's value (SI; the held ones at their starting values)."""
    sigma: dict[str, float]
    """1-sigma of each estimated quantity (SI)."""
    sigma_formal: dict[str, float]
    unobservable: dict[str, float]
    """Quantities the drive does not observe, with their 1-sigma before they were held."""
    noise_scale: dict[str, float]
    """The re-estimated noise scale of each residual group (x the starting noise)."""
    rms: dict[str, float]
    """RMS of each group's normalised residual (1: as its noise model says)."""
    outliers: dict[str, int]
    """Residuals beyond 3 sigma, per group."""
    bias_per_log: list[float]
    iterations: int
    poses: list[FloatArray]
    """The trajectory of O at the nodes of each drive, (n, 3)."""


# ----------------------------------------------------------------------------------- start


def odometry_steps(drive: Drive, v: dict[str, float], ppr: int) -> tuple[FloatArray,
                                                                         FloatArray]:
    """Distance (m) and turn (rad) of each interval by the odometry with the values ``v``."""
    if drive.motion == "mcu":
        k = 2.0 * math.pi / ppr
        dl = k * v["wheel_radius_left"] * drive.counts_left
        dr = k * v["wheel_radius_right"] * drive.counts_right
        ds = 0.5 * (dl + dr)
        dth_g = (drive.gyro - v["gyro_bias"] * drive.gyro_dt) / v["gyro_scale"]
        dth = np.where(drive.gyro_ok, dth_g, (dr - dl) / v["track"])
    else:
        ds = v["odom_scale_v"] * drive.dist
        dth = v["odom_scale_w"] * drive.turn + v["odom_yaw_per_m"] * drive.dist
    return ds, dth


def dead_reckoning(drive: Drive, v: dict[str, float], ppr: int) -> FloatArray:
    """Odometry poses of O at the nodes from the starting values, starting at the origin."""
    ds, dth = odometry_steps(drive, v, ppr)
    th = np.concatenate([[0.0], np.cumsum(dth)])
    mid = th[:-1] + 0.5 * dth
    x = np.concatenate([[0.0], np.cumsum(ds * np.cos(mid))])
    y = np.concatenate([[0.0], np.cumsum(ds * np.sin(mid))])
    return np.stack([x, y, th], axis=1)


def _fixes(drive: Drive, v: dict[str, float]) -> FloatArray:
    """Poses of O (t, x, y, heading) from each scan with two associated reflectors, else from
    each NAV pose."""
    out: list[tuple[float, float, float, float]] = []
    ok = np.isfinite(drive.obs_lx)
    if ok.sum() >= 2:
        t = drive.obs_t[ok]
        b = drive.obs_bearing[ok] + v["nav_yaw"]
        qx = v["nav_x"] + drive.obs_range[ok] * np.cos(b)
        qy = v["nav_y"] + drive.obs_range[ok] * np.sin(b)
        lx, ly = drive.obs_lx[ok], drive.obs_ly[ok]
        # a scan: measurements less than 0.2 s apart
        cut = np.nonzero(np.diff(t) > 0.02)[0] + 1
        bounds = np.concatenate([[0], cut, [len(t)]])
        for a, e in itertools.pairwise(bounds.tolist()):
            if e - a < 2:
                continue
            fix = pose_from_correspondences(qx[a:e], qy[a:e], lx[a:e], ly[a:e])
            if fix is not None:
                out.append((float(np.mean(t[a:e])) - v["nav_time_offset"], *fix))
    if not out and len(drive.pose_t):
        th = drive.pose_heading - v["nav_yaw"]
        c, s = np.cos(th), np.sin(th)
        x = drive.pose_x - c * v["nav_x"] + s * v["nav_y"]
        y = drive.pose_y - s * v["nav_x"] - c * v["nav_y"]
        t = drive.pose_t - v["nav_time_offset"] - v["nav_pose_age"]
        return np.stack([t, x, y, th], axis=1)
    return np.array(out, dtype=np.float64).reshape(-1, 4)


def _median5(a: FloatArray) -> FloatArray:
    """Running median over five samples, the ends repeated."""
    padded = np.concatenate([[a[0]] * 2, a, [a[-1]] * 2])
    return np.asarray(np.median(np.lib.stride_tricks.sliding_window_view(padded, 5), axis=1))


def initial_poses(drive: Drive, v: dict[str, float], ppr: int) -> FloatArray:
    """A first trajectory: the odometry, bent onto the fixes by a correction interpolated
    between them (median of five, against single bad fixes)."""
    odo = dead_reckoning(drive, v, ppr)
    fixes = _fixes(drive, v)
    if len(fixes) == 0:
        return odo
    fixes = fixes[np.argsort(fixes[:, 0])]
    ox = np.interp(fixes[:, 0], drive.t, odo[:, 0])
    oy = np.interp(fixes[:, 0], drive.t, odo[:, 1])
    oth = np.interp(fixes[:, 0], drive.t, odo[:, 2])
    dth = np.unwrap(fixes[:, 3] - oth)
    c, s = np.cos(dth), np.sin(dth)
    tx = fixes[:, 1] - (c * ox - s * oy)
    ty = fixes[:, 2] - (s * ox + c * oy)
    if len(fixes) >= 5:
        dth, tx, ty = (_median5(a) for a in (dth, tx, ty))
    cd = np.interp(drive.t, fixes[:, 0], dth)
    cx = np.interp(drive.t, fixes[:, 0], tx)
    cy = np.interp(drive.t, fixes[:, 0], ty)
    c, s = np.cos(cd), np.sin(cd)
    return np.stack([cx + c * odo[:, 0] - s * odo[:, 1], cy + s * odo[:, 0] + c * odo[:, 1],
                     odo[:, 2] + cd], axis=1)


def associate_unknown(drive: Drive, pose: FloatArray, v: dict[str, float],
                      reflectors: tuple[Reflector, ...], gate: float,
                      unknown: NDArray[np.bool_]) -> None:
    """Give each measurement in ``unknown`` the nearest map reflector to where it was measured,
    within ``gate`` m (NaN otherwise)."""
    if not unknown.any() or not reflectors:
        return
    t = drive.obs_t[unknown] - v["nav_time_offset"]
    x = np.interp(t, drive.t, pose[:, 0])
    y = np.interp(t, drive.t, pose[:, 1])
    th = np.interp(t, drive.t, pose[:, 2])
    c, s = np.cos(th), np.sin(th)
    hx = x + c * v["nav_x"] - s * v["nav_y"]
    hy = y + s * v["nav_x"] + c * v["nav_y"]
    b = th + v["nav_yaw"] + drive.obs_bearing[unknown]
    px = hx + drive.obs_range[unknown] * np.cos(b)
    py = hy + drive.obs_range[unknown] * np.sin(b)
    mx = np.array([r.x for r in reflectors])
    my = np.array([r.y for r in reflectors])
    d2 = (px[:, None] - mx[None, :]) ** 2 + (py[:, None] - my[None, :]) ** 2
    j = np.argmin(d2, axis=1)
    near = d2[np.arange(len(j)), j] <= gate * gate
    lx = np.where(near, mx[j], math.nan)
    ly = np.where(near, my[j], math.nan)
    drive.obs_lx[unknown] = lx
    drive.obs_ly[unknown] = ly


# ----------------------------------------------------------------------------------- solve


def _interp_index(drive: Drive, times: FloatArray) -> tuple[NDArray[np.int64],
                                                            NDArray[np.bool_]]:
    n = len(drive.t)
    k = np.clip(np.searchsorted(drive.t, times, side="right") - 1, 0, max(n - 2, 0))
    inside = (times >= drive.t[0]) & (times <= drive.t[-1]) & (n >= 2)
    return k.astype(np.int64), inside


class Problem:
    """The least squares over ``drives`` for the free quantities ``names``."""

    def __init__(self, drives: list[Drive], names: list[str], start: dict[str, float],
                 reflectors: tuple[Reflector, ...], ppr: int, settings: SolveSettings,
                 use_poses: list[bool]) -> None:
        self.drives = drives
        self.start = dict(start)
        self.ppr = ppr
        self.settings = settings
        self.reflectors = reflectors
        self.use_poses = use_poses
        self.prior = {q.name: q.prior_sigma for q in QUANTITIES.values()}
        self.unknown = [~np.isfinite(d.obs_lx) for d in drives]
        if settings.pose_period_s is not None:
            for d, drive in enumerate(drives):
                if use_poses[d] and len(drive.pose_t):
                    lever = lever_names(d)
                    self.prior.update(dict.fromkeys(lever, settings.lever_prior_m))
                    for n in lever:
                        self.start.setdefault(n, 0.0)
                    names = [*names, *lever]
        self.set_free(names)
        self.x = np.zeros(self.layout.size)
        for i, name in enumerate(self.layout.names):
            self.x[i] = self.start[name]
        for d, drive in enumerate(drives):
            pose = initial_poses(drive, start, ppr)
            po = self.layout.pose_offset[d]
            self.x[po:po + pose.size] = pose.ravel()
            nb = self.layout.bias_count[d]
            self.x[self.layout.bias_offset[d]:self.layout.bias_offset[d] + nb] = start[
                "gyro_bias"]
            associate_unknown(drive, pose, start, reflectors, settings.gate_m,
                              self.unknown[d])
        self.factors = Factors([], [], [], [], {g: 1.0 for g in GROUPS})
        self.weights: FloatArray | None = None

    def set_free(self, names: list[str], x: FloatArray | None = None) -> None:
        """Lay the state out for the free quantities ``names`` (moving ``x`` over if given)."""
        old: Layout | None = getattr(self, "layout", None)
        values = dict(self.start) if old is None else dict(old.values)
        glob = [n for n in names if n != "gyro_bias"]
        layout = Layout(glob, values)
        off = len(glob)
        for drive in self.drives:
            layout.pose_offset.append(off)
            off += 3 * len(drive.t)
            layout.bias_offset.append(off)
            nb = 0
            if "gyro_bias" in names and drive.motion == "mcu":
                nb = max(1, math.ceil(drive.duration / self.settings.bias_stretch_s))
            layout.bias_count.append(nb)
            off += nb
        layout.size = off
        if x is not None and old is not None:
            new = np.zeros(off)
            for i, n in enumerate(glob):
                new[i] = old.values[n]
            for d in range(len(self.drives)):
                n3 = 3 * len(self.drives[d].t)
                new[layout.pose_offset[d]:layout.pose_offset[d] + n3] = x[
                    old.pose_offset[d]:old.pose_offset[d] + n3]
                nb, ob = layout.bias_count[d], old.bias_count[d]
                if nb and ob:
                    new[layout.bias_offset[d]:layout.bias_offset[d] + nb] = x[
                        old.bias_offset[d]:old.bias_offset[d] + ob]
                elif nb:
                    new[layout.bias_offset[d]:layout.bias_offset[d] + nb] = values["gyro_bias"]
            self.x = new
        self.free = list(names)
        self.layout: Layout = layout

    def elimination_order(self) -> NDArray[np.int64]:
        """The state's columns in the order the factorisation eliminates them: each drive's
        nodes in time order, each gyro bias after the nodes of its stretch, the drives one after
        the other, and the free quantities (which touch every node) last.

        The normal matrix is then a band along the time (a node meets its neighbours, its
        stretch's bias and the quantities) with a dense border of a few quantities, which
        factorises without fill beyond the band and the border: in time and memory linear in
        the drive's length. A general ordering (minimum degree) finds much the same fill, but
        finding it takes time that grows faster than the drive (docs/calibration.md, "Long
        drives")."""
        layout = self.layout
        parts: list[NDArray[np.int64]] = []
        for d, drive in enumerate(self.drives):
            n, nb = len(drive.t), layout.bias_count[d]
            po, bo = layout.pose_offset[d], layout.bias_offset[d]
            # a node's place is its index; a bias stretch's, after the stretch's last node
            node_key = np.repeat(np.arange(n, dtype=np.float64), 3)
            ends = drive.t[0] + self.settings.bias_stretch_s * np.arange(1, nb + 1)
            bias_key = np.searchsorted(drive.t, ends, side="left") - 0.5
            if nb:
                bias_key[-1] = n - 0.5  # the last stretch takes the rest of the drive
            keys = np.concatenate([node_key, bias_key])
            columns = np.concatenate([np.arange(po, po + 3 * n), np.arange(bo, bo + nb)])
            parts.append(columns[np.argsort(keys, kind="stable")])
        parts.append(np.arange(len(layout.names)))
        return np.concatenate(parts).astype(np.int64)

    def relink(self) -> None:
        """Node of every measurement at the current time offset; re-associate unknown ids."""
        v = self.layout.values
        f = self.factors
        f.obs_k, f.obs_use, f.pose_k, f.pose_use, f.acc, f.pose_skew = [], [], [], [], [], []
        period = self.settings.pose_period_s or 0.0
        for d, drive in enumerate(self.drives):
            po = self.layout.pose_offset[d]
            pose = self.x[po:po + 3 * len(drive.t)].reshape(-1, 3)
            ds, dth = odometry_steps(drive, v, self.ppr)
            f.acc.append(interval_acceleration(drive.t, ds, dth, pose[:, 2]))
            associate_unknown(drive, pose, v, self.reflectors, self.settings.gate_m,
                              self.unknown[d])
            k, inside = _interp_index(drive, drive.obs_t - v["nav_time_offset"])
            f.obs_k.append(k)
            f.obs_use.append(inside & np.isfinite(drive.obs_lx))
            k, inside = _interp_index(drive, drive.pose_t - v["nav_time_offset"])
            f.pose_k.append(k)
            f.pose_use.append(inside & self.use_poses[d])
            rate = dth / np.maximum(np.diff(drive.t), 1e-6) if len(drive.t) > 1 else np.zeros(1)
            f.pose_skew.append(rate[k] * period / math.pi if len(k) else np.zeros(0))

    def evaluate(self, x: FloatArray, jac: bool = True) -> tuple[
            FloatArray, sp.csr_matrix | None, NDArray[np.int64], FloatArray, NDArray[np.int64]]:
        """Residuals, Jacobian, group, time and drive of every row at ``x``."""
        return evaluate(x, self.layout, self.drives, self.factors, self.settings.noise,
                        self.start, self.prior, self.settings.bias_stretch_s, self.ppr, jac)

    def robust_weights(self, r: FloatArray, grp: NDArray[np.int64]) -> FloatArray:
        """Huber weights (1 for priors)."""
        a = np.abs(r)
        k = self.settings.huber_k
        w = np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))
        return np.where(grp < 0, 1.0, w)

    def cost(self, x: FloatArray) -> float:
        """Huber cost at ``x``."""
        r, _, grp, _, _ = self.evaluate(x, jac=False)
        a = np.abs(r)
        k = self.settings.huber_k
        rho = np.where(a <= k, 0.5 * a * a, k * a - 0.5 * k * k)
        rho = np.where(grp < 0, 0.5 * a * a, rho)
        return float(rho.sum())

    def step(self, x: FloatArray, lam: float) -> FloatArray:
        """One damped Gauss-Newton step of the reweighted problem (damping ``lam`` on the
        column-scaled normal matrix): the new state."""
        h, g, norms = self._normal_equations(x)
        h = h + sp.diags(np.full(h.shape[0], lam))
        delta = Factor(h, self.elimination_order()).solve(-g)
        return np.asarray(x + delta / norms, dtype=np.float64)

    def _normal_equations(self, x: FloatArray) -> tuple[sp.csc_matrix, FloatArray, FloatArray]:
        """The reweighted problem's normal matrix and gradient at ``x``, column-scaled
        (:func:`lgvtool.sparse_normal.scaled_normal`), and the column norms. The Jacobian is
        released before they are returned, so that it and the factorisation are never held at
        once."""
        r, j, grp, _, _ = self.evaluate(x)
        assert j is not None
        jw, rw = self._weighed(j, r, grp)
        h, norms = scaled_normal(jw)
        g = (jw.T @ rw) / norms
        return h, g, norms

    def _weighed(self, j: sp.csr_matrix, r: FloatArray, grp: NDArray[np.int64]
                 ) -> tuple[sp.csr_matrix, FloatArray]:
        """The Jacobian ``j`` (its rows weighed in place) and the residuals ``r``, each row
        times the square root of its robust weight."""
        w = np.sqrt(self.robust_weights(r, grp))
        j.data *= np.repeat(w, np.diff(j.indptr))
        return j, w * r

    def gauss_newton(self) -> int:
        """Levenberg-Marquardt iterations at fixed links and noise; the number taken."""
        lam = 1e-6
        cost = self.cost(self.x)
        taken = 0
        for _ in range(self.settings.iterations):
            for _ in range(8):
                x_new = self.step(self.x, lam)
                c_new = self.cost(x_new)
                if c_new <= cost:
                    break
                lam *= 10.0
            else:
                return taken
            taken += 1
            improved = cost - c_new
            self.x = x_new
            for i, name in enumerate(self.layout.names):
                self.layout.values[name] = float(x_new[i])
            cost = c_new
            lam = max(lam / 10.0, 1e-9)
            if improved <= self.settings.tolerance * max(cost, 1.0):
                break
        return taken

    def rescale_noise(self) -> None:
        """Re-estimate each group's noise scale from its residuals (robust)."""
        r, _, grp, _, _ = self.evaluate(self.x, jac=False)
        for i, name in enumerate(GROUPS):
            sel = grp == i
            if name in RESCALED and sel.sum() >= 20:
                mad = 1.4826 * float(np.median(np.abs(r[sel])))
                if mad > 0:
                    self.factors.scale[name] *= mad

    def covariance(self, extra: list[FloatArray] | None = None
                   ) -> tuple[FloatArray, FloatArray]:
        """Formal and cluster-robust covariance of the free quantities (and of the linear
        combinations ``extra`` of the state), in state order."""
        n = len(self.layout.names)
        picks = [np.eye(1, self.layout.size, i).ravel() for i in range(n)]
        picks.extend(extra or [])
        if not picks:
            return np.zeros((0, 0)), np.zeros((0, 0))
        e = np.stack(picks, axis=1)
        h, _, norms = self._normal_equations(self.x)
        # H^-1 e in the state's units; the factor is released before the Jacobian is made again
        xs = Factor(h, self.elimination_order()).solve(e / norms[:, None]) / norms[:, None]
        formal = e.T @ xs
        del h, e
        r, j, grp, tim, drv = self.evaluate(self.x)
        assert j is not None
        jw, rw = self._weighed(j, r, grp)
        obs = grp >= 0
        keys, inv = np.unique(drv[obs] * 100_000 + np.floor(tim[obs] / self.settings.cluster_s),
                              return_inverse=True)
        cluster = np.full(len(grp), -1, dtype=np.int64)  # each row's stretch; -1: a prior
        cluster[obs] = inv
        del obs, inv
        # each stretch's sum of its rows' scores, a slice of rows and a column at a time
        u = np.zeros((len(keys), xs.shape[1]))
        for r0, r1, rows in row_slices(jw):
            scores = rows @ xs
            scores *= rw[r0:r1, None]
            at = cluster[r0:r1]
            sel = at >= 0
            for c in range(xs.shape[1]):
                u[:, c] += np.bincount(at[sel], weights=scores[sel, c], minlength=len(keys))
        robust = u.T @ u
        return formal, robust

    def residual_figures(self) -> tuple[dict[str, float], dict[str, int]]:
        """RMS of each group's normalised residuals and how many lie beyond 3 sigma."""
        r, _, grp, _, _ = self.evaluate(self.x, jac=False)
        rms: dict[str, float] = {}
        out: dict[str, int] = {}
        for i, name in enumerate(GROUPS):
            sel = grp == i
            if sel.any():
                out[name] = int((np.abs(r[sel]) > 3.0).sum())
                rms[name] = float(np.sqrt(np.mean(r[sel] ** 2)))
        return rms, out

    def poses(self) -> list[FloatArray]:
        """Trajectory of O at the nodes of each drive."""
        return [self.x[self.layout.pose_offset[d]:self.layout.pose_offset[d]
                       + 3 * len(dr.t)].reshape(-1, 3).copy()
                for d, dr in enumerate(self.drives)]

    def bias_mean_vector(self) -> tuple[FloatArray, list[FloatArray]]:
        """Linear combinations of the state: the mean gyro bias over all stretches, and per
        drive."""
        total = np.zeros(self.layout.size)
        per: list[FloatArray] = []
        count = sum(self.layout.bias_count)
        for d in range(len(self.drives)):
            nb, ob = self.layout.bias_count[d], self.layout.bias_offset[d]
            v = np.zeros(self.layout.size)
            if nb:
                v[ob:ob + nb] = 1.0 / nb
                total[ob:ob + nb] = 1.0 / count
            per.append(v)
        return total, per


def solve(problem: Problem, *, allow_unobservable: bool) -> Solution:
    """Run the rounds; check observability after the second; the uncertainties at the end.

    :raises UnobservableError: a quantity the drive does not observe, unless
        ``allow_unobservable`` (then it is held at its starting value).
    """
    unobservable: dict[str, float] = {}
    iterations = 0
    for rnd in range(problem.settings.rounds):
        problem.relink()
        iterations += problem.gauss_newton()
        problem.rescale_noise()
        if rnd == 1:
            sig_f, sig_r = _sigmas(problem)
            bad = {n: max(s, sig_r[n]) for n, s in sig_f.items()
                   if n in QUANTITIES and max(s, sig_r[n]) > QUANTITIES[n].max_sigma}
            if bad and not allow_unobservable:
                raise UnobservableError(bad)
            if bad:
                unobservable = bad
                problem.set_free([n for n in problem.free if n not in bad], problem.x)
                for n in bad:
                    problem.layout.values[n] = problem.start[n]
    problem.relink()
    iterations += problem.gauss_newton()
    sig_f, sig_r = _sigmas(problem)
    values = dict(problem.layout.values)
    total, per = problem.bias_mean_vector()
    biases = [float(v @ problem.x) if v.any() else values["gyro_bias"] for v in per]
    if "gyro_bias" in problem.free and any(problem.layout.bias_count):
        values["gyro_bias"] = float(total @ problem.x)
    rms, outliers = problem.residual_figures()
    return Solution(values=values,
                    sigma={n: max(sig_f[n], sig_r[n]) for n in sig_f},
                    sigma_formal=sig_f, unobservable=unobservable,
                    noise_scale=dict(problem.factors.scale), rms=rms, outliers=outliers,
                    bias_per_log=biases, iterations=iterations, poses=problem.poses())


class UnobservableError(Exception):
    """Quantities a drive does not observe, with their 1-sigma (SI)."""

    def __init__(self, sigma: dict[str, float]) -> None:
        super().__init__(", ".join(sigma))
        self.sigma = sigma


def _sigmas(problem: Problem) -> tuple[dict[str, float], dict[str, float]]:
    """Formal and cluster-robust 1-sigma of the free quantities (and of the mean gyro bias)."""
    names = list(problem.layout.names)
    total, _ = problem.bias_mean_vector()
    extra = [total] if "gyro_bias" in problem.free and total.any() else []
    formal, robust = problem.covariance(extra)
    if extra:
        names.append("gyro_bias")
    f = {n: math.sqrt(max(formal[i, i], 0.0)) for i, n in enumerate(names)}
    r = {n: math.sqrt(max(robust[i, i], 0.0)) for i, n in enumerate(names)}
    return f, r
