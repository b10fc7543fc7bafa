"""``layout refine``: a least-squares adjustment of the reflector layout over whole drives.

Unknowns (SI: m, rad): the pose of O ``(x, y, heading)`` at every landmark scan of each drive
(a *node*; one per scan with an associated landmark), every layout reflector's position
``(x, y)`` (not those held fixed), every reflector's own constant range offset (tape
against cylinder, diameter tolerance, incidence: :attr:`RefineSettings.range_offset_sigma_m`)
and one range offset common to all (the head's own, m).
Every residual is divided by its standard deviation, so the cost is the sum of squared
normalised residuals. The factors:

- **odometry** between consecutive nodes: the body-frame motion of the project's odometry
  track (:class:`lgvtool.localize.motion.MotionTrack`, the fusion and step form of the
  configuration's ``[estimators.ekf]``) against the motion between the two node poses, with
  that estimator's motion noise model (:meth:`lgvtool.localize.noise.MotionParams.noise_sigmas`,
  along, across, heading), never below :attr:`RefineSettings.motion_floor_m` and
  :attr:`RefineSettings.motion_floor_rad`;
- **landmark** observations: range and bearing from the NAV head to the reflector. Each is
  measured at its own instant (scan start plus its time in the scan): the pose then is the
  node's composed with the odometry from the node's time to that instant (known, so each
  observation has its own lever arm, :attr:`Drive.obs_mx`), the head at ``(nav_x, nav_y)`` of
  the configuration's vehicle (its ``nav_yaw`` and ``nav_time_offset`` already applied to the
  data, :mod:`lgvtool.localize.installation`);
- **the surveyed layout** as a prior on each free reflector, ``survey_sigma_m`` per axis, and
  a zero-mean prior of ``range_offset_sigma_m`` on each range offset.

The NAV poses are left out: the NAV computes them from the same landmark observations, so
they would count the same evidence twice.

An observation is associated by the device's layout id (the NAV350's global id of its match),
checked against the layout with :func:`lgvtool.localize.association.associate_points` at the
first pose of its node (an id whose reflector lies beyond :attr:`RefineSettings.gate_m` gives
way to the nearest unambiguous reflector in the gate, else the observation is left out).
Observations without an id (the device matched nothing: an object not in the layout, a
reflector moved beyond its own gate) are left out.

Solved by damped Gauss-Newton on the sparse normal equations
(:mod:`lgvtool.sparse_normal`: columns scaled to unit norm, SuperLU, the nodes eliminated in
time order and the reflectors last), with Huber weights on the observations, in rounds after
each of which the range and bearing noise are re-estimated from their residuals (1.4826 x the
median absolute normalised residual). A reflector's 1-sigma is the square root of the
diagonal of its 2x2 block of the inverse normal matrix (the factor solved for the
reflectors' columns).

Pure: values in, values out (the log is read by :mod:`lgvtool.app.layout_job`). Needs scipy
(the ``calibrate`` extra).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from lgvtool.angles import wrap_angle
from lgvtool.config import Reflector, Vehicle
from lgvtool.declared import make, setting
from lgvtool.errors import MissingDataError
from lgvtool.localize.logdata import LogData, scan_batch
from lgvtool.localize.noise import MotionParams

if TYPE_CHECKING:
    import scipy.sparse as sp

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

__all__ = ["Drive", "RefineSettings", "RefinedReflector", "Refinement", "prepare_drive",
           "refine", "refine_settings"]


@dataclass(frozen=True)
class RefineSettings:
    """How ``layout refine`` weighs the drive against the surveyed layout (``--set KEY=VALUE``)."""

    survey_sigma_m: float = setting(
        0.02,
        "Standard deviation of the surveyed layout, per reflector and axis, m: the prior that "
        "holds each reflector near its stored position. State your survey's: a total-station "
        "survey 0.005-0.02 m, a tape survey 0.02-0.05 m.",
        unit="m", minimum=0.0, min_open=True, maximum=10.0)
    range_sigma_m: float = setting(
        0.015,
        "Starting range noise of a landmark observation, m (re-estimated from the residuals).",
        unit="m", minimum=0.0, min_open=True, maximum=1.0)
    range_sigma_per_m: float = setting(
        0.001,
        "Growth of the starting range noise with the range, m per m.",
        unit="m/m", minimum=0.0, maximum=0.1)
    bearing_sigma_rad: float = setting(
        0.001,
        "Starting bearing noise of a landmark observation, rad (re-estimated from the "
        "residuals).",
        unit="rad", minimum=0.0, min_open=True, maximum=0.5)
    range_offset_sigma_m: float = setting(
        0.005,
        "Standard deviation of each reflector's own constant range offset (tape against "
        "cylinder, diameter tolerance), m: estimated per reflector with this prior; 0: none.",
        unit="m", minimum=0.0, maximum=0.5)
    motion_floor_m: float = setting(
        0.0005,
        "Least standard deviation of an odometry step along and across, m (a standstill's "
        "odometry is not exact).",
        unit="m", minimum=0.0, min_open=True, maximum=1.0)
    motion_floor_rad: float = setting(
        0.0002,
        "Least standard deviation of an odometry step's heading change, rad.",
        unit="rad", minimum=0.0, min_open=True, maximum=1.0)
    gate_m: float = setting(
        0.3,
        "An observation's id is taken when its reflector lies within this of where the "
        "observation puts it, m (from the first poses); else the nearest unambiguous one in it.",
        unit="m", minimum=0.0, min_open=True, maximum=10.0)
    huber_k: float = setting(
        2.0,
        "Huber loss threshold of the observations, standard deviations.",
        unit="", minimum=0.5, maximum=100.0)
    robust_survey: bool = setting(
        True,
        "The surveyed positions under the Huber loss too: a reflector that moved far beyond "
        "survey_sigma_m pulls the rest of the layout less.",
        unit="")
    rounds: int = setting(
        3, "Rounds of Gauss-Newton steps, the noise re-estimated after each.",
        unit="", minimum=1, maximum=20)
    iterations: int = setting(
        10, "Gauss-Newton steps per round at most.", unit="", minimum=1, maximum=100)


def refine_settings(overrides: Mapping[str, object] | None = None) -> RefineSettings:
    """:class:`RefineSettings` with ``overrides`` (``{key: value}``, each checked).

    :raises ConfigError: (exit 2) an unknown key or a bad value, naming ``refine.key``.
    """
    return make(RefineSettings, "refine", dict(overrides or {}), what="setting")


@dataclass(frozen=True)
class Drive:
    """One log prepared for the adjustment: nodes, the odometry between them, observations.

    Times in s after the log's first message; lengths m, angles rad.
    """

    name: str
    node_t: FloatArray
    """Time of each node (the start of its scan), s."""
    start: FloatArray
    """First pose of O at each node, (n, 3): a fix from the scan's landmarks, else the
    odometry from the nearest fixed node."""
    odo: FloatArray
    """Odometry between consecutive nodes, (n-1, 3): body-frame dx, dy (m), dheading (rad)."""
    odo_sigma: FloatArray
    """Its standard deviations, (n-1, 3): along, across (m), heading (rad)."""
    obs_node: IntArray
    """Node of each used observation."""
    obs_mx: FloatArray
    """The head's position at the observation's instant in the node's frame, x, m."""
    obs_my: FloatArray
    obs_dth: FloatArray
    """Heading change from the node to the observation's instant, rad."""
    obs_range: FloatArray
    """Measured range, m."""
    obs_bearing: FloatArray
    """Measured bearing from the vehicle's x axis, rad."""
    obs_ref: IntArray
    """Layout index of the associated reflector."""
    counts: dict[str, int] = field(default_factory=dict)
    """Observations ``total``, ``used``, ``without_id`` (left out), ``not_associated``
    (their id and the gate disagree and nothing else fits: left out)."""

    @property
    def nodes(self) -> int:
        """Number of nodes."""
        return len(self.node_t)


