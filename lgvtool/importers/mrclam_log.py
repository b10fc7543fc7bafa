"""Write an MRCLAM robot run as an lgvtool log (docs/mrclam.md).

Channels: odometry on ``/odom/twist`` (lgvtool.Odometry), one ``/nav/reflectors`` scan
(lgvtool.ReflectorScan, ``scan_period`` 0, every ``time_in_scan`` 0, id = landmark subject
number) per measurement stamp that has a landmark, the landmark map on ``/map/reflectors``,
ground truth on ``/truth/pose`` (foxglove.PoseInFrame) and one ``/diagnostics`` event per quirk
kind. Metadata: ``importer`` (provenance with SHA-256 of every file read, citation, camera
geometry, counts, quirks, settings) and ``config`` (camera at the robot centre, work area around
the landmarks, the landmark map, no reference circle, the estimators' camera and odometry noise
profile).
Log times are the dataset's own Unix stamps in ns, the odometry's delayed by the time the robot
takes to carry out a command (``timing`` in the ``importer`` record); messages are written in
time order.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lgvtool.config import Config, Reference, Vehicle, default_config
from lgvtool.errors import InputError
from lgvtool.importers.mrclam import CITATION, DATASET_URL, MrclamDataset, robot_files
from lgvtool.importers.mrclam_profile import (
    ESTIMATOR_PROFILE,
    PROFILE_NAME,
    estimator_profile,
)
from lgvtool.importers.mrclam_quirks import ImportSettings, PreparedRun, prepare_run
from lgvtool.json_types import JSON, JSONObject
from lgvtool.log import LogWriter, topics
from lgvtool.log.messages import FRAME_ID
from lgvtool.outputs import atomic_output
from lgvtool.progress import Progress
from lgvtool.timestamps import stamp

NS = 1_000_000_000
SOURCE = "importer"
"""The ``source`` of the importer's diagnostics (docs/log-format.md)."""

_MAP, _DIAG, _TRUTH, _ODOM, _SCAN = range(5)
"""Stream codes; at equal log times messages are written in this order."""


@dataclass(frozen=True)
class ImportSummary:
    """What one robot's import wrote and found."""

    robot: int
    """Robot (subject) number."""
    path: Path
    """The log written."""
    counts: dict[str, int]
    """Row and message counts (docs/mrclam.md lists the keys)."""
    quirks: tuple[dict[str, Any], ...]
    """One entry per quirk kind: kind, count, level, message."""
    camera: dict[str, float]
    """Camera geometry measured from the data (see PreparedRun.camera)."""
    start_s: float
    """First log time, s since the Unix epoch."""
    end_s: float
    """Last log time, s since the Unix epoch."""
    messages: int
    """Messages written (all channels, diagnostic mirrors included)."""
    elapsed_s: float
    """Wall-clock time of the import, s."""
    timing: dict[str, Any]
    """The odometry delay applied and measured (see PreparedRun.timing)."""
    estimator_profile: str = PROFILE_NAME
    """Name of the estimator settings stored in the log's configuration."""

    def to_dict(self) -> JSONObject:
        """A JSON-ready dict (stable keys)."""
        d = asdict(self)
        d["path"] = str(self.path)
        d["quirks"] = [dict(q) for q in self.quirks]
        return d

    def format_text(self) -> str:
        """A short human-readable summary, a few lines."""
        c, cam = self.counts, self.camera
        lines = [
            f"robot {self.robot} -> {self.path} ({self.messages} messages, "
            f"{self.end_s - self.start_s:.1f} s of data, imported in {self.elapsed_s:.2f} s)",
            f"  odometry  {c['odometry']} of {c['odometry_rows']} rows",
            f"  scans     {c['scans']} with {c['landmark_observations']} landmark observations "
            f"(of {c['measurement_rows']} measurement rows)",
            f"  truth     {c['truth']} of {c['truth_rows']} rows",
            f"  dropped   {c['robot_sightings']} robot sightings, {c['unknown_barcodes']} unknown "
            f"barcodes, {c['invalid_ranges']} invalid ranges, {c['broken_rows']} broken rows",
        ]
        if cam:
            lines.append(
                f"  camera    bearings {cam['bearing_min_rad']:+.3f} .. "
                f"{cam['bearing_max_rad']:+.3f} rad (fov {cam['fov_deg']:.1f} deg), ranges "
                f"{cam['range_min_m']:.2f} .. {cam['range_max_m']:.2f} m")
        tm = self.timing
        if tm:
            if tm["measured_delay_s"] is None:
                how = f"too few landmark sightings to measure it, {tm['pairs']} pairs"
            else:
                how = (f"landmark bearing changes off by {tm['bearing_rms_without_delay_rad']:.4f}"
                       f" rad RMS without a delay, {tm['bearing_rms_with_delay_rad']:.4f} rad "
                       f"with {tm['measured_delay_s']:.3f} s, {tm['pairs']} pairs")
            lines.append(f"  timing    odometry written {tm['odometry_delay_s']:.3f} s after its "
                         f"stamps ({tm['method']}; {how})")
        lines.append(f"  profile   {self.estimator_profile}: camera and odometry settings of "
                     f"{', '.join(sorted(ESTIMATOR_PROFILE))} in the log's config")
        lines.extend(f"  quirk     {q['kind']}: {q['message']}" for q in self.quirks)
        return "\n".join(lines)


