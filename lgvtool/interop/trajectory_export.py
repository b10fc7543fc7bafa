"""``lgvtool export``: every trajectory of a log into TUM, KITTI, CSV or Parquet files.

One file set per trajectory, all of the target rotation centre O in the map frame, stamped with
the log time (s since the Unix epoch), as ``lgvtool evaluate`` scores them
(:meth:`lgvtool.trajectory.Trajectory.clean`: sorted, finite, one pose per stamp):

- ``NAME``: each estimator's estimate, read from the log's ``/estimate/NAME/pose`` channels if
  it has any, else run over the log as ``evaluate`` runs them (same seed, same settings);
- ``nav``: every valid NAV pose of the head converted to O with the mounting
  (``vehicle.nav_x``, ``vehicle.nav_y``);
- ``truth``: the ground truth of O (``/truth/pose``), where the log has it;
- ``truth-at-NAME``: the ground truth interpolated at the stamps of ``NAME`` with the rules of
  lgvtool's truth metrics (:meth:`lgvtool.trajectory.Trajectory.sync`), so that another
  tool's absolute trajectory error on the pair equals lgvtool's true position RMSE.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from lgvtool.errors import InputError
from lgvtool.interop import trajfile
from lgvtool.interop.named_options import SAFE_NAME
from lgvtool.json_types import JSONObject, SettingValue, as_list
from lgvtool.outdir import guard_directory
from lgvtool.outputs import atomic_outputs

if TYPE_CHECKING:
    import pandas as pd

    from lgvtool.config import Config
    from lgvtool.log import LogReader
    from lgvtool.trajectory import Trajectory

NAV = "nav"
"""File name of the NAV pose converted to O."""
TRUTH = "truth"
"""File name of the ground truth."""
TRUTH_AT = "truth-at-"
"""Prefix of the ground truth resampled at a trajectory's stamps."""


@dataclass(frozen=True)
class Exported:
    """One trajectory to export: its file name, its poses (t s since the epoch, x m, y m,
    heading rad) and what it is, in words."""

    name: str
    poses: Trajectory
    what: str


@dataclass
class ExportSummary:
    """What :func:`export_log` wrote."""

    log: str
    directory: str
    format: str
    source: str
    """'log': estimates read from the log; 'replay': estimators run by export; 'none'."""
    trajectories: dict[str, JSONObject] = field(default_factory=dict)
    """name -> {files, poses, what}."""
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> JSONObject:
        """A JSON-ready dict (stable keys)."""
        return {"log": self.log, "directory": self.directory, "format": self.format,
                "source": self.source,
                "trajectories": {k: v for k, v in self.trajectories.items()},
                "warnings": list(self.warnings)}

    def format_text(self) -> str:
        """A few lines: the folder, then one line per trajectory."""
        n = sum(len(as_list(v["files"])) for v in self.trajectories.values())
        lines = [f"wrote {n} file(s) ({self.format}) into {self.directory}"]
        width = max((len(k) for k in self.trajectories), default=0)
        lines.extend(f"  {k:<{width}}  {v['poses']:>7} poses  {v['what']}"
                     for k, v in self.trajectories.items())
        return "\n".join(lines)


