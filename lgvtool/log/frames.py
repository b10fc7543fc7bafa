"""Turn decoded messages into pandas DataFrames with SI-unit columns.

Every table has ``t``, the log time (host receive time) in s since the Unix epoch, and, where
the message has a ``timestamp``, ``stamp`` in s. Other columns per schema are listed in
``docs/log-format.md``.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Iterable
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from lgvtool.errors import decoding_error
from lgvtool.log.messages import steering_fields, yaw_from_quaternion
from lgvtool.log.reader import LogMessage, LogReader
from lgvtool.timestamps import stamp_seconds


def _pose_row(t: float, d: dict[str, Any]) -> dict[str, Any]:
    p = d["pose"]
    return {"t": t, "stamp": stamp_seconds(d.get("timestamp")), "x": p["position"]["x"],
            "y": p["position"]["y"], "z": p["position"].get("z", 0.0),
            "heading": yaw_from_quaternion(p["orientation"])}


#: rows turned into a DataFrame at a time (the row dicts of one block are then freed)
ROWS_PER_BLOCK = 8192


class PoseColumns:
    """The columns of :func:`pose_table` (t, stamp in s; x, y, z in m; heading in rad), filled
    a few messages at a time; every :data:`ROWS_PER_BLOCK` rows become arrays (few, large
    blocks however small the pieces added)."""

    NAMES = ("t", "stamp", "x", "y", "z", "heading")

    def __init__(self) -> None:
        self._blocks: list[NDArray[np.float64]] = []
        self._rows: list[tuple[float, float, float, float, float, float]] = []

    def add(self, messages: Iterable[tuple[int, dict[str, Any]]]) -> None:
        """Add foxglove.PoseInFrame messages ``(log time ns, decoded message)``."""
        rows = self._rows
        atan2 = math.atan2
        for ns, d in messages:
            p = d["pose"]
            pos, q = p["position"], p["orientation"]
            qx, qy = float(q.get("x", 0.0)), float(q.get("y", 0.0))
            qz, qw = float(q.get("z", 0.0)), float(q.get("w", 0.0))
            rows.append((ns * 1e-9, stamp_seconds(d.get("timestamp")), float(pos["x"]),
                         float(pos["y"]), float(pos.get("z", 0.0)),
                         atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))))
            if len(rows) >= ROWS_PER_BLOCK:
                self._seal()
                rows = self._rows

    def _seal(self) -> None:
        if self._rows:
            self._blocks.append(np.array(self._rows, dtype=np.float64))
            self._rows = []

    def table(self) -> pd.DataFrame:
        """The table of every message added, in the order added; the rows are handed over
        (each block freed as it is copied), so call it once."""
        self._seal()
        blocks, self._blocks = self._blocks, []
        # one (columns, rows) array, as pandas makes of a table of lists
        cols = np.empty((len(self.NAMES), sum(len(b) for b in blocks)))
        at = 0
        while blocks:
            b = blocks.pop(0)
            cols[:, at:at + len(b)] = b.T
            at += len(b)
        return pd.DataFrame(cols.T, columns=list(self.NAMES))


def pose_table(messages: Iterable[tuple[int, dict[str, Any]]]) -> pd.DataFrame:
    """The table of foxglove.PoseInFrame messages ``(log time ns, decoded message)``, built
    column by column (the same values as :func:`_pose_row` per message)."""
    cols = PoseColumns()
    cols.add(messages)
    return cols.table()


class SteeringColumns:
    """Steering angle (rad, NaN where a frame has none) and absolute drive speed (m/s, 0 where
    a frame has none) of MCU frames, filled a block of decoded frames at a time."""

    def __init__(self) -> None:
        self._blocks: list[NDArray[np.float64]] = []
        self._angle: list[float] = []
        self._speed: list[float] = []

    def add(self, docs: list[dict[str, Any]]) -> None:
        """Add decoded MCU frames (:func:`steering_fields`); every :data:`ROWS_PER_BLOCK`
        frames become an array."""
        a, v = steering_fields(docs)
        self._angle.extend(a)
        self._speed.extend(v)
        if len(self._angle) >= ROWS_PER_BLOCK:
            self._seal()

    def _seal(self) -> None:
        if self._angle:
            self._blocks.append(np.array([self._angle, self._speed], dtype=np.float64))
            self._angle, self._speed = [], []

    def arrays(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The angles and speeds of every frame added, in the order added."""
        self._seal()
        both = np.concatenate(self._blocks, axis=1) if self._blocks else np.zeros((2, 0))
        return both[0].copy(), both[1].copy()


