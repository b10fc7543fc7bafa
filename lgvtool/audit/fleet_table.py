"""The audit over many logs: one row of KPIs per log (:func:`kpi_row`), grouped into the table
of ``kpis.csv`` / ``kpis.parquet`` (one row per vehicle and day, :func:`kpi_table`), and each
log's evidence kept in the output folder (``logs/<stem>-<key>.pkl``) so that
``audit --resume`` re-runs only the logs it does not hold (:func:`save_audited`,
:func:`load_audited`).

A log's key (:func:`log_key`) is the SHA-256 of its resolved path, size (bytes) and
modification time (ns), of the per-log options (estimator, seed, settings, configuration) and
of the lgvtool version: a log that was rewritten, audited with other options or by another
version is run again.

Times in s, positions in m.
"""

from __future__ import annotations

import hashlib
import math
import pickle
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from lgvtool.audit.reflector_audit import STATUSES

if TYPE_CHECKING:
    from lgvtool.audit.log_audit import LogEvidence
    from lgvtool.audit.reflector_audit import ReflectorVerdict

__all__ = ["KPI_COLUMNS", "LOGS_DIR", "AuditedLog", "kpi_row", "kpi_table", "load_audited",
           "log_key", "save_audited", "stored_path", "vehicle_of", "write_kpi_table"]

LOGS_DIR = "logs"
"""Sub-folder of the audit's output folder that keeps each log's evidence."""

STORE_FORMAT = "lgvtool.audit-log"
STORE_VERSION = 2
"""Bumped when the kept evidence changes shape (2: the stations' visits)."""

KPI_COLUMNS = (
    "vehicle", "day", "logs", "duration_s",
    *(f"reflectors_{s}" for s in STATUSES),
    "visible_median", "gdop_median", "reported_used_median",
    "share_in_navigation", "dropouts", "dropout_time_s", "pose_jumps",
    "station_visits", "station_visits_outside", "station_deviation_rms_m", "elapsed_s",
)
"""Columns of the KPI table, in order (docs/audit.md, "Many logs: the KPI table")."""

COUNT_COLUMNS = ("logs", *(f"reflectors_{s}" for s in STATUSES), "dropouts", "pose_jumps",
                 "station_visits", "station_visits_outside")
"""Columns of the KPI table that are counts (integers; empty where unknown)."""


@dataclass(frozen=True)
class AuditedLog:
    """One log's evidence with what the KPI table needs besides it."""

    key: str
    """:func:`log_key` of the log."""
    evidence: LogEvidence
    vehicle: str
    """The vehicle (:func:`vehicle_of`)."""
    day: str
    """UTC date of the log's first message (YYYY-MM-DD)."""
    elapsed_s: float
    """Wall time the log's audit took, s."""


def log_key(path: str, size: int, mtime_ns: int, options: object) -> str:
    """The key of a log's stored evidence: SHA-256 (hex) of its resolved ``path``, ``size``
    (bytes), ``mtime_ns`` (ns), the ``repr`` of the per-log ``options`` (frozen
    dataclasses, so their repr names every value) and the lgvtool version."""
    from lgvtool import __version__

    text = repr((__version__, path, size, mtime_ns, options))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def vehicle_of(metadata: Mapping[str, Mapping[str, object]], stem: str) -> str:
    """The vehicle a log names: the ``name`` of its ``vehicle`` metadata record, else the
    ``host`` that ``lgvtool record`` stores in its ``recorder`` record, else ``stem`` (the log
    file's name without its suffix)."""
    for record, field in (("vehicle", "name"), ("recorder", "host")):
        value = metadata.get(record, {}).get(field)
        if isinstance(value, str) and value.strip():
            return value.strip()
    return stem


def utc_day(start_ns: int) -> str:
    """The UTC date (YYYY-MM-DD) of a log time ``start_ns`` (ns since the epoch)."""
    return datetime.fromtimestamp(start_ns / 1e9, UTC).strftime("%Y-%m-%d")