def mrclam_config(run: PreparedRun, dataset: MrclamDataset) -> Config:
    """The configuration stored in the log: camera at the robot centre (nav_x = nav_y = 0),
    the work area around the landmarks, the landmark map, no reference circle (the robots
    drive freely, so evaluation uses the ground truth only), and the camera and odometry noise
    of every estimator (:mod:`lgvtool.importers.mrclam_profile`)."""
    base = default_config()
    return replace(
        base,
        vehicle=replace(Vehicle(), nav_x=0.0, nav_y=0.0),
        area=run.area,
        reference=Reference(steering_angle_deg=None),
        reflectors=dataset.landmark_map(run.settings.landmark_radius_m),
        estimators=estimator_profile(),
    )


def importer_record(run: PreparedRun, dataset: MrclamDataset) -> dict[str, object]:
    """The ``importer`` metadata record: provenance (dataset, robot, files with SHA-256),
    citation, camera geometry, counts, quirks, odometry timing, settings."""
    files = [*dataset.files, *run.files]
    return {
        "importer": "mrclam",
        "dataset": dataset.name,
        "dataset_number": dataset.number,
        "folder": dataset.root.name,
        "robot": run.robot,
        "files": {f.name: f.sha256 for f in files},
        "file_rows": {f.name: f.rows for f in files},
        "citation": CITATION,
        "url": DATASET_URL,
        "camera": run.camera,
        "counts": run.counts,
        "quirks": {q.kind: q.count for q in run.quirks},
        "residuals_vs_truth": run.residuals,
        "timing": run.timing,
        "settings": asdict(run.settings),
        "estimator_profile": PROFILE_NAME,
        "landmark_ids": "subject numbers (Barcodes.dat)",
        "time_unit": "log times are the dataset's Unix stamps in ns, rounded to the microsecond; "
                     "the odometry's delayed by timing.odometry_delay_s",
    }


def _scan_groups(run: PreparedRun) -> tuple[NDArray[np.int64], list[list[JSON]]]:
    """Scan stamps (ns) and, per scan, its observation dicts in file order."""
    obs = run.observations
    t = obs["t_ns"].to_numpy()
    stamps, first = np.unique(t, return_index=True)
    bounds = [*first.tolist(), len(t)]
    items: list[JSON] = [
        {"range": r, "bearing": b, "time_in_scan": 0.0, "id": i}
        for r, b, i in zip(obs["range"].tolist(), obs["bearing"].tolist(),
                           obs["landmark"].tolist(), strict=True)
    ]
    return stamps, [items[bounds[k]:bounds[k + 1]] for k in range(len(stamps))]


def _encode_odometry(run: PreparedRun) -> list[bytes]:
    """lgvtool.Odometry messages as JSON bytes, exactly as ``json.dumps`` would write them
    compactly (pre-encoded in one pass: several times faster than a dict per message)."""
    odo = run.odometry
    sec, nsec = np.divmod(odo["t_ns"].to_numpy(), NS)
    return [
        f'{{"timestamp":{{"sec":{s},"nsec":{n}}},"v":{v!r},"omega":{w!r}}}'.encode()
        for s, n, v, w in zip(sec.tolist(), nsec.tolist(), odo["v"].tolist(),
                              odo["omega"].tolist(), strict=True)
    ]


def _encode_truth(run: PreparedRun) -> list[bytes]:
    """foxglove.PoseInFrame messages (frame 'map', z 0, yaw quaternion) as JSON bytes."""
    tru = run.truth
    sec, nsec = np.divmod(tru["t_ns"].to_numpy(), NS)
    half = tru["theta"].to_numpy() / 2.0
    return [
        (f'{{"timestamp":{{"sec":{s},"nsec":{n}}},"frame_id":"{FRAME_ID}","pose":{{'
         f'"position":{{"x":{x!r},"y":{y!r},"z":0.0}},'
         f'"orientation":{{"x":0.0,"y":0.0,"z":{qz!r},"w":{qw!r}}}}}}}').encode()
        for s, n, x, y, qz, qw in zip(sec.tolist(), nsec.tolist(), tru["x"].tolist(),
                                      tru["y"].tolist(), np.sin(half).tolist(),
                                      np.cos(half).tolist(), strict=True)
    ]


