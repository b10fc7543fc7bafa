"""What the evaluation reads from a log besides the estimates: the ground truth's poses, the
MCU frames' steering and the data-quality inputs, taken in the same pass as the estimators'
reading of a raw log or the reading of a replayed log's own estimates
(:class:`EvaluationInputs`, a :class:`lgvtool.log.reader.Tap`), so that evaluating a log
reads its chunks once.

Times in s since the epoch (the log time), positions in m, headings and steering in rad,
speeds in m/s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import orjson
from numpy.typing import NDArray

from lgvtool.errors import LgvError, LogFormatError, decoding_error
from lgvtool.evaluate.quality import DataQuality, QualityInputs
from lgvtool.log import topics as T
from lgvtool.log.frames import SteeringColumns, TopicTables
from lgvtool.trajectory import Trajectory

if TYPE_CHECKING:
    from lgvtool.log import LogReader
    from lgvtool.log.reader import RawBlock

__all__ = ["EvaluationInputs"]


class EvaluationInputs:
    """Handed each chunk's messages as the estimators' reading goes (:meth:`add`), it keeps
    the truth's poses, the steering and the data quality's inputs. The quality is None when
    its inputs cannot be read (as :func:`lgvtool.evaluate.quality.quality_of_log` gives None);
    a truth or MCU frame that does not match its schema is a :class:`LogFormatError`."""

    def __init__(self, reader: LogReader) -> None:
        self.reader = reader
        self._truth = TopicTables(reader, [T.TRUTH] if reader.has_topic(T.TRUTH) else [])
        self._steering = SteeringColumns()
        self._inputs: QualityInputs | None = QualityInputs(reader)
        try:
            reader.check_topics(self._inputs.topics)
        except LogFormatError:
            self._inputs = None
        quality_topics = self._inputs.topics if self._inputs is not None else []
        #: the topics to read (those of the log)
        self.topics = [t for t in (T.TRUTH, T.MCU_FRAME, *quality_topics) if reader.has_topic(t)]

    def add(self, block: RawBlock) -> None:
        """Take one chunk's messages (:data:`lgvtool.log.reader.RawBlock`)."""
        loads = orjson.loads
        self._truth.add(block)
        if T.MCU_FRAME in block:
            try:
                self._steering.add([loads(x) for x in block[T.MCU_FRAME][1]])
            except (TypeError, ValueError, AttributeError) as exc:
                raise decoding_error(self.reader.path, T.MCU_FRAME, "lgvtool.McuFrame",
                                     exc) from None
        if self._inputs is not None:
            try:
                self._inputs.add(block)
            except (KeyError, TypeError, ValueError, AttributeError):
                self._inputs = None

    def truth(self) -> Trajectory | None:
        """The truth's poses of O (t s since the epoch, x, y m, heading rad) as
        :meth:`LogReader.dataframe` gives them, cleaned (sorted, finite, one pose per time);
        None when the log has no message of truth. Call it once."""
        table = self._truth.tables().get(T.TRUTH)
        if table is None or table.empty:
            return None
        return Trajectory.from_frame(table, name="truth")

    def steering_columns(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Steering angle (rad, NaN where a frame has none) and absolute drive speed (m/s, 0
        where a frame has none) of every MCU frame, in stored order."""
        return self._steering.arrays()

    def quality(self, t0: float) -> DataQuality | None:
        """The data quality, times counted from ``t0`` (s since the epoch)."""
        if self._inputs is None:
            return None
        try:
            return self._inputs.quality(self.reader, t0)
        except (LgvError, OSError, ValueError, KeyError, TypeError, AttributeError):
            return None