def _median(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(np.median(v)) if len(v) else math.nan


def kpi_row(log: AuditedLog, verdicts: Sequence[ReflectorVerdict],
            stations: Mapping[str, float] | None = None) -> dict[str, float | str]:
    """One log's KPIs (:data:`KPI_COLUMNS` but ``logs``): its reflectors per status as judged
    from this log's evidence alone (``verdicts``; zero everywhere for a log without landmark
    observations), the medians over its poses of the reflectors visible, of the GDOP (where a
    position is possible) and of the reflectors the device reported using, the navigation
    health (share in navigation, dropouts, their time s, pose jumps; NaN without NAV poses),
    the station figures (``stations``: :func:`lgvtool.audit.stations.log_kpis`, NaN when not
    given), its duration s and the wall time s its audit took."""
    ev = log.evidence
    cov = ev.coverage
    reported = cov.reported[cov.reported >= 0].astype(np.float64)
    nav = ev.navigation
    row: dict[str, float | str] = {"vehicle": log.vehicle, "day": log.day,
                                   "duration_s": ev.duration_s}
    for s in STATUSES:
        row[f"reflectors_{s}"] = float(sum(v.status == s for v in verdicts))
    row["visible_median"] = _median(cov.visible.astype(np.float64))
    row["gdop_median"] = _median(cov.gdop)
    row["reported_used_median"] = _median(reported)
    row["share_in_navigation"] = nav.share_in_navigation if nav else math.nan
    row["dropouts"] = float(len(nav.dropouts)) if nav else math.nan
    row["dropout_time_s"] = float(sum(d.duration for d in nav.dropouts)) if nav else math.nan
    row["pose_jumps"] = float(len(nav.jumps)) if nav else math.nan
    for col in ("station_visits", "station_visits_outside", "station_deviation_rms_m"):
        row[col] = float(stations.get(col, math.nan)) if stations is not None else math.nan
    row["elapsed_s"] = log.elapsed_s
    return row


_SUMMED = {"duration_s", "dropouts", "dropout_time_s", "pose_jumps", "elapsed_s",
           "station_visits", "station_visits_outside", *(f"reflectors_{s}" for s in STATUSES)}


def kpi_table(rows: Sequence[Mapping[str, float | str]]) -> list[dict[str, float | str]]:
    """The rows of :func:`kpi_row` grouped per vehicle and day (sorted by both): counts,
    durations and times summed; medians and the share in navigation weighted by each log's
    duration (NaN ignored), the stations' RMS deviation pooled over the logs' visits (each
    log's mean square weighted by its station visits); ``logs`` the number of logs."""
    groups: dict[tuple[str, str], list[Mapping[str, float | str]]] = {}
    for r in rows:
        groups.setdefault((str(r["vehicle"]), str(r["day"])), []).append(r)
    out: list[dict[str, float | str]] = []
    for (vehicle, day), members in sorted(groups.items()):
        row: dict[str, float | str] = {"vehicle": vehicle, "day": day,
                                       "logs": float(len(members))}
        weights = np.array([float(m["duration_s"]) for m in members])
        for col in KPI_COLUMNS[4:]:
            values = np.array([float(m[col]) for m in members])
            if col in _SUMMED:
                finite = values[np.isfinite(values)]
                row[col] = float(finite.sum()) if len(finite) else math.nan
            elif col == "station_deviation_rms_m":
                n = np.array([float(m["station_visits"]) for m in members])
                ok = np.isfinite(values) & (n > 0)
                row[col] = (math.sqrt(float(np.average(values[ok] ** 2, weights=n[ok])))
                            if ok.any() else math.nan)
            else:
                ok = np.isfinite(values) & (weights > 0)
                row[col] = (float(np.average(values[ok], weights=weights[ok]))
                            if ok.any() else math.nan)
        row["duration_s"] = float(weights.sum())
        out.append({c: row[c] for c in KPI_COLUMNS})
    return out


def write_kpi_table(rows: Sequence[Mapping[str, float | str]], csv_path: Path,
                    parquet_path: Path | None) -> None:
    """Write the table ``rows`` (:func:`kpi_table`) as CSV to ``csv_path`` (NaN as an empty
    cell) and, when ``parquet_path`` is given, as Parquet (needs pyarrow)."""
    import csv

    def cell(column: str, value: float | str) -> float | int | str:
        if isinstance(value, str):
            return value
        if math.isnan(value):
            return ""
        return int(value) if column in COUNT_COLUMNS else round(value, 6)

    with open(csv_path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(KPI_COLUMNS)
        for r in rows:
            w.writerow([cell(c, r[c]) for c in KPI_COLUMNS])
    if parquet_path is not None:
        import pandas as pd

        frame = pd.DataFrame([dict(r) for r in rows], columns=list(KPI_COLUMNS))
        for c in COUNT_COLUMNS:
            frame[c] = frame[c].astype("Int64")
        frame.to_parquet(parquet_path, index=False)


def stored_path(outdir: Path, log_path: str, key: str) -> Path:
    """Where a log's evidence is kept: ``<outdir>/logs/<stem>-<key[:16]>.pkl``."""
    return outdir / LOGS_DIR / f"{Path(log_path).stem}-{key[:16]}.pkl"


def save_audited(path: Path, log: AuditedLog) -> None:
    """Keep ``log`` at ``path`` (a pickle with a format header), atomically (a temporary file
    renamed over it)."""
    import os

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            pickle.dump({"format": STORE_FORMAT, "format_version": STORE_VERSION,
                         "key": log.key, "log": log}, f, protocol=pickle.HIGHEST_PROTOCOL)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


#: the callables outside lgvtool that a kept evidence file may name: numpy's array and scalar
#: rebuilders and the containers (a pickle names what it calls; anything else is refused)
_ALLOWED = (
    {("builtins", n) for n in ("dict", "list", "tuple", "set", "frozenset", "int", "float",
                               "complex", "str", "bytes", "bool", "slice")}
    | {(m, n) for m in ("numpy.core.multiarray", "numpy._core.multiarray")
       for n in ("_reconstruct", "scalar")}
    | {(m, "_frombuffer") for m in ("numpy.core.numeric", "numpy._core.numeric")}
    | {("numpy", "ndarray"), ("numpy", "dtype"), ("copyreg", "_reconstructor")}
)


class _EvidenceUnpickler(pickle.Unpickler):
    """An unpickler that makes only lgvtool's own classes, numpy arrays and plain containers:
    a file that names any other callable (a function of ``os``, one of lgvtool's functions) is
    refused, so a crafted file in an output folder cannot run code."""

    def find_class(self, module: str, name: str) -> type:
        found: type = super().find_class(module, name)
        if (module, name) in _ALLOWED or module == "numpy.dtypes" or (
                module.startswith("lgvtool.") and isinstance(found, type)):
            return found
        raise pickle.UnpicklingError(f"{module}.{name} is not part of an evidence file")


def load_audited(path: Path, key: str) -> AuditedLog | None:
    """The evidence kept at ``path`` for the log of ``key``; None when there is no such file.
    The file is the audit's own (written by :func:`save_audited` into the output folder), read
    by an unpickler that makes only lgvtool's classes, numpy arrays and containers.

    :raises InputError: the file is unreadable, of another format, or not of ``key``.
    """
    from lgvtool.errors import InputError

    if not path.exists():
        return None
    bad = (f"{path}: not a readable audit evidence file (delete it, or run with --force "
           "instead of --resume)")
    try:
        with open(path, "rb") as f:
            doc = _EvidenceUnpickler(f).load()
    except Exception as exc:
        raise InputError(bad) from exc
    if (not isinstance(doc, dict) or doc.get("format") != STORE_FORMAT
            or doc.get("format_version") != STORE_VERSION or doc.get("key") != key
            or not isinstance(doc.get("log"), AuditedLog)):
        raise InputError(bad)
    log: AuditedLog = doc["log"]
    return log