def steering_columns(reader: LogReader) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Steering angle (rad, NaN where a frame has none) and absolute drive speed (m/s, 0 where
    a frame has none) of every MCU frame of the log, in stored order (read a chunk at a time,
    two fields decoded; empty without /mcu/frame)."""
    import orjson

    from lgvtool.log import topics as T

    cols = SteeringColumns()
    if reader.has_topic(T.MCU_FRAME):
        loads = orjson.loads
        try:
            for block in reader.raw_column_chunks([T.MCU_FRAME]):
                cols.add([loads(x) for x in (block[T.MCU_FRAME][1] if T.MCU_FRAME in block
                                             else ())])
        except (TypeError, ValueError, AttributeError) as exc:
            raise decoding_error(reader.path, T.MCU_FRAME, "lgvtool.McuFrame", exc) from None
    return cols.arrays()


def to_dataframe(schema: str, messages: Iterable[LogMessage]) -> pd.DataFrame:
    """Flatten messages of one schema into a DataFrame (see the module docstring).

    Rows are built as dicts and turned into a DataFrame :data:`ROWS_PER_BLOCK` at a time, so
    that memory holds the table's columns, not a dict per row of a long log; poses (the
    largest tables) are built column by column."""
    if schema == "foxglove.PoseInFrame":
        return pose_table((m.log_time_ns, m.data) for m in messages)
    rows: list[dict[str, Any]] = []
    parts: list[pd.DataFrame] = []
    for m in messages:
        if len(rows) >= ROWS_PER_BLOCK:
            parts.append(pd.DataFrame(rows))
            rows = []
        t = m.log_time_ns * 1e-9
        d = m.data
        if schema == "foxglove.PoseInFrame":
            rows.append(_pose_row(t, d))
        elif schema == "foxglove.PosesInFrame":
            for i, p in enumerate(d["poses"]):
                rows.append(_pose_row(t, {"timestamp": d["timestamp"], "pose": p}) | {"index": i})
        elif schema == "lgvtool.ReflectorScan":
            base = {"t": t, "stamp": stamp_seconds(d.get("timestamp")), "scan_period": d["scan_period"]}
            for o in d["observations"]:
                rows.append(base | {"range": o["range"], "bearing": o["bearing"],
                                    "time_in_scan": o["time_in_scan"], "id": o["id"]})
        elif schema == "lgvtool.ReflectorMap":
            for r in d["reflectors"]:
                rows.append({"t": t, "stamp": stamp_seconds(d.get("timestamp"))} | r)
        elif schema == "lgvtool.RawBytes":
            data = base64.b64decode(d["data"])
            rows.append({"t": t, "stamp": stamp_seconds(d.get("timestamp")), "device": d["device"],
                         "direction": d["direction"], "size": len(data), "data": data})
        elif schema == "lgvtool.McuFrame":
            row = {"t": t, "stamp": stamp_seconds(d.get("timestamp"))}
            row.update({k: v for k, v in d.items() if k != "timestamp"})
            row["mcu_time"] = row.pop("mcu_time_ms") * 1e-3
            row["gyro_scale"] = math.radians(row["gyro_scale"])
            rows.append(row)
        else:
            row = {"t": t, "stamp": stamp_seconds(d.get("timestamp"))}
            for k, v in d.items():
                if k == "timestamp":
                    continue
                row[k] = v
            rows.append(row)
    columns = {
        "foxglove.PoseInFrame": ["t", "stamp", "x", "y", "z", "heading"],
        "lgvtool.ReflectorScan": ["t", "stamp", "scan_period", "range", "bearing",
                                  "time_in_scan", "id"],
    }.get(schema)
    if parts:
        if rows:
            parts.append(pd.DataFrame(rows))
        return pd.concat(parts, ignore_index=True, sort=False)
    return pd.DataFrame(rows, columns=columns) if columns and not rows else pd.DataFrame(rows)