def _layout_arrays(layout: Sequence[Reflector]) -> tuple[IntArray, FloatArray, FloatArray]:
    """The layout's ids, x and y (m), in layout order."""
    return (np.array([r.id for r in layout], dtype=np.int64),
            np.array([r.x for r in layout], dtype=np.float64),
            np.array([r.y for r in layout], dtype=np.float64))


def _fixes(node_of: IntArray, n: int, qx: FloatArray, qy: FloatArray, ref: IntArray,
           lx: FloatArray, ly: FloatArray) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Pose of O at each node from its observations' points ``(qx, qy)`` in the node's frame
    and their layout reflectors ``ref`` (2-D Kabsch, at least two distinct reflectors), and
    which nodes have one."""
    from lgvtool.localize.geometry import pose_from_correspondences

    pose = np.zeros((n, 3))
    ok = np.zeros(n, dtype=bool)
    bounds = np.searchsorted(node_of, np.arange(n + 1))
    for k in range(n):
        a, e = int(bounds[k]), int(bounds[k + 1])
        if e - a < 2 or len(np.unique(ref[a:e])) < 2:
            continue
        fix = pose_from_correspondences(qx[a:e], qy[a:e], lx[ref[a:e]], ly[ref[a:e]])
        if fix is not None:
            pose[k] = fix
            ok[k] = True
    return pose, ok


def _chain(fix: FloatArray, ok: NDArray[np.bool_], odo: FloatArray) -> FloatArray:
    """Every node's pose: the fixed ones as they are, the others the odometry composed from the
    last fixed node before them (or back from the first one after, at the start)."""
    from lgvtool.localize.geometry import compose

    n = len(fix)
    out = fix.copy()
    first = int(np.argmax(ok))
    for k in range(first - 1, -1, -1):  # back from the first fix
        dx, dy, dth = odo[k]
        th = out[k + 1, 2] - dth
        c, s = math.cos(th), math.sin(th)
        out[k] = (out[k + 1, 0] - (c * dx - s * dy), out[k + 1, 1] - (s * dx + c * dy), th)
    for k in range(first + 1, n):
        if not ok[k]:
            x, y, th = compose(out[k - 1, 0], out[k - 1, 1], out[k - 1, 2], *odo[k - 1])
            out[k] = (float(x), float(y), float(th))
    return out


def prepare_drive(name: str, data: LogData, vehicle: Vehicle, layout: Sequence[Reflector],
                  motion: MotionParams, settings: RefineSettings) -> Drive:
    """A :class:`Drive` from a log's data, with the installation of ``vehicle`` applied
    already (:func:`lgvtool.localize.installation.apply_installation`).

    :raises MissingDataError: (exit 2) no motion data, no landmark observations (a NAV200 log:
        poses only), none with a layout id, or none that fixes a pose.
    """
    from lgvtool.localize.association import associate_points
    from lgvtool.localize.motion import MotionTrack

    if not data.has_motion:
        raise MissingDataError(f"{name}: no motion data (/mcu/frame or /odom/twist)")
    b = scan_batch(data.scans)
    if len(b.ranges) == 0:
        raise MissingDataError(
            f"{name}: no landmark observations (/nav/reflectors): layout refine needs a "
            "NAV350 recording's landmarks (a NAV200 recording holds poses only)")
    ids, lx, ly = _layout_arrays(layout)
    order = np.argsort(ids)
    at = np.clip(np.searchsorted(ids[order], b.ids), 0, len(ids) - 1)
    known = np.where(ids[order][at] == b.ids, order[at], -1).astype(np.int64)
    total = len(b.ranges)
    without_id = int((known < 0).sum())
    if without_id == total:
        raise MissingDataError(f"{name}: none of its {total} landmark observations carries an "
                               "id of the layout")
    owner = np.repeat(np.arange(len(b.t)), b.counts)
    keep = known >= 0
    owner, known = owner[keep], known[keep]
    rng, brg, tin = b.ranges[keep], b.bearings[keep], b.times[keep]
    scans, node_of = np.unique(owner, return_inverse=True)
    node_of = node_of.astype(np.int64)
    node_t = b.t[scans]
    n = len(node_t)
    track = MotionTrack(data.increments(motion.motion_settings(), vehicle), motion.step_form)
    d = track.deltas(node_t[node_of], node_t[node_of] + tin)
    c, s = np.cos(d.dth), np.sin(d.dth)
    mx = d.dx + c * vehicle.nav_x - s * vehicle.nav_y
    my = d.dy + s * vehicle.nav_x + c * vehicle.nav_y
    qx = mx + rng * np.cos(d.dth + brg)
    qy = my + rng * np.sin(d.dth + brg)
    step = track.deltas(node_t[:-1], node_t[1:])
    odo = np.stack([step.dx, step.dy, step.dth], axis=1)
    along, across, turn = motion.noise_sigmas(step.dist, step.rot)
    sigma = np.stack([np.maximum(along, settings.motion_floor_m),
                      np.maximum(across, settings.motion_floor_m),
                      np.maximum(turn, settings.motion_floor_rad)], axis=1)
    fix, ok = _fixes(node_of, n, qx, qy, known, lx, ly)
    if not ok.any():
        raise MissingDataError(f"{name}: no scan sees two layout reflectors by their ids: no "
                               "pose to start from")
    start = _chain(fix, ok, odo)
    # the ids checked against the layout at the first poses
    p = start[node_of]
    cp, sp_ = np.cos(p[:, 2]), np.sin(p[:, 2])
    wx = p[:, 0] + cp * qx - sp_ * qy
    wy = p[:, 1] + sp_ * qx + cp * qy
    ref, _how = associate_points(wx + 1j * wy, lx + 1j * ly, known, settings.gate_m, 2.0)
    used = ref >= 0
    counts = {"total": total, "used": int(used.sum()), "without_id": without_id,
              "not_associated": int((~used).sum())}
    return Drive(name=name, node_t=node_t, start=start, odo=odo, odo_sigma=sigma,
                 obs_node=node_of[used], obs_mx=mx[used], obs_my=my[used], obs_dth=d.dth[used],
                 obs_range=rng[used], obs_bearing=brg[used], obs_ref=ref[used], counts=counts)


# ------------------------------------------------------------------------------ the problem

_RANGE, _BEARING, _ODOMETRY, _SURVEY, _PRIOR = 0, 1, 2, 3, 4


@dataclass(frozen=True)
class _Columns:
    """Where everything sits in the state: each drive's poses from its offset (3 per node),
    then per layout reflector its x, y columns (-1: held fixed) and its range offset's
    (-1: not estimated)."""

    pose: list[int]
    ref_x: IntArray
    ref_y: IntArray
    offset: IntArray
    common: int
    """The column of the range offset common to every reflector (the head's own)."""
    size: int


def _columns(drives: Sequence[Drive], fixed: NDArray[np.bool_], offsets: bool) -> _Columns:
    """The state's layout for ``drives``, the reflectors ``fixed`` held, with a range offset
    per reflector when ``offsets``."""
    pose: list[int] = []
    at = 0
    for d in drives:
        pose.append(at)
        at += 3 * d.nodes
    m = len(fixed)
    ref_x = np.full(m, -1, dtype=np.int64)
    ref_y = np.full(m, -1, dtype=np.int64)
    free = np.flatnonzero(~fixed)
    ref_x[free] = at + 2 * np.arange(len(free))
    ref_y[free] = ref_x[free] + 1
    at += 2 * len(free)
    offset = np.full(m, -1, dtype=np.int64)
    if offsets:
        offset[:] = at + np.arange(m)
        at += m
    return _Columns(pose, ref_x, ref_y, offset, at, at + 1)


class _Rows:
    """Residuals and the Jacobian's entries, collected as coordinates."""

    def __init__(self) -> None:
        self.res: list[FloatArray] = []
        self.group: list[IntArray] = []
        self.rows: list[IntArray] = []
        self.cols: list[IntArray] = []
        self.vals: list[FloatArray] = []
        self.n = 0

    def add(self, e: FloatArray, group: int,
            terms: Sequence[tuple[IntArray | int, FloatArray | float]]) -> None:
        """Residuals ``e`` and their derivatives ``[(columns, values), ...]`` (a column -1 is
        held fixed and left out)."""
        m = len(e)
        if m == 0:
            return
        r = self.n + np.arange(m, dtype=np.int64)
        self.res.append(np.asarray(e, dtype=np.float64))
        self.group.append(np.full(m, group, dtype=np.int64))
        for col, val in terms:
            c = np.broadcast_to(np.asarray(col, dtype=np.int64), (m,))
            v = np.broadcast_to(np.asarray(val, dtype=np.float64), (m,))
            keep = c >= 0
            self.rows.append(r[keep])
            self.cols.append(c[keep])
            self.vals.append(v[keep])
        self.n += m


@dataclass
class _Problem:
    """The least squares over ``drives``: the surveyed layout ``lx``, ``ly`` (m), the
    reflectors ``fixed``, the settings and the state's columns."""

    drives: Sequence[Drive]
    lx: FloatArray
    ly: FloatArray
    fixed: NDArray[np.bool_]
    settings: RefineSettings
    cols: _Columns
    scale: list[float] = field(default_factory=lambda: [1.0, 1.0])
    """Noise scale of the range and the bearing residuals (x their starting noise)."""

    def unpack(self, x: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Reflector x, y (m) and range offsets (m: each reflector's own, without the common
        one) at state ``x``."""
        c = self.cols
        rx = np.where(c.ref_x >= 0, x[np.maximum(c.ref_x, 0)], self.lx)
        ry = np.where(c.ref_y >= 0, x[np.maximum(c.ref_y, 0)], self.ly)
        off = np.where(c.offset >= 0, x[np.maximum(c.offset, 0)], 0.0)
        return rx, ry, off

    def evaluate(self, x: FloatArray, jac: bool = True
                 ) -> tuple[FloatArray, sp.csr_matrix | None, IntArray]:
        """Normalised residuals, the Jacobian (a CSR matrix, or None) and each row's group."""
        import scipy.sparse as sp

        st = self.settings
        c = self.cols
        rows = _Rows()
        rx, ry, off = self.unpack(x)
        sr0, sb0 = self.scale
        for d, drive in enumerate(self.drives):
            po = c.pose[d]
            n = drive.nodes
            pose = x[po:po + 3 * n].reshape(n, 3)
            cx = po + 3 * np.arange(n, dtype=np.int64)
            # odometry: the motion between the node poses in the earlier one's frame
            if n > 1:
                px, py, pth = pose[:-1, 0], pose[:-1, 1], pose[:-1, 2]
                co, so = np.cos(pth), np.sin(pth)
                ex, ey = pose[1:, 0] - px, pose[1:, 1] - py
                bx, by = co * ex + so * ey, -so * ex + co * ey
                bth = wrap_angle(pose[1:, 2] - pth - drive.odo[:, 2])
                sa, sc, sh = drive.odo_sigma[:, 0], drive.odo_sigma[:, 1], drive.odo_sigma[:, 2]
                x0, y0, t0 = cx[:-1], cx[:-1] + 1, cx[:-1] + 2
                x1, y1, t1 = cx[1:], cx[1:] + 1, cx[1:] + 2
                rows.add((bx - drive.odo[:, 0]) / sa, _ODOMETRY, [
                    (x0, -co / sa), (y0, -so / sa), (t0, by / sa), (x1, co / sa), (y1, so / sa)])
                rows.add((by - drive.odo[:, 1]) / sc, _ODOMETRY, [
                    (x0, so / sc), (y0, -co / sc), (t0, -bx / sc), (x1, -so / sc),
                    (y1, co / sc)])
                rows.add(bth / sh, _ODOMETRY, [(t0, -1.0 / sh), (t1, 1.0 / sh)])
            # landmarks: range and bearing from the head at the observation's instant
            k = drive.obs_node
            j = drive.obs_ref
            th = pose[k, 2]
            co, so = np.cos(th), np.sin(th)
            hx = pose[k, 0] + co * drive.obs_mx - so * drive.obs_my
            hy = pose[k, 1] + so * drive.obs_mx + co * drive.obs_my
            dhx_dth = -so * drive.obs_mx - co * drive.obs_my
            dhy_dth = co * drive.obs_mx - so * drive.obs_my
            ux, uy = rx[j] - hx, ry[j] - hy
            r2 = np.maximum(ux * ux + uy * uy, 1e-12)
            rho = np.sqrt(r2)
            sr = (st.range_sigma_m + st.range_sigma_per_m * drive.obs_range) * sr0
            e = (rho + off[j] + x[c.common] - drive.obs_range) / sr
            gx, gy = ux / rho / sr, uy / rho / sr  # d range / d reflector
            rows.add(e, _RANGE, [
                (cx[k], -gx), (cx[k] + 1, -gy), (cx[k] + 2, -(gx * dhx_dth + gy * dhy_dth)),
                (c.ref_x[j], gx), (c.ref_y[j], gy), (c.offset[j], 1.0 / sr),
                (c.common, 1.0 / sr)])
            sb = st.bearing_sigma_rad * sb0
            pred = np.arctan2(uy, ux) - th - drive.obs_dth
            e = wrap_angle(pred - drive.obs_bearing) / sb
            gx, gy = -uy / r2 / sb, ux / r2 / sb  # d bearing / d reflector
            rows.add(e, _BEARING, [
                (cx[k], -gx), (cx[k] + 1, -gy),
                (cx[k] + 2, -(gx * dhx_dth + gy * dhy_dth) - 1.0 / sb),
                (c.ref_x[j], gx), (c.ref_y[j], gy)])
        # the surveyed layout and the range offsets
        free = np.flatnonzero(~self.fixed)
        ss = st.survey_sigma_m
        rows.add((rx[free] - self.lx[free]) / ss, _SURVEY, [(c.ref_x[free], 1.0 / ss)])
        rows.add((ry[free] - self.ly[free]) / ss, _SURVEY, [(c.ref_y[free], 1.0 / ss)])
        if st.range_offset_sigma_m > 0:
            so_ = st.range_offset_sigma_m
            rows.add(off / so_, _PRIOR, [(c.offset, 1.0 / so_)])
        res = np.concatenate(rows.res)
        grp = np.concatenate(rows.group)
        if not jac:
            return res, None, grp
        j_mat = sp.csr_matrix((np.concatenate(rows.vals), (np.concatenate(rows.rows),
                                                           np.concatenate(rows.cols))),
                              shape=(rows.n, c.size))
        return res, j_mat, grp

    def weights(self, r: FloatArray, grp: IntArray) -> FloatArray:
        """Huber weights of the observations (1 for the odometry and the priors)."""
        a = np.abs(r)
        k = self.settings.huber_k
        w = np.where(a <= k, 1.0, k / np.maximum(a, 1e-12))
        return np.where(self.robust(grp), w, 1.0)

    def robust(self, grp: IntArray) -> NDArray[np.bool_]:
        """The rows under the Huber loss: the observations, and the survey's with
        :attr:`RefineSettings.robust_survey`."""
        out = grp <= _BEARING
        if self.settings.robust_survey:
            out |= grp == _SURVEY
        return out

    def cost(self, x: FloatArray) -> float:
        """Huber cost at ``x``."""
        r, _, grp = self.evaluate(x, jac=False)
        a = np.abs(r)
        k = self.settings.huber_k
        rho = np.where((a > k) & self.robust(grp), k * a - 0.5 * k * k, 0.5 * a * a)
        return float(rho.sum())

    def order(self) -> IntArray:
        """Elimination order: each drive's nodes in time order, the reflectors last."""
        return np.arange(self.cols.size, dtype=np.int64)

    def normal(self, x: FloatArray) -> tuple[sp.csc_matrix, FloatArray, FloatArray]:
        """The reweighted, column-scaled normal matrix, gradient and column norms at ``x``
        (:func:`lgvtool.sparse_normal.scaled_normal`)."""
        from lgvtool.sparse_normal import scaled_normal

        r, j, grp = self.evaluate(x)
        assert j is not None
        w = np.sqrt(self.weights(r, grp))
        j.data *= np.repeat(w, np.diff(j.indptr))  # each row times its weight's root
        h, norms = scaled_normal(j)
        g = np.asarray(j.T @ (w * r), dtype=np.float64) / norms
        return h, g, norms


def _step(problem: _Problem, x: FloatArray, lam: float) -> FloatArray:
    """One damped Gauss-Newton step (damping ``lam`` on the column-scaled normal matrix)
    from ``x``: the new state."""
    import scipy.sparse as sp

    from lgvtool.sparse_normal import Factor

    h, g, norms = problem.normal(x)
    damped = (h + sp.diags(np.full(h.shape[0], lam))).tocsc()
    delta = Factor(damped, problem.order()).solve(-g)
    return np.asarray(x + delta / norms, dtype=np.float64)


def _gauss_newton(problem: _Problem, x: FloatArray) -> tuple[FloatArray, int]:
    """Levenberg-Marquardt steps at fixed noise; the state and the steps taken."""
    lam = 1e-6
    cost = problem.cost(x)
    taken = 0
    for _ in range(problem.settings.iterations):
        for _ in range(8):
            x_new = _step(problem, x, lam)
            c_new = problem.cost(x_new)
            if c_new <= cost:
                break
            lam *= 10.0
        else:
            break
        taken += 1
        improved = cost - c_new
        x, cost = x_new, c_new
        lam = max(lam / 10.0, 1e-9)
        if improved <= 1e-6 * max(cost, 1.0):
            break
    return x, taken


# ------------------------------------------------------------------------------ the result


@dataclass(frozen=True)
class RefinedReflector:
    """One layout reflector after the adjustment (m)."""

    reflector: Reflector
    """The reflector at its refined position (id, radius and layer as in the layout)."""
    surveyed: Reflector
    """The reflector as the layout had it."""
    sigma_x: float
    """1-sigma of the refined x, m (0 when held fixed)."""
    sigma_y: float
    """1-sigma of the refined y, m."""
    correlation: float
    """Correlation of the x and y errors."""
    observations: int
    """Landmark observations of it that took part."""
    fixed: bool
    """Held at its surveyed position (``--fix``)."""
    range_offset: float
    """Its estimated constant range offset, m (0 when not estimated)."""

    @property
    def shift(self) -> tuple[float, float]:
        """Refined minus surveyed position, m."""
        return (self.reflector.x - self.surveyed.x, self.reflector.y - self.surveyed.y)


@dataclass(frozen=True)
class Refinement:
    """What the adjustment found."""

    reflectors: tuple[RefinedReflector, ...]
    """Every layout reflector, in layout order."""
    poses: tuple[FloatArray, ...]
    """The adjusted pose of O at each node of each drive, (n, 3) m, m, rad."""
    node_t: tuple[FloatArray, ...]
    """Each drive's node times, s after its log's first message."""
    iterations: int
    """Gauss-Newton steps taken."""
    noise: dict[str, float]
    """The re-estimated noise: ``range_m`` (at 0 m), ``bearing_rad``."""
    rms: dict[str, float]
    """RMS of each group's normalised residuals (``range``, ``bearing``, ``odometry``)."""
    counts: dict[str, int]
    """Observations over all drives: ``total``, ``used``, ``without_id``, ``not_associated``;
    and ``nodes``."""
    common_range_offset: float
    """The range offset common to every reflector (the head's own), m."""

    @property
    def layout(self) -> tuple[Reflector, ...]:
        """The refined layout."""
        return tuple(r.reflector for r in self.reflectors)


def refine(drives: Sequence[Drive], layout: Sequence[Reflector], fixed_ids: Sequence[int],
           settings: RefineSettings) -> Refinement:
    """Adjust ``layout`` (and the drives' poses) to the drives' odometry and landmarks, the
    reflectors of ``fixed_ids`` held at their surveyed positions (the module docstring)."""
    from lgvtool.sparse_normal import Factor

    ids, lx, ly = _layout_arrays(layout)
    fixed = np.isin(ids, np.asarray(list(fixed_ids), dtype=np.int64))
    cols = _columns(drives, fixed, settings.range_offset_sigma_m > 0)
    problem = _Problem(drives, lx, ly, fixed, settings, cols)
    x = np.zeros(cols.size)
    for d, drive in enumerate(drives):
        x[cols.pose[d]:cols.pose[d] + 3 * drive.nodes] = drive.start.ravel()
    free = cols.ref_x >= 0
    x[cols.ref_x[free]] = lx[free]
    x[cols.ref_y[free]] = ly[free]
    iterations = 0
    for _ in range(settings.rounds):
        x, taken = _gauss_newton(problem, x)
        iterations += taken
        res, _, grp = problem.evaluate(x, jac=False)
        for g in (_RANGE, _BEARING):
            sel = grp == g
            if sel.sum() >= 20:
                mad = 1.4826 * float(np.median(np.abs(res[sel])))
                if mad > 0:
                    problem.scale[g] *= mad
    x, taken = _gauss_newton(problem, x)
    iterations += taken
    # the reflectors' 2x2 blocks of the inverse normal matrix
    h, _, norms = problem.normal(x)
    picks = np.concatenate([cols.ref_x[free], cols.ref_y[free]])
    e = np.zeros((cols.size, len(picks)))
    e[picks, np.arange(len(picks))] = 1.0
    cov_cols = Factor(h, problem.order()).solve(e / norms[:, None]) / norms[:, None]
    nf = int(free.sum())
    var_x = cov_cols[cols.ref_x[free], np.arange(nf)]
    var_y = cov_cols[cols.ref_y[free], nf + np.arange(nf)]
    cov_xy = cov_cols[cols.ref_x[free], nf + np.arange(nf)]
    sx = np.zeros(len(layout))
    sy = np.zeros(len(layout))
    rho = np.zeros(len(layout))
    sx[free] = np.sqrt(np.maximum(var_x, 0.0))
    sy[free] = np.sqrt(np.maximum(var_y, 0.0))
    rho[free] = cov_xy / np.maximum(sx[free] * sy[free], 1e-300)
    rx, ry, off = problem.unpack(x)
    seen = np.zeros(len(layout), dtype=np.int64)
    for drive in drives:
        seen += np.bincount(drive.obs_ref, minlength=len(layout))
    out = []
    for i, r in enumerate(layout):
        out.append(RefinedReflector(
            reflector=Reflector(r.id, float(rx[i]), float(ry[i]), r.radius, r.layer),
            surveyed=r, sigma_x=float(sx[i]), sigma_y=float(sy[i]), correlation=float(rho[i]),
            observations=int(seen[i]), fixed=bool(fixed[i]), range_offset=float(off[i])))
    res, _, grp = problem.evaluate(x, jac=False)
    rms = {name: float(np.sqrt(np.mean(res[grp == g] ** 2)))
           for name, g in (("range", _RANGE), ("bearing", _BEARING), ("odometry", _ODOMETRY))
           if (grp == g).any()}
    counts = {key: sum(d.counts.get(key, 0) for d in drives)
              for key in ("total", "used", "without_id", "not_associated")}
    counts["nodes"] = sum(d.nodes for d in drives)
    return Refinement(
        reflectors=tuple(out),
        poses=tuple(x[cols.pose[d]:cols.pose[d] + 3 * dr.nodes].reshape(-1, 3).copy()
                    for d, dr in enumerate(drives)),
        node_t=tuple(dr.node_t for dr in drives), iterations=iterations,
        noise={"range_m": settings.range_sigma_m * problem.scale[_RANGE],
               "bearing_rad": settings.bearing_sigma_rad * problem.scale[_BEARING]},
        rms=rms, counts=counts, common_range_offset=float(x[cols.common]))
