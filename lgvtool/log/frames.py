"""Turn decoded messages into pandas DataFrames with SI-unit columns.

Every table has ``t``, the log time (host receive time) in s since the Unix epoch, and, where
the message has a ``timestamp``, ``stamp`` in s. Other columns per schema are listed in
``docs/log-format.md``.
"""

from __future__ import annotations

import base64
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from lgvtool.errors import decoding_error
from lgvtool.log.messages import McuFrameFields, steering_fields, yaw_from_quaternion
from lgvtool.log.reader import LogMessage, LogReader, RawBlock
from lgvtool.log.validate import check_magnitude
from lgvtool.timestamps import stamp_seconds


def _pose_row(t: float, d: dict[str, Any]) -> dict[str, Any]:
    p = d["pose"]
    return {"t": t, "stamp": stamp_seconds(d.get("timestamp")), "x": p["position"]["x"],
            "y": p["position"]["y"], "z": p["position"].get("z", 0.0),
            "heading": yaw_from_quaternion(p["orientation"])}


#: rows turned into a DataFrame at a time (the row dicts of one block are then freed)
ROWS_PER_BLOCK = 8192


class PoseColumns:
    """The table of foxglove.PoseInFrame messages (t, stamp in s; x, y, z in m; heading in
    rad; the values of :func:`_pose_row`), built column by column a few messages at a time;
    every :data:`ROWS_PER_BLOCK` rows become arrays (few, large blocks however small the
    pieces added)."""

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
        (each block freed as it is copied), so call it once.

        :raises ValueError: a position beyond :data:`~lgvtool.log.validate.MAX_MAGNITUDE` m
            (NaN is kept: an estimate may have none)."""
        self._seal()
        blocks, self._blocks = self._blocks, []
        # one (columns, rows) array, as pandas makes of a table of lists
        cols = np.empty((len(self.NAMES), sum(len(b) for b in blocks)))
        at = 0
        while blocks:
            b = blocks.pop(0)
            cols[:, at:at + len(b)] = b.T
            at += len(b)
        check_magnitude({n: cols[k] for k, n in enumerate(self.NAMES) if n in ("x", "y", "z")})
        return pd.DataFrame(cols.T, columns=list(self.NAMES))


class SteeringColumns:
    """Steering angle (rad, NaN where a frame has none) and absolute drive speed (m/s, 0 where
    a frame has none) of MCU frames, filled a block of decoded frames at a time."""

    def __init__(self) -> None:
        self._blocks: list[NDArray[np.float64]] = []
        self._angle: list[float] = []
        self._speed: list[float] = []

    def add(self, docs: Sequence[McuFrameFields]) -> None:
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


class RowTable:
    """The table of :func:`to_dataframe` for a schema other than foxglove.PoseInFrame, filled
    a few messages at a time: rows are built as dicts and turned into a DataFrame
    :data:`ROWS_PER_BLOCK` at a time, so that memory holds the table's columns, not a dict per
    row of a long log."""

    def __init__(self, schema: str) -> None:
        self.schema = schema
        self._rows: list[dict[str, Any]] = []
        self._parts: list[pd.DataFrame] = []

    def add(self, messages: Iterable[tuple[int, dict[str, Any]]]) -> None:
        """Add messages ``(log time ns, decoded message)`` of the schema."""
        schema = self.schema
        rows = self._rows
        for ns, d in messages:
            if len(rows) >= ROWS_PER_BLOCK:
                self._parts.append(pd.DataFrame(rows))
                rows = self._rows = []
            t = ns * 1e-9
            if schema == "foxglove.PosesInFrame":
                for i, p in enumerate(d["poses"]):
                    rows.append(_pose_row(t, {"timestamp": d["timestamp"], "pose": p})
                                | {"index": i})
            elif schema == "lgvtool.ReflectorScan":
                base = {"t": t, "stamp": stamp_seconds(d.get("timestamp")),
                        "scan_period": d["scan_period"]}
                for o in d["observations"]:
                    rows.append(base | {"range": o["range"], "bearing": o["bearing"],
                                        "time_in_scan": o["time_in_scan"], "id": o["id"]})
            elif schema == "lgvtool.ReflectorMap":
                for r in d["reflectors"]:
                    rows.append({"t": t, "stamp": stamp_seconds(d.get("timestamp"))} | r)
            elif schema == "lgvtool.RawBytes":
                data = base64.b64decode(d["data"])
                rows.append({"t": t, "stamp": stamp_seconds(d.get("timestamp")),
                             "device": d["device"], "direction": d["direction"],
                             "size": len(data), "data": data})
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

    def table(self) -> pd.DataFrame:
        """The table of every message added, in the order added; call it once."""
        rows, parts = self._rows, self._parts
        self._rows, self._parts = [], []
        if parts:
            if rows:
                parts.append(pd.DataFrame(rows))
            return pd.concat(parts, ignore_index=True, sort=False)
        if not rows and self.schema == "lgvtool.ReflectorScan":
            return pd.DataFrame(columns=["t", "stamp", "scan_period", "range", "bearing",
                                         "time_in_scan", "id"])
        return pd.DataFrame(rows)


def table_builder(schema: str) -> PoseColumns | RowTable:
    """What fills the table of messages of ``schema`` a few at a time (``add``, then
    ``table``): the poses column by column, any other schema row by row."""
    return PoseColumns() if schema == "foxglove.PoseInFrame" else RowTable(schema)


class TopicTables:
    """The tables of some topics of a log (:meth:`LogReader.dataframe`'s), built from the
    chunks of a reading pass as they go by: a tap (:class:`lgvtool.log.reader.Tap`) of
    :meth:`LogReader.dataframes` or of the estimators' reading, so that a caller takes them
    in a pass it makes anyway. A topic whose chunks hold its messages out of log-time order is
    read again, in that order, by :meth:`tables`."""

    def __init__(self, reader: LogReader, topics: Iterable[str]) -> None:
        self.reader = reader
        #: the topics to be read (each once, in the order given)
        self.topics = list(dict.fromkeys(topics))
        self._schemas = {t: reader.schema_of(t) for t in self.topics}
        self._builders: dict[str, PoseColumns | RowTable | None] = {
            t: table_builder(s) for t, s in self._schemas.items()}
        self._last = dict.fromkeys(self.topics, -1 << 63)

    def add(self, block: RawBlock) -> None:
        """Take one chunk's messages (those of other topics are ignored).

        :raises LogFormatError: a message that does not match its topic's schema."""
        import orjson

        for topic in self.topics:
            found = block.get(topic)
            into = self._builders[topic]
            if found is None or into is None or not len(found[0]):
                continue
            t = found[0]
            if int(t[0]) < self._last[topic] or bool((np.diff(t) < 0).any()):
                self._builders[topic] = None  # read again in log-time order
                continue
            self._last[topic] = int(t[-1])
            try:
                into.add(zip(t.tolist(), map(orjson.loads, found[1]), strict=True))
            except (KeyError, TypeError, ValueError, AttributeError) as exc:
                raise decoding_error(self.reader.path, topic, self._schemas[topic],
                                     exc) from None

    def tables(self) -> dict[str, pd.DataFrame]:
        """Every topic's table (empty for a topic without messages); call it once."""
        out: dict[str, pd.DataFrame] = {}
        for topic, builder in self._builders.items():
            schema = self._schemas[topic]
            try:
                out[topic] = (to_dataframe(schema, self.reader.messages([topic]))
                              if builder is None else builder.table())
            except (KeyError, TypeError, ValueError, AttributeError) as exc:
                raise decoding_error(self.reader.path, topic, schema, exc) from None
        return out


def to_dataframe(schema: str, messages: Iterable[LogMessage]) -> pd.DataFrame:
    """Flatten messages of one schema into a DataFrame (see the module docstring), built a
    block of rows at a time (:func:`table_builder`)."""
    builder = table_builder(schema)
    builder.add((m.log_time_ns, m.data) for m in messages)
    return builder.table()