def _estimates(reader: LogReader, names: Sequence[str] | None, cfg: Config, seed: int,
               settings: Mapping[str, SettingValue], start_at_truth: bool, warnings: list[str],
               threads: int | None) -> tuple[dict[str, Trajectory], str,
                                             dict[str, pd.DataFrame]]:
    """The estimates of the log (source 'log'), else those of the estimators run over it, and
    the tables of the log's ground truth and NAV poses (those it has), read in the same pass
    as the log's estimates or as the estimators' reading."""
    from lgvtool.localize.registry import check_names, in_run_order
    from lgvtool.log import topics
    from lgvtool.trajectory import Trajectory

    others = [t for t in (topics.TRUTH, topics.NAV_POSE) if reader.has_topic(t)]

    present = in_run_order(topics.estimator_names(reader.topic_names()))
    if present:
        chosen = list(names) if names else present
        check_names(chosen, also=present)  # a mistyped name: "did you mean ...?"
        missing = [n for n in chosen if n not in present]
        if missing:
            raise InputError(f"{reader.path}: no estimates of {', '.join(missing)} in the log "
                             f"(it holds {', '.join(present)})")
        if start_at_truth:
            warnings.append("--start-at-truth has no effect: the log's own estimates are "
                            "exported")
        tables = reader.dataframes([*(topics.estimate_pose(n) for n in chosen), *others])
        return ({n: Trajectory.from_frame(tables[topics.estimate_pose(n)], name=n)
                 for n in chosen}, "log", {t: tables[t] for t in others})
    from lgvtool.errors import MissingDataError
    from lgvtool.gc_pause import collector_paused
    from lgvtool.localize import DEFAULT_ESTIMATORS, run_replay
    from lgvtool.log.frames import TopicTables

    side = TopicTables(reader, others)
    try:
        with collector_paused():
            run = run_replay(reader, list(names) if names else list(DEFAULT_ESTIMATORS),
                             config=cfg, seed=seed, settings=dict(settings),
                             initial_pose="truth" if start_at_truth else None, tap=side,
                             threads=threads)
    except MissingDataError as exc:
        if names:
            raise MissingDataError(f"{reader.path}: {exc}") from None
        warnings.append(f"no estimator exported: {exc}")
        return {}, "none", reader.dataframes(others)
    for name, reason in run.skipped.items():
        if names:
            raise InputError(f"{reader.path}: {reason}")
        warnings.append(f"estimator '{name}' left out: {reason}")
    return run.trajectories, "replay", side.tables()


def nav_at_o(df: pd.DataFrame | None, cfg: Config) -> Trajectory | None:
    """The valid NAV poses of the head (the table of /nav/pose, None without) converted to O
    (t s since the epoch, x m, y m, heading rad; rows with a value that is not finite left
    out), cleaned (:meth:`~lgvtool.trajectory.Trajectory.clean`)."""
    import numpy as np

    from lgvtool.localize.geometry import nav_to_o
    from lgvtool.trajectory import Trajectory

    if df is None or df.empty:
        return None
    df = df[df["valid"].astype(bool)]
    x, y, h = nav_to_o(df["x"], df["y"], df["heading"], cfg.vehicle.nav_x, cfg.vehicle.nav_y)
    t = df["t"].to_numpy(dtype=float)
    x, y, h = (np.asarray(v, dtype=float) for v in (x, y, h))
    ok = np.isfinite(t) & np.isfinite(x) & np.isfinite(y) & np.isfinite(h)
    return Trajectory.cleaned(t[ok], x[ok], y[ok], h[ok])