def _write_messages(w: LogWriter, run: PreparedRun, dataset: MrclamDataset,
                    progress: Progress | None = None) -> None:
    """Every message of ``run`` in log-time order (``progress`` counts them)."""
    scan_t, scans = _scan_groups(run)
    odo_t = run.odometry["t_ns"].to_numpy()
    tru_t = run.truth["t_ns"].to_numpy()
    quirk_t = np.array([q.time_ns for q in run.quirks], dtype=np.int64)
    streams = [
        (_MAP, np.array([run.start_ns], dtype=np.int64)),
        (_DIAG, quirk_t),
        (_TRUTH, tru_t),
        (_ODOM, odo_t),
        (_SCAN, scan_t),
    ]
    t_all = np.concatenate([t for _, t in streams])
    code = np.concatenate([np.full(len(t), c, dtype=np.int8) for c, t in streams])
    index = np.concatenate([np.arange(len(t)) for _, t in streams])
    order = np.lexsort((index, code, t_all))

    odo_msg, tru_msg = _encode_odometry(run), _encode_truth(run)
    ot, tt, st = odo_t.tolist(), tru_t.tolist(), scan_t.tolist()
    write = w.write_encoded
    if progress is not None:
        progress.stage(f"robot {run.robot}: writing", len(order))
    for k, (c, i) in enumerate(zip(code[order].tolist(), index[order].tolist(), strict=True)):
        if progress is not None and k % 20_000 == 0:
            progress.set(k)
        if c == _ODOM:
            write(topics.ODOM, odo_msg[i], ot[i])
        elif c == _TRUTH:
            write(topics.TRUTH, tru_msg[i], tt[i])
        elif c == _SCAN:
            w.write(topics.NAV_REFLECTORS, {"timestamp": stamp(st[i]), "scan_period": 0.0,
                                            "observations": scans[i]}, st[i])
        elif c == _DIAG:
            q = run.quirks[i]
            w.write_diagnostic(SOURCE, q.kind, q.message, q.time_ns, level=q.level,
                               count=q.count, details=q.details)
        else:
            w.write_map(dataset.landmark_map(run.settings.landmark_radius_m), run.start_ns)
    if progress is not None:
        progress.set(len(order))


def write_run(run: PreparedRun, dataset: MrclamDataset, out: str | Path, *,
              compression: str = "zstd", started: float | None = None,
              progress: Progress | None = None) -> ImportSummary:
    """Write ``run`` as a log at ``out`` (replaced atomically: a failed import leaves no file).
    Chunks are closed by size (4 MiB), as for every offline writer.

    :param started: ``time.perf_counter()`` at the start of the import, for the summary.
    :raises InputError: ``out`` is a folder or its folder does not exist.
    """
    t0 = time.perf_counter() if started is None else started
    path = Path(out)
    if path.is_dir():
        raise InputError(f"{path}: is a folder, expected the output .mcap file")
    if not path.parent.is_dir():
        raise InputError(f"{path}: folder {path.parent} does not exist")
    # a temporary file of its own beside the output (lgvtool.outputs.atomic_output), so that
    # two imports to one output never write the same file
    with atomic_output(path) as part, LogWriter(part, chunk_seconds=None,
                                                compression=compression,
                                                source="import mrclam") as w:
        w.add_metadata("importer", importer_record(run, dataset))
        w.write_config(mrclam_config(run, dataset))
        _write_messages(w, run, dataset, progress)
        messages = w.message_count
    return ImportSummary(
        robot=run.robot, path=path, counts=dict(run.counts),
        quirks=tuple({"kind": q.kind, "count": q.count, "level": q.level, "message": q.message}
                     for q in run.quirks),
        camera=dict(run.camera), start_s=run.start_ns / 1e9, end_s=run.end_ns / 1e9,
        messages=messages, elapsed_s=time.perf_counter() - t0, timing=dict(run.timing),
    )


def import_robot(dataset: str | Path | MrclamDataset, robot: int, out: str | Path, *,
                 settings: ImportSettings | None = None, compression: str = "zstd",
                 progress: Progress | None = None) -> ImportSummary:
    """Import robot ``robot`` of the MRCLAM dataset folder ``dataset`` into the log ``out``
    (``progress``: stages reading, preparing and writing on stderr).

    :raises InputError: not a dataset, no such robot, an unusable file, a bad output path.
    """
    t0 = time.perf_counter()
    ds = dataset if isinstance(dataset, MrclamDataset) else MrclamDataset.open(dataset)
    if progress is not None:
        progress.stage(f"robot {robot}: reading and preparing", 2)
    rec = ds.load_robot(robot)
    if progress is not None:
        progress.advance()
    run = prepare_run(ds, rec, settings)
    if progress is not None:
        progress.advance()
    return write_run(run, ds, out, compression=compression, started=t0, progress=progress)


def import_all(dataset: str | Path | MrclamDataset, out_dir: str | Path, *,
               settings: ImportSettings | None = None, compression: str = "zstd",
               progress: Progress | None = None) -> list[ImportSummary]:
    """Import every robot of ``dataset`` into ``out_dir``/robotN.mcap (folder created).

    :raises InputError: as :func:`import_robot`, or ``out_dir`` is a file.
    """
    ds = dataset if isinstance(dataset, MrclamDataset) else MrclamDataset.open(dataset)
    folder = Path(out_dir)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"{folder}: is a file, expected an output folder for --all")
    complete = [r for r in ds.robots
                if all((ds.root / n).is_file() for n in robot_files(r).values())]
    if not complete:
        raise InputError(f"{ds.root}: no robot has all three files")
    folder.mkdir(parents=True, exist_ok=True)
    return [import_robot(ds, r, folder / f"robot{r}.mcap", settings=settings,
                         compression=compression, progress=progress) for r in complete]
