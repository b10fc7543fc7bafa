"""The one trajectory type: poses over time, of the target rotation centre O unless its maker
says otherwise (the audit's track of the NAV head, :class:`lgvtool.audit.coverage.HeadTrack`).

Every part that carries a trajectory carries a :class:`Trajectory`: the estimators' rows and
``replay``'s estimates (with their covariance, particle count and ESS), the log's ground truth
and the simulator's, the trajectories ``evaluate`` scores and those ``export`` writes or
reads back from other tools' files.

Units:

- ``t``: s, counted from ``t0_ns`` (int ns since the Unix epoch; 0, the default: ``t`` is s
  since the Unix epoch, the log time as ``evaluate`` and ``export`` use it). ``replay`` keeps
  its estimates in s after the log's first message (``t0_ns`` the first message's time), so
  that :attr:`Trajectory.t_ns` gives back the exact ns stamps of the log;
- ``x``, ``y``: m, in the map frame;
- ``heading``: rad, counter-clockwise from the map x axis, on whichever branch its maker
  gave it: ``replay``'s estimates and :meth:`Trajectory.interpolate` wrap it into
  (-pi, pi]; an estimator's own rows and the simulator's truth keep it continuous; a log's
  truth has twice its quaternion's angle. No operation depends on the branch (interpolation
  unwraps first); :meth:`Trajectory.wrapped` and :meth:`Trajectory.unwrapped` give either;
- ``covariance`` (optional): per row the row-major 3x3 covariance of (x, y, heading), m^2,
  m rad, rad^2; ``particles`` (optional): particle count per row; ``ess`` (optional):
  effective sample size per row.

Times never decrease (equal times are allowed; :meth:`Trajectory.cleaned` sorts, drops rows
without a finite time or position and keeps the last row of equal times, for input from
files and logs). The type is pure (no file, no clock) and needs numpy only; pandas users
convert with :meth:`Trajectory.from_frame` and :meth:`Trajectory.to_frame`. The arrays are
shared, not copied: treat them as read-only.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from lgvtool.angles import wrap_angle
from lgvtool.errors import InputError
from lgvtool.timestamps import seconds_to_ns_array

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["COLUMNS", "SYNC_MAX_GAP", "FloatArray", "Trajectory"]

FloatArray = NDArray[np.float64]

COLUMNS = ("t", "x", "y", "heading")
"""The DataFrame columns of a trajectory (:meth:`Trajectory.to_frame`): s, m, m, rad."""

SYNC_MAX_GAP = 0.5
"""Longest gap between two samples of the reference that :meth:`Trajectory.sync` always
bridges, s; longer ones are bridged while within 5 times its median sampling interval."""

_EXTRAS = ("covariance", "particles", "ess")


def _floats(a: ArrayLike) -> FloatArray:
    return np.asarray(a, dtype=np.float64)


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Poses of O at times: ``t`` (s after ``t0_ns``), ``x``, ``y`` (m), ``heading`` (rad),
    optional per-row ``covariance`` (n x 9, m^2, m rad, rad^2), ``particles`` and ``ess``
    (units and conventions: the module's docstring).

    :raises ValueError: arrays of different lengths, a column that is not one-dimensional, a
        covariance that is not n x 9, or decreasing times.
    """

    t: FloatArray
    x: FloatArray
    y: FloatArray
    heading: FloatArray
    t0_ns: int = 0
    """Origin of ``t``, int ns since the Unix epoch (0: ``t`` is s since the epoch)."""
    covariance: FloatArray | None = None
    particles: NDArray[np.int64] | None = None
    ess: FloatArray | None = None

    def __post_init__(self) -> None:
        put = object.__setattr__
        for name in COLUMNS:
            put(self, name, _floats(getattr(self, name)))
        n = len(self.t)
        for name in COLUMNS:
            a = getattr(self, name)
            if a.ndim != 1 or len(a) != n:
                raise ValueError(f"trajectory column '{name}' has shape {a.shape}, expected "
                                 f"({n},) as t")
        if self.covariance is not None:
            cov = _floats(self.covariance)
            if cov.shape != (n, 9):
                raise ValueError(f"trajectory covariance has shape {cov.shape}, expected "
                                 f"({n}, 9)")
            put(self, "covariance", cov)
        if self.particles is not None:
            put(self, "particles", np.asarray(self.particles, dtype=np.int64))
        if self.ess is not None:
            put(self, "ess", _floats(self.ess))
        for name in ("particles", "ess"):
            a = getattr(self, name)
            if a is not None and (a.ndim != 1 or len(a) != n):
                raise ValueError(f"trajectory column '{name}' has shape {a.shape}, expected "
                                 f"({n},) as t")
        if n > 1 and not bool(np.all(self.t[1:] >= self.t[:-1])):
            k = int(np.argmax(self.t[1:] < self.t[:-1]))
            raise ValueError(f"trajectory times decrease at row {k + 1} ({self.t[k]!r} s, "
                             f"then {self.t[k + 1]!r} s); use Trajectory.cleaned to sort")
        put(self, "t0_ns", int(self.t0_ns))

    # ------------------------------------------------------------------------ making one

    @classmethod
    def empty(cls, t0_ns: int = 0) -> Trajectory:
        """A trajectory without a pose."""
        none = np.array([], dtype=np.float64)
        return cls(none, none, none, none, t0_ns)

    @classmethod
    def cleaned(cls, t: ArrayLike, x: ArrayLike, y: ArrayLike,
                heading: ArrayLike | None = None, t0_ns: int = 0) -> Trajectory:
        """The poses of unordered input (a file, a log's table): rows without a finite time
        or position dropped, sorted by time (stably), of equal times the last one kept. A
        missing heading (None) is NaN; a heading that is not finite stays as it is."""
        tt, xx, yy = _floats(t), _floats(x), _floats(y)
        hh = np.full(len(tt), np.nan) if heading is None else _floats(heading)
        ok = np.isfinite(tt) & np.isfinite(xx) & np.isfinite(yy)
        if not bool(np.all(ok)):
            tt, xx, yy, hh = tt[ok], xx[ok], yy[ok], hh[ok]
        if len(tt) > 1 and not bool(np.all(tt[1:] > tt[:-1])):
            order = np.argsort(tt, kind="stable")
            tt, xx, yy, hh = tt[order], xx[order], yy[order], hh[order]
            last = np.concatenate([tt[1:] != tt[:-1], [True]])
            tt, xx, yy, hh = tt[last], xx[last], yy[last], hh[last]
        return cls(tt, xx, yy, hh, t0_ns)

    def clean(self) -> Trajectory:
        """This trajectory cleaned as :meth:`cleaned` cleans (no extras kept)."""
        return Trajectory.cleaned(self.t, self.x, self.y, self.heading, self.t0_ns)

    @classmethod
    def from_frame(cls, df: pd.DataFrame, t0_ns: int = 0, *, name: str = "") -> Trajectory:
        """The trajectory of a DataFrame with columns t (s after ``t0_ns``), x, y (m) and
        optionally heading (rad), cleaned as :meth:`cleaned` cleans (values that are not
        numbers count as missing).

        :raises InputError: a frame without t, x or y (``name`` names the trajectory).
        """
        import pandas as pd

        missing = [c for c in ("t", "x", "y") if c not in df.columns]
        if missing:
            raise InputError(f"trajectory '{name}' lacks column(s) {', '.join(missing)}")
        cols = {c: pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=np.float64)
                for c in COLUMNS if c in df.columns}
        return cls.cleaned(cols["t"], cols["x"], cols["y"], cols.get("heading"), t0_ns)

    @classmethod
    def of(cls, value: Trajectory | pd.DataFrame, name: str = "") -> Trajectory:
        """``value`` itself, or the trajectory of a DataFrame (:meth:`from_frame`, s since the
        epoch): for callers that hold their poses in pandas."""
        return value if isinstance(value, Trajectory) else cls.from_frame(value, name=name)

    def to_frame(self) -> pd.DataFrame:
        """A DataFrame with columns t (s after ``t0_ns``), x, y (m), heading (rad)."""
        import pandas as pd

        return pd.DataFrame({"t": self.t, "x": self.x, "y": self.y, "heading": self.heading})

    # ------------------------------------------------------------------------ what it is

    def __len__(self) -> int:
        return len(self.t)

    def __repr__(self) -> str:
        span = f", {self.t[0]:.3f} .. {self.t[-1]:.3f} s" if len(self) else ""
        return f"Trajectory({len(self)} poses{span}, t0_ns={self.t0_ns})"

    @property
    def duration(self) -> float:
        """Time from the first pose to the last, s (0 with fewer than two)."""
        return float(self.t[-1] - self.t[0]) if len(self) > 1 else 0.0

    @cached_property
    def t_ns(self) -> NDArray[np.int64]:
        """The times as int ns since the Unix epoch (``t0_ns`` plus ``t`` rounded to the
        nearest ns; computed once)."""
        return self.t0_ns + seconds_to_ns_array(self.t)

    def on_epoch(self) -> Trajectory:
        """The same poses with ``t`` in s since the Unix epoch (``t0_ns`` 0): the log time
        ``evaluate`` and ``export`` use (the ns stamps times 1e-9)."""
        if self.t0_ns == 0:
            return self
        return replace(self, t=_floats(self.t_ns * 1e-9), t0_ns=0)

    def path_length(self) -> float:
        """Length of the polyline through the positions, m (0 with fewer than two)."""
        if len(self) < 2:
            return 0.0
        return float(np.sum(np.hypot(np.diff(self.x), np.diff(self.y))))

    # ------------------------------------------------------------------------ changing it

    def wrapped(self) -> Trajectory:
        """The headings wrapped into (-pi, pi] (:func:`lgvtool.angles.wrap_angle`)."""
        return replace(self, heading=wrap_angle(self.heading))

    def unwrapped(self) -> Trajectory:
        """The headings made continuous (``numpy.unwrap``: no step larger than pi)."""
        return replace(self, heading=np.unwrap(self.heading))

    def select(self, rows: NDArray[np.bool_] | NDArray[np.intp]) -> Trajectory:
        """The rows ``rows`` (a mask, or increasing indices), extras included."""
        extras = {k: None if getattr(self, k) is None else getattr(self, k)[rows]
                  for k in _EXTRAS}
        return Trajectory(self.t[rows], self.x[rows], self.y[rows], self.heading[rows],
                          self.t0_ns, **extras)

    def between(self, start: float, end: float) -> Trajectory:
        """The poses with ``start <= t <= end`` (s, the trajectory's clock)."""
        a = int(np.searchsorted(self.t, start, side="left"))
        b = int(np.searchsorted(self.t, end, side="right"))
        return self.select(np.arange(a, max(a, b)))

    def interpolate(self, times: ArrayLike) -> Trajectory:
        """The poses at ``times`` (s, the trajectory's clock, not decreasing): x and y
        linearly, the heading linearly on the continuous heading, then wrapped into
        (-pi, pi]. Times outside the trajectory take its first or last pose; of equal times
        in the trajectory the first counts. No extras.

        :raises ValueError: an empty trajectory.
        """
        if len(self) == 0:
            raise ValueError("cannot interpolate an empty trajectory")
        te = _floats(times)
        tt, keep = self._unique_times()
        return Trajectory(te, np.interp(te, tt, self.x[keep]), np.interp(te, tt, self.y[keep]),
                          wrap_angle(np.interp(te, tt, np.unwrap(self.heading[keep]))),
                          self.t0_ns)

    def sync(self, reference: Trajectory, *, max_gap: float = SYNC_MAX_GAP
             ) -> tuple[Trajectory, Trajectory]:
        """This trajectory and ``reference`` on common times: the rows of this one inside the
        reference's time span and not inside one of its gaps (longer than ``max_gap`` s and
        than 5 times its median sampling interval), and the reference interpolated at their
        times (:meth:`interpolate`). Both empty when the reference has fewer than two
        distinct times.

        :raises ValueError: the two trajectories count time from different origins.
        """
        if reference.t0_ns != self.t0_ns:
            raise ValueError(f"cannot sync trajectories of different clocks (t0_ns "
                             f"{self.t0_ns} and {reference.t0_ns})")
        tt, keep = reference._unique_times()
        if len(tt) < 2 or len(self) == 0:
            nothing = np.array([], dtype=np.intp)
            return self.select(nothing), Trajectory.empty(self.t0_ns)
        te = self.t
        inside = (te >= tt[0]) & (te <= tt[-1])
        idx = np.clip(np.searchsorted(tt, te, side="right"), 1, len(tt) - 1)
        limit = max(max_gap, 5.0 * float(np.median(np.diff(tt))))
        ok = inside & ((tt[idx] - tt[idx - 1]) <= limit)
        mine = self.select(ok)
        te = mine.t
        return mine, Trajectory(
            te, np.interp(te, tt, reference.x[keep]), np.interp(te, tt, reference.y[keep]),
            wrap_angle(np.interp(te, tt, np.unwrap(reference.heading[keep]))), self.t0_ns)

    def _unique_times(self) -> tuple[FloatArray, NDArray[np.bool_]]:
        """The distinct times (s) and the mask of the rows holding them (the first of equal
        times)."""
        if len(self) == 0:
            return self.t, np.zeros(0, dtype=bool)
        keep = np.concatenate([[True], np.diff(self.t) > 0])
        return self.t[keep], keep