def collect(reader: LogReader, *, estimators: Sequence[str] | None = None,
            config: Config | None = None, seed: int = 0,
            settings: Mapping[str, SettingValue] | None = None, start_at_truth: bool = False,
            threads: int | None = 1) -> tuple[list[Exported], str, list[str]]:
    """Every trajectory of the log to export, the estimates' source and warnings; estimators
    that export runs run on ``threads`` threads at once (see :func:`export_log`)."""
    from lgvtool.log import topics
    from lgvtool.trajectory import Trajectory

    cfg = config if config is not None else reader.config()
    warnings: list[str] = list(reader.warnings)
    estimates, source, tables = _estimates(reader, estimators, cfg, seed, settings or {},
                                           start_at_truth, warnings, threads)
    for name in estimates:
        if not SAFE_NAME.match(name):
            raise InputError(f"estimator name '{name}' cannot name a file (letters, digits and "
                             f"_ . + - only)")
        if name in (NAV, TRUTH) or name.startswith(TRUTH_AT):
            raise InputError(f"estimator name '{name}' clashes with an exported file name "
                             f"({NAV}, {TRUTH}, {TRUTH_AT}*)")
    how = "read from the log" if source == "log" else f"run by lgvtool export, seed {seed}"
    out = [Exported(n, tr.on_epoch().clean(), f"estimator '{n}' ({how})")
           for n, tr in estimates.items()]
    nav = nav_at_o(tables.get(topics.NAV_POSE), cfg)
    if nav is not None and len(nav):
        out.append(Exported(NAV, nav, f"NAV head pose converted to O (nav_x "
                                      f"{cfg.vehicle.nav_x} m, nav_y {cfg.vehicle.nav_y} m)"))
    truth = tables.get(topics.TRUTH)
    if truth is not None and len(truth):
        true_poses = Trajectory.from_frame(truth, name=TRUTH)
        resampled = []
        for tr in out:
            at = tr.poses.sync(true_poses)[1]
            resampled.append(Exported(
                TRUTH_AT + tr.name, at,
                f"ground truth of O interpolated at the {len(at)} stamps of '{tr.name}' "
                f"inside the truth"))
        out.append(Exported(TRUTH, true_poses, "ground truth of O"))
        out.extend(resampled)
    empty = [t.name for t in out if len(t.poses) == 0]
    for name in empty:
        warnings.append(f"trajectory '{name}' has no pose: no file written")
    return [t for t in out if len(t.poses)], source, warnings


def export_log(log: str | Path, directory: str | Path, fmt: str, *,
               estimators: Sequence[str] | None = None, config: Config | None = None,
               seed: int = 0, settings: Mapping[str, SettingValue] | None = None,
               start_at_truth: bool = False, force: bool = False,
               threads: int | None = 1) -> ExportSummary:
    """Export every trajectory of ``log`` as ``fmt`` files into ``directory`` (created).
    Estimators that export runs run on ``threads`` threads at once (None: one per
    estimator, at most one per CPU; the same files for any count); one by default, as
    filters side by side hold their working memory at once (docs/performance.md).

    :raises InputError: unknown format, pyarrow missing for Parquet, an output that exists
        (without ``force``) or is the log, a log without the estimates asked for.
    """
    import warnings as pywarnings

    from lgvtool.log import LogReader

    if fmt not in trajfile.FORMATS:
        raise InputError(f"unknown format '{fmt}' (known: {', '.join(trajfile.FORMATS)})")
    if fmt == "parquet":
        trajfile.require_pyarrow()
    folder = Path(directory)
    with pywarnings.catch_warnings():
        pywarnings.simplefilter("ignore")
        reader = LogReader(log)
    trajectories, source, warnings = collect(
        reader, estimators=estimators, config=config, seed=seed, settings=settings,
        start_at_truth=start_at_truth, threads=threads)
    if not trajectories:
        raise InputError(f"{log}: no trajectory to export (no estimate, NAV pose or truth)")
    plan = [(tr, [folder / n for n in trajfile.file_names(tr.name, fmt)]) for tr in trajectories]
    guard_directory(directory, [p.name for _tr, paths in plan for p in paths], [log],
                    force=force)
    folder.mkdir(parents=True, exist_ok=True)
    summary = ExportSummary(str(log), str(folder), fmt, source, warnings=warnings)
    name = Path(str(log)).name
    # every file lands together: when one cannot be written (a full disk), none is replaced
    with atomic_outputs() as place:
        for tr, paths in plan:
            meta = {"lgvtool_export_of": name, "trajectory": tr.name, "content": tr.what,
                    "point": "target rotation centre O", "frame": "map",
                    "time": "log time, s since the Unix epoch",
                    "units": "t s, x m, y m, heading rad (counter-clockwise from the map x "
                             "axis)"}
            trajfile.write_trajectory(tr.poses, [place(p) for p in paths], fmt, meta)
            summary.trajectories[tr.name] = {"files": [p.name for p in paths],
                                             "poses": len(tr.poses), "what": tr.what}
    return summary
