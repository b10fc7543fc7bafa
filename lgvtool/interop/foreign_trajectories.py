"""Trajectories produced by other tools, scored by ``lgvtool evaluate --trajectory NAME=FILE``.

A foreign trajectory is a TUM or CSV file (:func:`lgvtool.interop.trajfile.read_trajectory`)
of the target rotation centre O in the log's map frame, stamped in the log's time (s since the
Unix epoch). It is scored beside the built-in estimators: Table 1 column pair, truth metrics,
report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

from lgvtool.errors import InputError
from lgvtool.interop.named_options import SAFE_NAME, parse_pairs
from lgvtool.interop.trajfile import read_trajectory

if TYPE_CHECKING:
    from lgvtool.trajectory import Trajectory


def parse_trajectory_options(items: Sequence[str]) -> dict[str, str]:
    """``NAME=FILE`` options -> ``{NAME: FILE}``.

    :raises InputError: no ``=``, an empty or unusable name, a name given twice.
    """
    def check(name: str) -> None:
        if not SAFE_NAME.match(name):
            raise InputError(f"--trajectory name '{name}' must be letters, digits and _ . + - "
                             f"(it names a Table 1 column)")

    return parse_pairs(items, "--trajectory", "NAME=FILE", check)


def load_trajectories(items: Sequence[str]) -> dict[str, Trajectory]:
    """Read every ``NAME=FILE`` trajectory (t s, x m, y m, heading rad).

    :raises InputError: as :func:`parse_trajectory_options` and
        :func:`~lgvtool.interop.trajfile.read_trajectory` (bad line with its number, no pose).
    """
    return {name: read_trajectory(path)
            for name, path in parse_trajectory_options(items).items()}


def _span(trajectories: Sequence[Trajectory]) -> tuple[float, float] | None:
    spans = [(float(tr.t[0]), float(tr.t[-1])) for tr in trajectories if len(tr)]
    if not spans:
        return None
    return min(a for a, _ in spans), max(b for _, b in spans)


def add_foreign(trajectories: Mapping[str, Trajectory], foreign: Mapping[str, Trajectory],
                truth: Trajectory | None = None, *, log: str = "log"
                ) -> dict[str, Trajectory]:
    """The log's ``trajectories`` with the ``foreign`` ones added.

    :raises InputError: a foreign name that is already an estimator of the log, or a foreign
        trajectory whose stamps do not overlap the log's (truth, else estimates) time span.
    """
    out = dict(trajectories)
    span = _span([truth.on_epoch()] if truth is not None and len(truth)
                 else [tr.on_epoch() for tr in trajectories.values()])
    for name, df in foreign.items():
        if name in out:
            raise InputError(f"--trajectory name '{name}' is already an estimator of {log}; "
                             f"choose another name")
        t0, t1 = float(df.t[0]), float(df.t[-1])
        if span is not None and (t1 < span[0] or t0 > span[1]):
            raise InputError(
                f"--trajectory {name}: its stamps ({t0:.3f} .. {t1:.3f} s) lie outside {log} "
                f"({span[0]:.3f} .. {span[1]:.3f} s); stamps must be the log's time, s since "
                f"the Unix epoch")
        out[name] = df
    return out
